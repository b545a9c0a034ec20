#include "bounded_lm.h"

#include <fmt/format.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "dense_solve.h"
#include "lm_evaluator.h"

// The minimiser, in the steps of Ceres' TrustRegionMinimizer (docs/solver.md draws them): start
// (clamp into the box, first pass, first projection), then per iteration the binding set and its
// convergence tests, the reduced Gauss-Newton model, the trust-region step, the candidate point
// and its evaluation (with variable projection: the linear entries re-solved there, and the step
// extended when the model understated the gain), the radius update, and accept or reject. The
// passes over the pixels are the evaluator's (lm_evaluator.h), the dense solves dense_solve.h's,
// the model's structure model_structure.h's.
namespace shadefit::fit::internal {
namespace {

// Trust region (Nocedal and Wright 2006, Algorithm 4.1; Moré 1978): a step is accepted when
// the actual reduction is at least kMinRatio of the predicted one; the radius shrinks to a
// quarter of the step below ratio 0.25 and doubles above 0.75. The first radius is
// kInitialRadiusFactor times |D x0| (Moré's factor 100: the first Gauss-Newton step is usually
// good, and a rejected one costs only one pass). kMinRatio is Ceres' min_relative_decrease:
// with Moré's 1e-4, aluminium-rim's first step (roughness 0.5 to its floor 0.01, ratio 1.7e-4)
// was accepted into a basin of kd = 1 and no f0 (cost 3.3e5 against 0.14).
constexpr double kMinRatio = 1e-3;
// Variable projection: a step whose actual reduction exceeds the predicted one by this factor
// is extended along its direction, at most kMaxExtension times (SolveBoundedLm).
constexpr double kExtendRatio = 1.2;
constexpr double kMaxExtension = 8.0;
constexpr double kInitialRadiusFactor = 100.0;

// Entries within kActiveFraction of their box from a bound, with the gradient pointing out of
// it, are held (Bertsekas 1982's eps-active set: an entry creeping towards its bound is put on it
// instead of being approached geometrically). 1e-6 of the box is below every tolerance the fits
// are judged by (1% of a parameter).
constexpr double kActiveFraction = 1e-6;

// Variable projection (Golub and Pereyra 1973, "The differentiation of pseudo-inverses and
// nonlinear least squares problems whose variables separate", SIAM J. Numer. Anal. 10(2);
// with Kaufman's 1975 approximation of the reduced Jacobian, BIT 15). With the L2 loss and a
// fixed exposure the image is affine in the linear entries (LinearEntries: kd and f0 of ggx,
// kd and ks of the Blinn-Phong models), so for given nonlinear entries (roughness, shininess)
// their best values are a box-constrained linear least-squares problem whose normal equations
// are the Jacobian pass's own rows of J^T J and J^T r, solved exactly (BoxQp). The trust
// region then works on the nonlinear entries alone, with the Schur complement of the linear
// block (the Gauss-Newton model of the cost with the linear entries re-optimised), and every
// trial point is re-projected before it is judged. The valley that a joint step follows at
// ~1% per step when a highlight and the diffuse trade off (black-glossy-rim: kd and f0 falling
// together by 10x while roughness moves 10%) is then a one-dimensional problem.

// The unknowns the step moves at the current point: those not held on a bound (with variable
// projection the free linear ones apart, re-optimised along the step), and the projected
// gradient, the first-order optimality measure with bounds.
struct BindingSet {
  std::vector<int> varying, held_linear;
  double projected_gradient = 0;
};

// The Gauss-Newton model of the cost over the varying unknowns: h and g, Moré's scaling D of
// each, and |D x| over them.
struct ReducedModel {
  Eigen::MatrixXd h;
  Eigen::VectorXd g, scale;
  double x_norm = 0;
};

// A candidate point: the projected step to it, its pass, and whether that pass went stale (its
// g and h belong to the point before the linear entries moved).
struct Candidate {
  std::vector<double> x;
  Eigen::VectorXd step;
  double step_norm = 0;   // |D step| of the step computed.
  double step_taken = 0;  // |D step| of the step taken (longer where it was extended).
  Sums pass;
  bool stale = false;
};

class Minimizer {
 public:
  Minimizer(const BoundedLmProblem& problem, const BoundedLmOptions& options);
  BoundedLmSummary Minimize(std::vector<double>* y, double* e);

 private:
  bool Start(const std::vector<double>& y, double e);
  void StartRadius();
  bool Iterate();
  BindingSet FindBindingSet() const;
  ReducedModel Reduce(const BindingSet& binding) const;
  Candidate StepTo(const BindingSet& binding, const ReducedModel& model,
                   const Eigen::VectorXd& d) const;
  void Evaluate(Candidate* c);
  void Extend(const BindingSet& binding, const ReducedModel& model, Candidate* c);
  void UpdateRadius(const Candidate& c, double ratio);
  bool Accept(Candidate* c);
  void Trace(const Candidate& c, double ratio, double lambda, int free,
             double projected_gradient) const;
  bool ProjectLinear(Sums* pass, std::vector<double>* x) const;
  Sums JacobianAt(const std::vector<double>& x);
  void UpdateScale();
  double ScaleOf(int i) const { return scale_[i] > 0 ? scale_[i] : 1.0; }
  bool Stop(LmTermination termination) {
    summary_.termination = termination;
    return false;
  }

  const BoundedLmProblem& problem_;
  const BoundedLmOptions& options_;
  const Parametrization& param_;
  const int n_, N_;  // The model's entries; the unknowns, with the log exposure.
  const std::vector<Chunk> chunks_;
  const std::shared_ptr<const Geometry> geometry_;
  std::vector<double> lo_, hi_;  // Box of every unknown (the exposure is unbounded).
  std::vector<bool> unknown_, linear_;
  std::vector<int> linear_index_;
  bool varpro_ = false;
  std::vector<double> x_;  // [y, e].
  Sums at_;                // The Jacobian pass at x_.
  std::vector<double> scale_;
  double radius_ = 0;
  BoundedLmSummary summary_;
};

Minimizer::Minimizer(const BoundedLmProblem& problem, const BoundedLmOptions& options)
    : problem_(problem),
      options_(options),
      param_(*problem.param),
      n_(problem.param->size()),
      N_(problem.param->size() + 1),
      chunks_(Chunks(problem)),
      geometry_(GeometryOf(problem, chunks_)),
      lo_(N_),
      hi_(N_),
      unknown_(N_, false),
      linear_(ProjectedEntries(problem)),
      scale_(N_, 0.0) {
  for (int i = 0; i < n_; ++i) {
    BoxOf(param_, i, &lo_[i], &hi_[i]);
    unknown_[i] = !param_.entry(i).fixed;
  }
  lo_[n_] = -std::numeric_limits<double>::infinity();
  hi_[n_] = std::numeric_limits<double>::infinity();
  unknown_[n_] = problem.exposure_free;
  varpro_ = std::find(linear_.begin(), linear_.end(), true) != linear_.end();
  for (int i = 0; i < N_; ++i) {
    if (linear_[i]) linear_index_.push_back(i);
  }
}

Sums Minimizer::JacobianAt(const std::vector<double>& x) {
  ++summary_.jacobian_evaluations;
  return Jacobian(problem_, *geometry_, chunks_, std::vector<double>(x.begin(), x.begin() + n_),
                  x[n_]);
}

// Moves the linear entries of x to their exact optimum for the other entries, from the pass at
// x, and the pass with them (ShiftLinear); else updates only the pass's cost (exact: the cost
// is quadratic in them). Returns whether the pass is stale: its g and h belong to the old
// point, and a fresh pass is needed there.
bool Minimizer::ProjectLinear(Sums* pass, std::vector<double>* x) const {
  const int l = static_cast<int>(linear_index_.size());
  Eigen::MatrixXd h(l, l);
  Eigen::VectorXd g(l), z0(l), zl(l), zh(l);
  for (int a = 0; a < l; ++a) {
    const int i = linear_index_[a];
    g[a] = pass->g[i];
    z0[a] = (*x)[i];
    zl[a] = lo_[i];
    zh[a] = hi_[i];
    for (int b = 0; b < l; ++b) h(a, b) = pass->h[i * N_ + linear_index_[b]];
  }
  const Eigen::VectorXd z = BoxQp(h, g, z0, zl, zh);
  const Eigen::VectorXd d = z - z0;
  const double change = g.dot(d) + 0.5 * d.dot(h * d);
  if (!(change < 0)) return false;
  std::vector<double> delta(N_, 0.0);
  for (int a = 0; a < l; ++a) {
    (*x)[linear_index_[a]] = z[a];
    delta[linear_index_[a]] = d[a];
  }
  if (ShiftLinear(delta, pass)) return false;
  pass->cost += change;
  return true;
}

// The start point clamped into the box, its pass, and with variable projection its linear
// entries at their optimum; false (the summary says why) where the cost is not finite there.
bool Minimizer::Start(const std::vector<double>& y, double e) {
  x_ = y;
  x_.push_back(e);
  for (int i = 0; i < n_; ++i) {
    if (unknown_[i]) x_[i] = std::clamp(x_[i], lo_[i], hi_[i]);
  }
  at_ = JacobianAt(x_);
  summary_.initial_cost = summary_.final_cost = at_.cost;
  if (!at_.finite) return Stop(LmTermination::kNonFiniteStart);
  if (varpro_ && ProjectLinear(&at_, &x_)) {
    at_ = JacobianAt(x_);
    if (!at_.finite) return Stop(LmTermination::kNonFiniteJacobian);
  }
  return true;
}

// Moré's scaling: D_i = max over the iterations of |column i of J| (1 where it is 0).
void Minimizer::UpdateScale() {
  for (int i = 0; i < N_; ++i) scale_[i] = std::max(scale_[i], std::sqrt(at_.h[i * N_ + i]));
}

// kInitialRadiusFactor x |D x| over the unknowns the trust region steps, or the options' radius.
void Minimizer::StartRadius() {
  double radius = 0;
  for (int i = 0; i < N_; ++i) {
    if (unknown_[i] && !linear_[i]) radius += std::pow(ScaleOf(i) * x_[i], 2);
  }
  radius = std::sqrt(radius);
  radius_ = kInitialRadiusFactor * (radius > 0 ? radius : 1.0);
  if (options_.initial_radius > 0) radius_ = options_.initial_radius;
}

BindingSet Minimizer::FindBindingSet() const {
  BindingSet out;
  for (int i = 0; i < N_; ++i) {
    if (!unknown_[i]) continue;
    const double width = hi_[i] - lo_[i];
    const double eps = std::isfinite(width) ? kActiveFraction * width : 0.0;
    const double moved = std::clamp(x_[i] - at_.g[i], lo_[i], hi_[i]) - x_[i];
    out.projected_gradient = std::max(out.projected_gradient, std::abs(moved));
    const bool out_low = x_[i] <= lo_[i] + eps && at_.g[i] > 0;
    const bool out_high = x_[i] >= hi_[i] - eps && at_.g[i] < 0;
    if (!out_low && !out_high) (linear_[i] ? out.held_linear : out.varying).push_back(i);
  }
  return out;
}

ReducedModel Minimizer::Reduce(const BindingSet& binding) const {
  const std::vector<int>& varying = binding.varying;
  const int m = static_cast<int>(varying.size());
  ReducedModel out;
  out.h.resize(m, m);
  out.g.resize(m);
  out.scale.resize(m);
  for (int a = 0; a < m; ++a) {
    out.g[a] = at_.g[varying[a]];
    out.scale[a] = ScaleOf(varying[a]);
    out.x_norm += std::pow(out.scale[a] * x_[varying[a]], 2);
    for (int b = 0; b < m; ++b) out.h(a, b) = at_.h[varying[a] * N_ + varying[b]];
  }
  if (!binding.held_linear.empty()) {
    // The linear entries re-optimised along the step: the Schur complement of their block
    // (Kaufman's reduced Gauss-Newton matrix), g likewise.
    const std::vector<int>& held = binding.held_linear;
    const int l = static_cast<int>(held.size());
    Eigen::MatrixXd hll(l, l), hln(l, m);
    Eigen::VectorXd gl(l);
    for (int a = 0; a < l; ++a) {
      gl[a] = at_.g[held[a]];
      for (int b = 0; b < l; ++b) hll(a, b) = at_.h[held[a] * N_ + held[b]];
      for (int b = 0; b < m; ++b) hln(a, b) = at_.h[held[a] * N_ + varying[b]];
    }
    const Eigen::MatrixXd pinv = PsdPseudoInverse(hll).Matrix();
    out.h -= hln.transpose() * pinv * hln;
    out.g -= hln.transpose() * (pinv * gl);
    out.h = 0.5 * (out.h + out.h.transpose());
  }
  out.x_norm = std::sqrt(out.x_norm);
  return out;
}

// The trust-region step d, then the box: the model's prediction is taken at the projected step.
Candidate Minimizer::StepTo(const BindingSet& binding, const ReducedModel& model,
                            const Eigen::VectorXd& d) const {
  const int m = static_cast<int>(binding.varying.size());
  Candidate c;
  c.x = x_;
  c.step.resize(m);
  for (int a = 0; a < m; ++a) {
    const int i = binding.varying[a];
    c.x[i] = std::clamp(x_[i] + d[a], lo_[i], hi_[i]);
    c.step[a] = c.x[i] - x_[i];
  }
  c.step_norm = c.step_taken = model.scale.cwiseProduct(c.step).norm();
  return c;
}

// The candidate's cost; with variable projection after re-optimising the linear entries there,
// which needs that point's normal equations (a Jacobian pass, kept unless it went stale).
void Minimizer::Evaluate(Candidate* c) {
  if (varpro_) {
    c->pass = JacobianAt(c->x);
    if (c->pass.finite) c->stale = ProjectLinear(&c->pass, &c->x);
  } else {
    c->pass = Cost(problem_, *geometry_, chunks_,
                   std::vector<double>(c->x.begin(), c->x.begin() + n_), c->x[n_]);
    ++summary_.residual_evaluations;
  }
}

// The reduction beat the model's by kExtendRatio or more: the reduced Gauss-Newton matrix
// overstates the curvature (a large-residual fit, such as GGX to a measured material, where
// J^T J misses the residuals' own curvature), and full steps converge only linearly
// (alum-bronze under the key light: ratio 1.65 at every one of 49 steps). The parabola through
// the cost at 0 and 1 with the slope g.step at 0 (the projected cost's derivative: the linear
// entries sit at their optimum) puts its minimum at t > 1; the step is extended there once, and
// kept if it is lower still (a quadratic-interpolation line search along the step, Nocedal and
// Wright 2006, sec. 3.5).
void Minimizer::Extend(const BindingSet& binding, const ReducedModel& model, Candidate* c) {
  const double slope = model.g.dot(c->step);
  const double curvature = c->pass.cost - at_.cost - slope;
  if (!(slope < 0 && curvature > 0)) return;
  const double t = std::min(kMaxExtension, -slope / (2 * curvature));
  if (!(t > 1.5)) return;
  const int m = static_cast<int>(binding.varying.size());
  std::vector<double> longer = x_;
  for (int a = 0; a < m; ++a) {
    const int i = binding.varying[a];
    longer[i] = std::clamp(x_[i] + t * c->step[a], lo_[i], hi_[i]);
  }
  Sums longer_pass = JacobianAt(longer);
  if (!longer_pass.finite) return;
  const bool longer_stale = ProjectLinear(&longer_pass, &longer);
  if (!(longer_pass.cost < c->pass.cost)) return;
  Eigen::VectorXd taken(m);
  for (int a = 0; a < m; ++a) taken[a] = longer[binding.varying[a]] - x_[binding.varying[a]];
  c->step_taken = model.scale.cwiseProduct(taken).norm();
  c->x = std::move(longer);
  c->pass = std::move(longer_pass);
  c->stale = longer_stale;
}

// The radius update on the ratio of the computed step (trust region, above).
void Minimizer::UpdateRadius(const Candidate& c, double ratio) {
  if (!c.pass.finite || ratio < 0.25) {
    radius_ = 0.25 * std::min(radius_, c.step_norm);
  } else if (ratio > 0.75) {
    radius_ = std::max(radius_, 2.0 * c.step_taken);
  }
}

// Moves to the candidate; false (the summary says why) where the solve ends there.
bool Minimizer::Accept(Candidate* c) {
  x_ = c->x;
  const double previous = at_.cost;
  if (varpro_ && !c->stale) {
    at_ = std::move(c->pass);
  } else {
    at_ = JacobianAt(x_);
  }
  if (!at_.finite) return Stop(LmTermination::kNonFiniteJacobian);
  UpdateScale();
  if (previous - at_.cost <= options_.function_tolerance * previous) {
    return Stop(LmTermination::kFunctionTolerance);
  }
  return true;
}

// SHADEFIT_FIT_TRACE=1: one line per step (debugging aid, as the Ceres path's table).
void Minimizer::Trace(const Candidate& c, double ratio, double lambda, int free,
                      double projected_gradient) const {
  fmt::print("lm {:3d} cost {:.9g} trial {:.9g} ratio {:.3g} radius {:.3g} lambda {:.3g} "
             "free {} |g| {:.3g}:",
             summary_.iterations, at_.cost, c.pass.cost, ratio, radius_, lambda, free,
             projected_gradient);
  for (int i = 0; i < N_; ++i) {
    fmt::print(" {:.4g}", i < n_ && param_.entry(i).lm_log ? std::exp(c.x[i]) : c.x[i]);
  }
  fmt::print("\n");
}

// One iteration; false when the solve stops (the summary says why).
bool Minimizer::Iterate() {
  const BindingSet binding = FindBindingSet();
  if (binding.projected_gradient <= options_.gradient_tolerance) {
    return Stop(LmTermination::kGradientTolerance);
  }
  // Every unknown held on a bound with its gradient pointing outwards (with variable
  // projection: every nonlinear one, the linear ones at their optimum): a KKT point.
  if (binding.varying.empty()) return Stop(LmTermination::kEveryUnknownOnBound);
  const ReducedModel model = Reduce(binding);
  const double tolerance =
      options_.parameter_tolerance * (model.x_norm + options_.parameter_tolerance);
  if (radius_ <= tolerance) return Stop(LmTermination::kTrustRegionTolerance);
  ++summary_.iterations;
  Eigen::VectorXd d;
  double lambda = 0;
  if (!TrustRegionStep(model.h, model.g, model.scale, radius_, &d, &lambda)) {
    radius_ *= 0.25;
    return true;
  }
  Candidate c = StepTo(binding, model, d);
  if (c.step_norm <= tolerance) return Stop(LmTermination::kParameterTolerance);
  const double predicted = -(model.g.dot(c.step) + 0.5 * c.step.dot(model.h * c.step));
  // The Gauss-Newton step itself (inside the region) is predicted to gain less than the
  // function tolerance: the accepted-step test would stop after evaluating it (one more pass,
  // two with variable projection, to confirm what the model says). MINPACK's lmder stops on the
  // same predicted relative reduction (Moré, Garbow and Hillstrom 1980, "User guide for
  // MINPACK-1", ANL-80-74, sec. 2.3: ftol, both actual and predicted; the actual one is that of
  // the step that led here).
  if (lambda == 0 && predicted >= 0 && predicted <= options_.function_tolerance * at_.cost) {
    return Stop(LmTermination::kPredictedReduction);
  }
  Evaluate(&c);
  const double ratio = predicted > 0 ? (at_.cost - c.pass.cost) / predicted : -1.0;
  if (varpro_ && c.pass.finite && ratio > kExtendRatio) Extend(binding, model, &c);
  if (options_.trace) {
    Trace(c, ratio, lambda, static_cast<int>(binding.varying.size()), binding.projected_gradient);
  }
  UpdateRadius(c, ratio);
  const double actual = at_.cost - c.pass.cost;
  if (c.pass.finite && actual > 0 && ratio > kMinRatio) return Accept(&c);
  return true;
}

BoundedLmSummary Minimizer::Minimize(std::vector<double>* y, double* e) {
  if (!Start(*y, *e)) return summary_;
  UpdateScale();
  StartRadius();
  summary_.termination = LmTermination::kMaxIterations;
  while (summary_.iterations < options_.max_iterations && Iterate()) {
  }
  summary_.final_cost = at_.cost;
  std::copy(x_.begin(), x_.begin() + n_, y->begin());
  *e = x_[n_];
  summary_.final_radius = radius_;
  return summary_;
}

}  // namespace

std::string_view LmTerminationMessage(LmTermination termination) {
  switch (termination) {
    case LmTermination::kMaxIterations: return "maximum iterations reached";
    case LmTermination::kGradientTolerance: return "gradient tolerance reached";
    case LmTermination::kEveryUnknownOnBound: return "every unknown on a bound";
    case LmTermination::kTrustRegionTolerance: return "trust region below the parameter tolerance";
    case LmTermination::kParameterTolerance: return "parameter tolerance reached";
    case LmTermination::kPredictedReduction:
      return "predicted reduction below the function tolerance";
    case LmTermination::kFunctionTolerance: return "function tolerance reached";
    case LmTermination::kNonFiniteStart: return "non-finite cost at the start point";
    case LmTermination::kNonFiniteJacobian: return "non-finite Jacobian";
  }
  return "unknown termination";
}

bool BoundedLmSummary::converged() const {
  switch (termination) {
    case LmTermination::kGradientTolerance:
    case LmTermination::kEveryUnknownOnBound:
    case LmTermination::kTrustRegionTolerance:
    case LmTermination::kParameterTolerance:
    case LmTermination::kPredictedReduction:
    case LmTermination::kFunctionTolerance:
      return true;
    case LmTermination::kMaxIterations:
    case LmTermination::kNonFiniteStart:
    case LmTermination::kNonFiniteJacobian:
      return false;
  }
  return false;
}

std::vector<bool> ProjectedEntries(const BoundedLmProblem& problem) {
  const Parametrization& param = *problem.param;
  const int n = param.size();
  std::vector<bool> linear(n + 1, false);
  if (!ProjectionApplies(problem.loss, problem.exposure_free)) return linear;
  const std::vector<bool> model_linear = LinearEntries(problem.model);
  bool any_linear = false, any_nonlinear = false;
  for (int i = 0; i < n; ++i) {
    if (param.entry(i).fixed) continue;
    linear[i] = model_linear[i] && !param.entry(i).lm_log;
    (linear[i] ? any_linear : any_nonlinear) = true;
  }
  if (!any_linear || !any_nonlinear) std::fill(linear.begin(), linear.end(), false);
  return linear;
}

BoundedLmSummary SolveBoundedLm(const BoundedLmProblem& problem, const BoundedLmOptions& options,
                                std::vector<double>* y, double* e) {
  return Minimizer(problem, options).Minimize(y, e);
}

}  // namespace shadefit::fit::internal
