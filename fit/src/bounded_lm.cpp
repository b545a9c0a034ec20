#include "bounded_lm.h"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <ceres/jet.h>

#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <limits>
#include <thread>
#include <type_traits>

namespace shadefit::fit::internal {
namespace {

// Pixels per partial sum. The sums of a pass are taken per chunk and then added in chunk order,
// so the result does not depend on how many threads ran the chunks.
constexpr int kChunkPixels = 1024;

struct Chunk {
  int span = 0, begin = 0, count = 0;
};

std::vector<Chunk> Chunks(const BoundedLmProblem& problem) {
  std::vector<Chunk> out;
  for (int s = 0; s < static_cast<int>(problem.spans.size()); ++s) {
    for (int k = 0; k < problem.spans[s].count; k += kChunkPixels) {
      out.push_back({s, k, std::min(kChunkPixels, problem.spans[s].count - k)});
    }
  }
  return out;
}

// Runs fn(chunk index) for every chunk on `threads` threads (chunk c on thread c % threads).
template <typename Fn>
void ForEachChunk(int chunks, int threads, const Fn& fn) {
  threads = std::max(1, std::min(threads, chunks));
  auto work = [&](int t) {
    for (int c = t; c < chunks; c += threads) fn(c);
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(work, t);
  work(0);
  for (std::thread& th : pool) th.join();
}

// One pass's sums: cost = 0.5 sum r^2, g = J^T r, h = J^T J (row-major, N x N), over the
// unknowns [y_0 .. y_{n-1}, e].
struct Sums {
  double cost = 0;
  std::vector<double> g, h;
  bool finite = true;
};

// Whether the bounded LM works on log p for entry i (else on p itself, in [exp(lower),
// exp(upper)] for the parametrisation's log rows). The sine path fits every kMultiplicative row
// in log space because its linear-space steps stranded f0 at 0 (residuals.cpp); with bounds held
// by the active set a specular scale on its floor is released as soon as its gradient turns, and
// the image is linear in f0 and in the normalised ks (Schlick's F, the lobe's scale): in p the
// Gauss-Newton model of them is exact, in log p it is not, and a valley along f0 and kd was
// followed at ~1% per step (black-glossy-rim: cost 0.13 after 200 iterations in log f0). The
// widths (roughness: the peak goes as 1 / roughness^4) and the table's log rows (shininess,
// classic ks, spanning decades) stay in log space.
bool InBoxLog(const Parametrization& param, int i) {
  const EntryMap& e = param.entry(i);
  if (!e.log) return false;
  const ParamSpec& spec = param.model().SpecOfEntry(i);
  return spec.log_scale || (spec.roles & kWidthParam) != 0;
}

// Box of entry i in the bounded LM's coordinates.
void BoxOf(const Parametrization& param, int i, double* lo, double* hi) {
  const EntryMap& e = param.entry(i);
  const bool linear_of_log = e.log && !InBoxLog(param, i);
  *lo = linear_of_log ? std::exp(e.lower) : e.lower;
  *hi = linear_of_log ? std::exp(e.upper) : e.upper;
}

template <typename T>
T Compress(Loss loss, const T& x) {
  return CompressRadiance(loss, x);
}

// Natural parameters of box coordinates y (fixed entries: their value).
template <typename T>
void NaturalOfBox(const Parametrization& param, const T* y, T* p) {
  using std::exp;
  for (int i = 0; i < param.size(); ++i) {
    const EntryMap& e = param.entry(i);
    if (e.fixed) {
      p[i] = T(e.fixed_value);
    } else {
      p[i] = InBoxLog(param, i) ? exp(y[i]) : y[i];
    }
  }
}

// Cost only (no derivatives): doubles through the twin.
template <int kParams>
Sums CostPass(const BoundedLmProblem& problem, const std::vector<Chunk>& chunks,
              const std::vector<double>& y, double e) {
  double p[kParams];
  NaturalOfBox(*problem.param, y.data(), p);
  const double scale = std::exp(e);
  std::vector<double> partial(chunks.size(), 0.0);
  ForEachChunk(static_cast<int>(chunks.size()), problem.threads, [&](int ci) {
    const Chunk& c = chunks[ci];
    const PixelSpan& s = problem.spans[c.span];
    double sum = 0;
    for (int k = c.begin; k < c.begin + c.count; ++k) {
      double rgb[3];
      ShadePoint(problem.model, p, s.points[k], rgb);
      for (int ch = 0; ch < 3; ++ch) {
        const double r = Compress(problem.loss, scale * rgb[ch]) - s.targets[3 * k + ch];
        sum += r * r;
      }
    }
    partial[ci] = sum;
  });
  Sums out;
  for (double v : partial) out.cost += v;
  out.cost *= 0.5;
  out.finite = std::isfinite(out.cost);
  return out;
}

// One chunk's sums of the Jacobian pass (N unknowns). At namespace scope: gcc 12 crashes on a
// local class with Eigen members inside the function template.
template <int N>
struct JetPartial {
  double cost = 0;
  Eigen::Matrix<double, N, 1> g = Eigen::Matrix<double, N, 1>::Zero();
  Eigen::Matrix<double, N, N> h = Eigen::Matrix<double, N, N>::Zero();
};

// Cost, gradient and Gauss-Newton matrix in one pass: AutoDiff over the parameters only (the
// geometry enters as plain numbers), each residual's Jacobian row folded into J^T J at once.
template <int kParams>
Sums JacobianPass(const BoundedLmProblem& problem, const std::vector<Chunk>& chunks,
                  const std::vector<double>& y, double e) {
  constexpr int N = kParams + 1;  // The model block and the log exposure.
  using Jet = ceres::Jet<double, N>;
  using Vec = Eigen::Matrix<double, N, 1>;
  using Mat = Eigen::Matrix<double, N, N>;
  Jet yj[kParams], p[kParams];
  for (int i = 0; i < kParams; ++i) yj[i] = Jet(y[i], i);
  NaturalOfBox(*problem.param, yj, p);
  const Jet scale = problem.exposure_free ? exp(Jet(e, kParams)) : Jet(std::exp(e));
  using Partial = JetPartial<N>;
  std::vector<Partial> partial(chunks.size());
  ForEachChunk(static_cast<int>(chunks.size()), problem.threads, [&](int ci) {
    const Chunk& c = chunks[ci];
    const PixelSpan& s = problem.spans[c.span];
    Partial& out = partial[ci];
    for (int k = c.begin; k < c.begin + c.count; ++k) {
      Jet rgb[3];
      ShadePoint(problem.model, p, s.points[k], rgb);
      for (int ch = 0; ch < 3; ++ch) {
        const Jet r = Compress(problem.loss, scale * rgb[ch]) - Jet(s.targets[3 * k + ch]);
        out.cost += r.a * r.a;
        out.g.noalias() += r.a * r.v;
        out.h.template selfadjointView<Eigen::Upper>().rankUpdate(r.v);
      }
    }
  });
  Vec g = Vec::Zero();
  Mat h = Mat::Zero();
  double cost = 0;
  for (const Partial& q : partial) {
    cost += q.cost;
    g += q.g;
    h += q.h;
  }
  const Mat full = h.template selfadjointView<Eigen::Upper>();
  Sums out;
  out.cost = 0.5 * cost;
  out.g.assign(g.data(), g.data() + N);
  out.h.assign(full.data(), full.data() + N * N);  // Symmetric: layout does not matter.
  out.finite = std::isfinite(out.cost) && g.allFinite() && full.allFinite();
  return out;
}

template <typename Fn>
auto Dispatch(ModelId model, const Fn& fn) {
  return VisitModel(model, [&](auto tag) {
    constexpr int kParams = decltype(tag)::template Of<double, double>::kParamCount;
    return fn(std::integral_constant<int, kParams>{});
  });
}

Sums Cost(const BoundedLmProblem& problem, const std::vector<Chunk>& chunks,
          const std::vector<double>& y, double e) {
  return Dispatch(problem.model,
                  [&](auto k) { return CostPass<decltype(k)::value>(problem, chunks, y, e); });
}

Sums Jacobian(const BoundedLmProblem& problem, const std::vector<Chunk>& chunks,
              const std::vector<double>& y, double e) {
  return Dispatch(problem.model,
                  [&](auto k) { return JacobianPass<decltype(k)::value>(problem, chunks, y, e); });
}

// Trust region (Nocedal and Wright 2006, Algorithm 4.1; Moré 1978): a step is accepted when
// the actual reduction is at least kMinRatio of the predicted one; the radius shrinks to a
// quarter of the step below ratio 0.25 and doubles above 0.75. The first radius is
// kInitialRadiusFactor times |D x0| (Moré's factor 100: the first Gauss-Newton step is usually
// good, and a rejected one costs only a cost pass).
constexpr double kMinRatio = 1e-4;
constexpr double kInitialRadiusFactor = 100.0;

// Moré (1978, "The Levenberg-Marquardt algorithm: implementation and theory", Lecture Notes in
// Mathematics 630), sec. 2-5: the step minimises the Gauss-Newton model |J d + r|^2 subject to
// |D d| <= radius, D the column norms of J (non-decreasing over the iterations: the scaling that
// makes the method invariant to the units of each unknown; scipy's x_scale='jac' is the same
// idea). Inside the region the answer is the Gauss-Newton step itself (lambda = 0): unlike a
// damping that is always applied (Ceres' LM, D / radius added to J^T J), a valley whose
// curvature is tiny along one direction is crossed in one step, not at the pace of the damping.
// Else lambda > 0 with |D d(lambda)| = radius, found by bisection in log lambda between 0 and
// |D^-1 g| / radius (where |D d| <= radius is guaranteed); <= 12 unknowns, so each trial is a
// Cholesky of a 12 x 12 matrix.
bool TrustRegionStep(const Eigen::MatrixXd& h, const Eigen::VectorXd& g,
                     const Eigen::VectorXd& scale, double radius, Eigen::VectorXd* d,
                     double* lambda_out) {
  const int m = static_cast<int>(g.size());
  auto solve = [&](double lambda, Eigen::VectorXd* out) {
    Eigen::MatrixXd a = h;
    for (int i = 0; i < m; ++i) a(i, i) += lambda * scale[i] * scale[i];
    const Eigen::LLT<Eigen::MatrixXd> llt(a);
    if (llt.info() != Eigen::Success) return false;
    *out = llt.solve(-g);
    return out->allFinite();
  };
  auto norm = [&](const Eigen::VectorXd& v) { return scale.cwiseProduct(v).norm(); };
  *lambda_out = 0;
  if (solve(0.0, d) && norm(*d) <= 1.1 * radius) return true;
  double hi = scale.cwiseInverse().cwiseProduct(g).norm() / radius;
  if (!(hi > 0) || !std::isfinite(hi)) return false;
  Eigen::VectorXd best;
  if (!solve(hi, &best)) return false;
  double lo = 0;
  for (int it = 0; it < 60; ++it) {
    const double mid = lo > 0 ? std::sqrt(lo * hi) : hi * 1e-4;
    Eigen::VectorXd trial;
    if (!solve(mid, &trial) || norm(trial) > 1.1 * radius) {
      lo = mid;
      continue;
    }
    hi = mid;
    best = trial;
    if (norm(trial) >= 0.9 * radius) break;
    if (lo > 0 && hi / lo < 1.0 + 1e-6) break;
  }
  *d = best;
  *lambda_out = hi;
  return true;
}

// Entries within kActiveFraction of their box from a bound, with the gradient pointing out of
// it, are held (Bertsekas 1982's eps-active set: an entry creeping towards its bound is put on it
// instead of being approached geometrically). 1e-6 of the box is below every tolerance the fits
// are judged by (1% of a parameter).
constexpr double kActiveFraction = 1e-6;

}  // namespace

std::vector<double> BoxOfInternal(const Parametrization& param, const std::vector<double>& u) {
  std::vector<double> y(u.size());
  for (int i = 0; i < param.size(); ++i) {
    const EntryMap& e = param.entry(i);
    y[i] = e.lower + 0.5 * (e.upper - e.lower) * (std::sin(u[i]) + 1.0);
    y[i] = std::clamp(y[i], e.lower, e.upper);
    if (e.log && !InBoxLog(param, i)) y[i] = std::exp(y[i]);
  }
  return y;
}

std::vector<double> InternalOfBox(const Parametrization& param, const std::vector<double>& y) {
  std::vector<double> u(y.size());
  for (int i = 0; i < param.size(); ++i) {
    const EntryMap& e = param.entry(i);
    const double box = e.log && !InBoxLog(param, i) ? std::log(y[i]) : y[i];
    u[i] = Parametrization::FromBox(e, box);
  }
  return u;
}

double BoundedLmCost(const BoundedLmProblem& problem, const std::vector<double>& y, double e) {
  const Sums s = Cost(problem, Chunks(problem), y, e);
  return s.finite ? s.cost : std::numeric_limits<double>::quiet_NaN();
}

double BoundedLmNormalEquations(const BoundedLmProblem& problem, const std::vector<double>& y,
                                double e, std::vector<double>* g, std::vector<double>* h) {
  Sums s = Jacobian(problem, Chunks(problem), y, e);
  *g = std::move(s.g);
  *h = std::move(s.h);
  return s.finite ? s.cost : std::numeric_limits<double>::quiet_NaN();
}

BoundedLmSummary SolveBoundedLm(const BoundedLmProblem& problem, const BoundedLmOptions& options,
                                std::vector<double>* y_io, double* e_io) {
  const Parametrization& param = *problem.param;
  const int n = param.size();
  const int N = n + 1;
  const std::vector<Chunk> chunks = Chunks(problem);
  BoundedLmSummary summary;

  // x = [y, e]; box of every unknown (the exposure is unbounded).
  std::vector<double> x(*y_io), lo(N), hi(N);
  x.push_back(*e_io);
  std::vector<bool> unknown(N, false);
  for (int i = 0; i < n; ++i) {
    BoxOf(param, i, &lo[i], &hi[i]);
    unknown[i] = !param.entry(i).fixed;
    if (unknown[i]) x[i] = std::clamp(x[i], lo[i], hi[i]);
  }
  lo[n] = -std::numeric_limits<double>::infinity();
  hi[n] = std::numeric_limits<double>::infinity();
  unknown[n] = problem.exposure_free;

  auto split = [&](const std::vector<double>& v) {
    return std::vector<double>(v.begin(), v.begin() + n);
  };
  Sums at = Jacobian(problem, chunks, split(x), x[n]);
  ++summary.jacobian_evaluations;
  summary.initial_cost = summary.final_cost = at.cost;
  if (!at.finite) {
    summary.failed = true;
    summary.message = "non-finite cost at the start point";
    return summary;
  }

  const bool trace = std::getenv("SHADEFIT_FIT_TRACE") != nullptr;
  // Moré's scaling: D_i = max over the iterations of |column i of J| (1 where it is 0).
  std::vector<double> scale(N, 0.0);
  auto update_scale = [&] {
    for (int i = 0; i < N; ++i) scale[i] = std::max(scale[i], std::sqrt(at.h[i * N + i]));
  };
  auto scale_of = [&](int i) { return scale[i] > 0 ? scale[i] : 1.0; };
  update_scale();
  double radius = 0;
  for (int i = 0; i < N; ++i) {
    if (unknown[i]) radius += std::pow(scale_of(i) * x[i], 2);
  }
  radius = std::sqrt(radius);
  radius = kInitialRadiusFactor * (radius > 0 ? radius : 1.0);
  summary.message = "maximum iterations reached";
  while (summary.iterations < options.max_iterations) {
    // Binding set and projected gradient (the first-order optimality measure with bounds).
    std::vector<int> varying;
    double projected_gradient = 0;
    for (int i = 0; i < N; ++i) {
      if (!unknown[i]) continue;
      const double width = hi[i] - lo[i];
      const double eps = std::isfinite(width) ? kActiveFraction * width : 0.0;
      const double moved = std::clamp(x[i] - at.g[i], lo[i], hi[i]) - x[i];
      projected_gradient = std::max(projected_gradient, std::abs(moved));
      const bool out_low = x[i] <= lo[i] + eps && at.g[i] > 0;
      const bool out_high = x[i] >= hi[i] - eps && at.g[i] < 0;
      if (!out_low && !out_high) varying.push_back(i);
    }
    if (projected_gradient <= options.gradient_tolerance) {
      summary.converged = true;
      summary.message = "gradient tolerance reached";
      break;
    }
    if (varying.empty()) {
      // Every unknown is held on a bound with its gradient pointing outwards: a KKT point.
      summary.converged = true;
      summary.message = "every unknown on a bound";
      break;
    }
    const int m = static_cast<int>(varying.size());
    Eigen::MatrixXd h(m, m);
    Eigen::VectorXd g(m), d_scale(m);
    double x_norm = 0;
    for (int a = 0; a < m; ++a) {
      g[a] = at.g[varying[a]];
      d_scale[a] = scale_of(varying[a]);
      x_norm += std::pow(d_scale[a] * x[varying[a]], 2);
      for (int b = 0; b < m; ++b) h(a, b) = at.h[varying[a] * N + varying[b]];
    }
    x_norm = std::sqrt(x_norm);
    if (radius <= options.parameter_tolerance * (x_norm + options.parameter_tolerance)) {
      summary.converged = true;
      summary.message = "trust region below the parameter tolerance";
      break;
    }
    ++summary.iterations;
    Eigen::VectorXd d;
    double lambda = 0;
    if (!TrustRegionStep(h, g, d_scale, radius, &d, &lambda)) {
      radius *= 0.25;
      continue;
    }
    // Projected trial point (the reduced step, then the box); the model's prediction is taken
    // at the projected step.
    std::vector<double> trial = x;
    Eigen::VectorXd step(m);
    for (int a = 0; a < m; ++a) {
      const int i = varying[a];
      trial[i] = std::clamp(x[i] + d[a], lo[i], hi[i]);
      step[a] = trial[i] - x[i];
    }
    const double step_norm = d_scale.cwiseProduct(step).norm();
    if (step_norm <= options.parameter_tolerance * (x_norm + options.parameter_tolerance)) {
      summary.converged = true;
      summary.message = "parameter tolerance reached";
      break;
    }
    const double predicted = -(g.dot(step) + 0.5 * step.dot(h * step));
    const Sums trial_cost = Cost(problem, chunks, split(trial), trial[n]);
    ++summary.residual_evaluations;
    const double actual = at.cost - trial_cost.cost;
    const double ratio = predicted > 0 ? actual / predicted : -1.0;
    if (trace) {
      // SHADEFIT_FIT_TRACE=1: one line per step (debugging aid, as the Ceres path's table).
      fmt::print("lm {:3d} cost {:.9g} trial {:.9g} ratio {:.3g} radius {:.3g} lambda {:.3g} "
                 "free {} |g| {:.3g}:",
                 summary.iterations, at.cost, trial_cost.cost, ratio, radius, lambda, m,
                 projected_gradient);
      for (int i = 0; i < N; ++i) {
        fmt::print(" {:.4g}", i < n && InBoxLog(param, i) ? std::exp(trial[i]) : trial[i]);
      }
      fmt::print("\n");
    }
    if (!trial_cost.finite || ratio < 0.25) {
      radius = 0.25 * std::min(radius, step_norm);
    } else if (ratio > 0.75) {
      radius = std::max(radius, 2.0 * step_norm);
    }
    if (trial_cost.finite && actual > 0 && ratio > kMinRatio) {
      x = trial;
      const double previous = at.cost;
      at = Jacobian(problem, chunks, split(x), x[n]);
      ++summary.jacobian_evaluations;
      if (!at.finite) {
        summary.message = "non-finite Jacobian";
        break;
      }
      update_scale();
      if (previous - at.cost <= options.function_tolerance * previous) {
        summary.converged = true;
        summary.message = "function tolerance reached";
        break;
      }
    }
  }
  summary.final_cost = at.cost;
  std::copy(x.begin(), x.begin() + n, y_io->begin());
  *e_io = x[n];
  return summary;
}

}  // namespace shadefit::fit::internal
