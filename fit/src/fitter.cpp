#include "shadefit/fit/fitter.h"

#include <ceres/ceres.h>
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cmath>
#include <memory>
#include <numbers>
#include <numeric>

#include "prepared_reference.h"
#include "shadefit/fit/residuals.h"
#include "shadefit/render/error.h"
#include "shadefit/render/files.h"

namespace shadefit::fit {
using internal::AttachQuadrature;
using internal::Prepare;
using internal::PreparedReference;
using internal::ProposalAlphas;
using internal::RendererHolder;
using internal::SubsampleForEnvironment;

Loss ParseLoss(const std::string& name) {
  if (name == "l2") return Loss::kL2;
  if (name == "log") return Loss::kLog;
  if (name == "cuberoot") return Loss::kCubeRoot;
  if (name == "huber") return Loss::kHuber;
  if (name == "cauchy") return Loss::kCauchy;
  throw Error("", "--loss",
              fmt::format("unknown loss '{}'{} (known: l2, log, cuberoot, huber, cauchy)", name,
                          DidYouMean(name, {"l2", "log", "cuberoot", "huber", "cauchy"})));
}

std::string LossName(Loss loss) {
  switch (loss) {
    case Loss::kL2: return "l2";
    case Loss::kLog: return "log";
    case Loss::kCubeRoot: return "cuberoot";
    case Loss::kHuber: return "huber";
    case Loss::kCauchy: return "cauchy";
  }
  return "?";
}

DerivativePath ParsePath(const std::string& name) {
  if (name == "auto") return DerivativePath::kAuto;
  if (name == "gbuffer") return DerivativePath::kGBuffer;
  if (name == "gl") return DerivativePath::kGl;
  throw Error("", "--path", fmt::format("unknown path '{}' (known: auto, gbuffer, gl)", name));
}

std::string PathName(DerivativePath path) {
  switch (path) {
    case DerivativePath::kAuto: return "auto";
    case DerivativePath::kGBuffer: return "gbuffer";
    case DerivativePath::kGl: return "gl";
  }
  return "?";
}

Exposure ParseExposure(const std::string& name) {
  if (name == "fixed") return Exposure::kFixed;
  if (name == "free") return Exposure::kFree;
  throw Error("", "--exposure", fmt::format("unknown exposure '{}' (known: fixed, free)", name));
}

namespace {

bool IsRobust(Loss loss) { return loss == Loss::kHuber || loss == Loss::kCauchy; }

struct SolveSetup {
  const Parametrization* param = nullptr;
  bool gl = false;
  int threads = 2;
};

double Mean(const std::vector<double>& v) {
  return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / v.size();
}

// Which free entries lie in the numerical null space of J at the optimum. J is taken in the
// internal coordinates u, where every column means "move this entry through a comparable part
// of its box" (the sine transform maps the whole box to u in [-pi/2, pi/2]), so column sizes
// compare across entries without units. An eigenvector of J^T J with eigenvalue below
// kNullEigen * max marks every entry with a component above kNullComponent as undetermined:
// exact degeneracies (a grey dielectric in ggx-metallic: base, metallic and f0_dielectric trade
// off) and entries whose effect vanishes (f0_dielectric of a pure metal).
constexpr double kNullEigen = 1e-12;
constexpr double kNullComponent = 0.1;

std::vector<bool> UndeterminedColumns(const ceres::CRSMatrix& jacobian) {
  const int n = jacobian.num_cols;
  Eigen::MatrixXd jtj = Eigen::MatrixXd::Zero(n, n);
  for (int r = 0; r < jacobian.num_rows; ++r) {
    for (int a = jacobian.rows[r]; a < jacobian.rows[r + 1]; ++a) {
      for (int b = jacobian.rows[r]; b < jacobian.rows[r + 1]; ++b) {
        jtj(jacobian.cols[a], jacobian.cols[b]) += jacobian.values[a] * jacobian.values[b];
      }
    }
  }
  std::vector<bool> undetermined(n, false);
  if (n == 0) return undetermined;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(jtj);
  const double max_eigen = eig.eigenvalues().maxCoeff();
  for (int k = 0; k < n; ++k) {
    if (eig.eigenvalues()[k] > kNullEigen * max_eigen) continue;
    for (int i = 0; i < n; ++i) {
      if (std::abs(eig.eigenvectors()(i, k)) > kNullComponent) undetermined[i] = true;
    }
  }
  return undetermined;
}

}  // namespace

FitResult Fit(const FitProblem& problem, const FitOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const ModelInfo& model = FindModel(problem.model);
  const Parametrization param(model, problem.fixed);
  if (problem.references.empty()) throw Error("", "--ref", "no reference given");
  if (options.starts < 1) throw Error("", "--starts", "must be >= 1");
  if (param.FreeCount() == 0 && options.exposure == Exposure::kFixed) {
    throw Error("", "--fix", "every parameter is fixed (and the exposure): nothing to fit");
  }

  FitResult result;
  result.model = model.name;
  result.loss = LossName(options.loss);
  result.starts = options.starts;
  result.seed = options.seed;
  result.exposure_free = options.exposure == Exposure::kFree;

  // --- References: G-buffers, valid pixels, derivative path. -----------------------------------
  RendererHolder holder(options.renderer);
  Renderer& renderer = *holder.renderer;
  std::vector<PreparedReference> refs;
  bool twin_ok = true;
  for (const FitReference& ref : problem.references) {
    refs.push_back(Prepare(ref, renderer, options.environment_samples, &result.gbuffer_renders));
    twin_ok = twin_ok && TwinSupportsScene(ref.scene);
  }
  // The twin covers every scene: environment and uniform light through its quadrature.
  DerivativePath path = options.path;
  if (path == DerivativePath::kAuto) path = DerivativePath::kGBuffer;
  result.path = path;
  const bool gl = path == DerivativePath::kGl;
  const bool environment = !gl && !twin_ok;
  if (environment) {
    for (PreparedReference& r : refs) {
      if (TwinSupportsScene(r.scene)) continue;
      r.environment = true;
      SubsampleForEnvironment(&r, std::max(64, options.environment_pixels));
    }
    AttachQuadrature(refs,
                     ProposalAlphas(model.id, param.ToNatural(param.DefaultInternal()), false),
                     std::max(4, options.environment_twin_samples));
  }

  double loss_scale = 0;
  if (IsRobust(options.loss)) {
    if (options.loss_scale > 0) {
      loss_scale = options.loss_scale;
    } else {
      double p99 = 0;
      for (const auto& r : refs) p99 = std::max(p99, r.p99_norm);
      loss_scale = kRobustScaleFraction * p99;
    }
  }
  result.loss_scale = loss_scale;

  // --- The Ceres problem: one model block u, one log-exposure block e. -------------------------
  ResidualSettings settings{model.id, options.loss, &param};
  const int n = param.size();
  std::vector<double> u = param.DefaultInternal();
  double log_exposure[1] = {0.0};
  std::unique_ptr<ceres::LossFunction> loss_function;
  // Robust losses act on each residual block's squared norm, so their blocks are single pixels.
  if (options.loss == Loss::kHuber) loss_function = std::make_unique<ceres::HuberLoss>(loss_scale);
  if (options.loss == Loss::kCauchy) {
    loss_function = std::make_unique<ceres::CauchyLoss>(loss_scale);
  }
  const int block = IsRobust(options.loss) ? 1 : std::max(1, options.pixels_per_block);
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem ceres_problem(problem_options);
  long residual_count = 0;
  double cost_scale = 0;  // 0.5 * sum of squared targets: the cost of predicting nothing.
  for (auto& r : refs) {
    for (std::size_t k = 0; k < r.points.size(); ++k) {
      for (int c = 0; c < 3; ++c) {
        const double t = CompressRadiance(options.loss, r.linear[3 * k + c]);
        r.targets.push_back(t);
        cost_scale += 0.5 * t * t;
      }
    }
    if (gl) {
      // Capacity: the centre, the trial point and one (two when central) per entry.
      r.cache = std::make_unique<GlRenderCache>(&renderer, &r.scene, model.id,
                                                (options.central_differences ? 2 : 1) * n + 3);
    }
    const int count = static_cast<int>(r.points.size());
    for (int k = 0; k < count; k += block) {
      const int m = std::min(block, count - k);
      ceres::CostFunction* cost =
          gl ? static_cast<ceres::CostFunction*>(new GlBlockResidual(
                   settings, r.cache.get(), &r.pixels[k], &r.targets[3 * k], m, options.fd_step,
                   options.central_differences))
             : CreateGBufferResidual(settings, &r.points[k], &r.targets[3 * k], m);
      ceres_problem.AddResidualBlock(cost, loss_function.get(), u.data(), log_exposure);
      residual_count += 3 * m;
    }
  }
  const std::vector<int> fixed = param.FixedIndices();
  // No bounds: the sine transform keeps every parameter in its box (residuals.h).
  if (static_cast<int>(fixed.size()) == n) {
    ceres_problem.SetParameterBlockConstant(u.data());
  } else if (!fixed.empty()) {
    ceres_problem.SetManifold(u.data(), new ceres::SubsetManifold(n, fixed));
  }
  if (!result.exposure_free) ceres_problem.SetParameterBlockConstant(log_exposure);

  ceres::Solver::Options solver_options;
  solver_options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  // Few parameters, many residuals: J^T J is tiny; QR of the tall J would cost more.
  solver_options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.gradient_tolerance = options.gradient_tolerance;
  solver_options.parameter_tolerance = options.parameter_tolerance;
  // The GL context is current on this thread only: the GL path evaluates on it.
  const int threads = gl ? 1 : std::max(1, options.num_threads);
  solver_options.num_threads = threads;
  // SHADEFIT_FIT_TRACE=1 prints Ceres' per-iteration table (debugging aid).
  const bool trace = std::getenv("SHADEFIT_FIT_TRACE") != nullptr;
  solver_options.logging_type = trace ? ceres::PER_MINIMIZER_ITERATION : ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = trace;
  struct TraceCallback : ceres::IterationCallback {
    const std::vector<double>* u;
    const Parametrization* param;
    ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
      std::vector<double> p = param->ToNatural(*u);
      for (double v : p) fmt::print(" {:.4g}", v);
      fmt::print("\n");
      return ceres::SOLVER_CONTINUE;
    }
  } trace_callback;
  trace_callback.u = &u;
  trace_callback.param = &param;
  if (trace) {
    solver_options.update_state_every_iteration = true;
    solver_options.callbacks.push_back(&trace_callback);
  }

  // --- Coarse stage (G-buffer path, large problems): every start first runs on a subsample. ------
  // All pixels at or above the reference's 90th percentile (highlights are few and carry the
  // shape information) plus a regular stride through the rest, kCoarseTarget pixels in all; the
  // starts that end within kPolishTolerance of the best coarse cost are then polished on every
  // pixel. A polish from a nearby point takes a few iterations, so N starts cost about
  // N coarse fits + a few full ones instead of N full fits.
  constexpr long kCoarseThreshold = 16384;  // Valid pixels over all references.
  constexpr long kCoarseTarget = 4096;
  constexpr double kPolishTolerance = 1e-2;
  long total_points = 0;
  for (const auto& r : refs) total_points += static_cast<long>(r.points.size());
  const bool coarse = !gl && options.coarse_to_fine && total_points > kCoarseThreshold;
  std::vector<std::vector<ShadingPoint>> coarse_points(refs.size());
  std::vector<std::vector<double>> coarse_targets(refs.size());
  ceres::Problem coarse_problem(problem_options);
  if (coarse) {
    for (std::size_t ri = 0; ri < refs.size(); ++ri) {
      const auto& r = refs[ri];
      const long want = std::max<long>(64, kCoarseTarget * static_cast<long>(r.points.size()) /
                                               total_points);
      std::vector<double> norms;
      for (std::size_t k = 0; k < r.points.size(); ++k) {
        norms.push_back(std::hypot(r.linear[3 * k], r.linear[3 * k + 1], r.linear[3 * k + 2]));
      }
      std::vector<double> sorted = norms;
      std::nth_element(sorted.begin(), sorted.begin() + sorted.size() * 9 / 10, sorted.end());
      const double p90 = sorted[sorted.size() * 9 / 10];
      const long stride = std::max<long>(1, static_cast<long>(r.points.size()) / want);
      for (std::size_t k = 0; k < r.points.size(); ++k) {
        if (norms[k] < p90 && k % stride != 0) continue;
        coarse_points[ri].push_back(r.points[k]);
        for (int c = 0; c < 3; ++c) coarse_targets[ri].push_back(r.targets[3 * k + c]);
      }
      const int count = static_cast<int>(coarse_points[ri].size());
      for (int k = 0; k < count; k += block) {
        const int m = std::min(block, count - k);
        coarse_problem.AddResidualBlock(
            CreateGBufferResidual(settings, &coarse_points[ri][k], &coarse_targets[ri][3 * k], m),
            loss_function.get(), u.data(), log_exposure);
      }
    }
    if (static_cast<int>(fixed.size()) == n) {
      coarse_problem.SetParameterBlockConstant(u.data());
    } else if (!fixed.empty()) {
      coarse_problem.SetManifold(u.data(), new ceres::SubsetManifold(n, fixed));
    }
    if (!result.exposure_free) coarse_problem.SetParameterBlockConstant(log_exposure);
  }

  // --- Multi-start. -------------------------------------------------------------------------
  int best = -1;
  std::vector<std::vector<double>> best_u(options.starts);
  std::vector<double> best_e(options.starts);
  std::vector<int> coarse_iterations(options.starts, 0);
  ceres::Solver::Summary best_summary;
  auto count_evaluations = [&](const ceres::Solver::Summary& summary) {
    result.residual_evaluations += summary.num_residual_evaluations;
    result.jacobian_evaluations += summary.num_jacobian_evaluations;
  };
  // Full-problem solve from the current u, e; records start s.
  // Active set (bounds without crawling): an optimum on a bound is approached through a
  // stationary point of the sine transform, where Levenberg-Marquardt creeps (cost ~ delta^2,
  // step ~ delta / 2: linear convergence). So a solve runs in stages of kStageIterations; after a
  // stage that has not converged, entries within kSnap of a bound (|sin u| > 1 - kSnap, i.e.
  // 0.05% of their box) are snapped onto it and held there, and the rest is solved on. This is
  // the working-set treatment of bound constraints (Nocedal and Wright 2006, sec. 16.5 and 16.7:
  // a constraint that a stage's iterates press against joins the working set). Returns the last
  // stage's summary (initial_cost: the first stage's) and the iterations of all stages.
  auto staged_solve = [&](ceres::Problem& problem, int* iterations) {
    constexpr int kStageIterations = 15;
    constexpr double kSnap = 1e-3;
    constexpr double kSnapWide = 2e-2;  // 1% of the box.
    const int budget = options.max_iterations;
    solver_options.max_num_iterations = std::min(budget, kStageIterations);
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
    count_evaluations(summary);
    int used = static_cast<int>(summary.iterations.size()) - 1;
    std::vector<int> held = fixed;
    ceres::Problem::EvaluateOptions eval;
    eval.num_threads = threads;
    auto cost_now = [&] {
      double c = 0;
      problem.Evaluate(eval, &c, nullptr, nullptr, nullptr);
      return c;
    };
    auto is_held = [&](int i) { return std::find(held.begin(), held.end(), i) != held.end(); };
    for (int round = 0; round < 12 && used < budget; ++round) {
      bool changed = false;
      // Release: a held entry whose step 1% into its box lowers the cost does not belong on
      // the bound (its Lagrange multiplier has the wrong sign); it is solved for again.
      if (held.size() > fixed.size()) {
        double c0 = cost_now();
        for (std::size_t k = 0; k < held.size();) {
          const int i = held[k];
          if (std::find(fixed.begin(), fixed.end(), i) != fixed.end()) {
            ++k;
            continue;
          }
          const double save = u[i];
          u[i] = std::asin(std::sin(save) > 0 ? 1.0 - kSnapWide : -(1.0 - kSnapWide));
          const double c = cost_now();
          if (std::isfinite(c) && c < c0 * (1 - 1e-9)) {
            held.erase(held.begin() + static_cast<long>(k));
            c0 = c;
            changed = true;
          } else {
            u[i] = save;
            ++k;
          }
        }
      }
      if (summary.termination_type == ceres::NO_CONVERGENCE) {
        // Snap: entries within kSnapWide of a bound when snapping them all does not raise the
        // cost (relative 1e-6: the bound is where they are going), else those within kSnap.
        const std::vector<double> keep_u = u;
        const double c_before = cost_now();
        std::vector<int> wide;
        for (int i = 0; i < n; ++i) {
          if (is_held(i) || !(std::abs(std::sin(u[i])) > 1.0 - kSnapWide)) continue;
          wide.push_back(i);
          u[i] = std::sin(u[i]) > 0 ? std::numbers::pi / 2 : -std::numbers::pi / 2;
        }
        const double c_after = wide.empty() ? c_before : cost_now();
        const bool accept_wide = std::isfinite(c_after) && c_after <= c_before * (1 + 1e-6);
        for (int i : wide) {
          if (accept_wide || std::abs(std::sin(keep_u[i])) > 1.0 - kSnap) {
            held.push_back(i);
            changed = true;
          } else {
            u[i] = keep_u[i];
          }
        }
        // A stage that stopped at its limit goes on even when the working set is unchanged.
        changed = changed || summary.iterations.size() > 1;
      }
      if (!changed || static_cast<int>(held.size()) >= n) break;
      std::sort(held.begin(), held.end());
      problem.SetManifold(u.data(), held.empty() ? nullptr : new ceres::SubsetManifold(n, held));
      solver_options.max_num_iterations = std::min(budget - used, kStageIterations);
      ceres::Solver::Summary finish;
      ceres::Solve(solver_options, &problem, &finish);
      count_evaluations(finish);
      used += static_cast<int>(finish.iterations.size()) - 1;
      finish.initial_cost = summary.initial_cost;
      summary = finish;
    }
    solver_options.max_num_iterations = options.max_iterations;
    if (held.size() > fixed.size()) {
      problem.SetManifold(u.data(), fixed.empty() ? nullptr : new ceres::SubsetManifold(n, fixed));
    }
    *iterations = used;
    return summary;
  };
  auto solve_full = [&](int s, StartResult* start) {
    int used = 0;
    const ceres::Solver::Summary summary = staged_solve(ceres_problem, &used);
    start->params = param.ToNatural(u);
    start->exposure = std::exp(log_exposure[0]);
    if (!coarse) start->initial_cost = summary.initial_cost;
    start->final_cost = summary.final_cost;
    start->iterations = coarse_iterations[s] + used;
    start->termination = ceres::TerminationTypeToString(summary.termination_type);
    start->converged = summary.termination_type == ceres::CONVERGENCE;
    best_u[s] = u;
    best_e[s] = log_exposure[0];
    const bool usable = summary.termination_type != ceres::FAILURE &&
                        std::isfinite(summary.final_cost);
    if (usable && (best < 0 || summary.final_cost < result.start_results[best].final_cost)) {
      best = s;
      best_summary = summary;
    }
  };
  std::vector<double> coarse_cost(options.starts, std::numeric_limits<double>::quiet_NaN());
  for (int s = 0; s < options.starts; ++s) {
    // Copy into place: the Problem holds u.data(), a move would swap the storage.
    const std::vector<double> start_u = param.Start(s, options.seed);
    std::copy(start_u.begin(), start_u.end(), u.begin());
    log_exposure[0] = 0.0;
    StartResult start;
    start.start = param.ToNatural(u);
    result.start_results.push_back(start);
    if (!coarse) {
      solve_full(s, &result.start_results[s]);
      continue;
    }
    int used = 0;
    const ceres::Solver::Summary summary = staged_solve(coarse_problem, &used);
    coarse_iterations[s] = used;
    coarse_cost[s] = summary.termination_type == ceres::FAILURE ? NAN : summary.final_cost;
    best_u[s] = u;
    best_e[s] = log_exposure[0];
    StartResult& sr = result.start_results[s];
    sr.coarse_cost = coarse_cost[s];
    sr.params = param.ToNatural(u);
    sr.exposure = std::exp(log_exposure[0]);
    sr.iterations = coarse_iterations[s];
    sr.termination = ceres::TerminationTypeToString(summary.termination_type);
    sr.final_cost = std::numeric_limits<double>::quiet_NaN();
  }
  if (coarse) {
    double best_coarse = std::numeric_limits<double>::infinity();
    for (double c : coarse_cost) {
      if (std::isfinite(c)) best_coarse = std::min(best_coarse, c);
    }
    for (int s = 0; s < options.starts; ++s) {
      if (!(coarse_cost[s] <= best_coarse * (1 + kPolishTolerance) + 1e-12 * cost_scale)) continue;
      std::copy(best_u[s].begin(), best_u[s].end(), u.begin());
      log_exposure[0] = best_e[s];
      StartResult& sr = result.start_results[s];
      sr.polished = true;
      // Initial cost of the full problem at the start point, for the record.
      const std::vector<double> start_u = param.ToInternal(sr.start);
      std::vector<double> keep(u);
      std::copy(start_u.begin(), start_u.end(), u.begin());
      const double keep_e = log_exposure[0];
      log_exposure[0] = 0.0;
      double initial = 0;
      ceres::Problem::EvaluateOptions eval;
      eval.num_threads = threads;
      ceres_problem.Evaluate(eval, &initial, nullptr, nullptr, nullptr);
      sr.initial_cost = initial;
      std::copy(keep.begin(), keep.end(), u.begin());
      log_exposure[0] = keep_e;
      solve_full(s, &sr);
    }
  }
  if (best < 0) {
    // Every start failed (NaN residuals, numerical failure): still a result, never a crash.
    best = 0;
    best_summary = ceres::Solver::Summary();
  }
  // Environment rounds: re-centre the quadrature's GGX proposal on the winner's lobe and solve
  // again from it. Every start's cost is then re-evaluated on the new quadrature, so that costs
  // stay comparable between starts.
  for (int round = 0; environment && round < options.environment_rounds &&
                      std::isfinite(result.start_results[best].final_cost);
       ++round) {
    AttachQuadrature(refs, ProposalAlphas(model.id, result.start_results[best].params, true),
                     2 * std::max(4, options.environment_twin_samples));
    ceres::Problem::EvaluateOptions eval;
    eval.num_threads = threads;
    for (int s = 0; s < options.starts; ++s) {
      StartResult& sr = result.start_results[s];
      if (s == best || !std::isfinite(sr.final_cost)) continue;
      std::copy(best_u[s].begin(), best_u[s].end(), u.begin());
      log_exposure[0] = best_e[s];
      ceres_problem.Evaluate(eval, &sr.final_cost, nullptr, nullptr, nullptr);
    }
    const int winner_before = best;
    std::copy(best_u[best].begin(), best_u[best].end(), u.begin());
    log_exposure[0] = best_e[best];
    StartResult& sr = result.start_results[winner_before];
    const int previous_iterations = sr.iterations;
    const double initial = sr.initial_cost;
    best = -1;  // solve_full picks the best of the re-evaluated starts and this re-solve.
    for (int s = 0; s < options.starts; ++s) {
      const StartResult& o = result.start_results[s];
      if (s != winner_before && std::isfinite(o.final_cost) &&
          (best < 0 || o.final_cost < result.start_results[best].final_cost)) {
        best = s;
      }
    }
    solve_full(winner_before, &sr);
    sr.iterations += previous_iterations;
    sr.initial_cost = initial;
    if (best < 0) best = winner_before;
  }
  const StartResult& winner = result.start_results[best];
  std::copy(best_u[best].begin(), best_u[best].end(), u.begin());
  log_exposure[0] = best_e[best];
  result.values = winner.params;
  result.exposure = winner.exposure;
  result.initial_cost = winner.initial_cost;
  result.final_cost = winner.final_cost;
  result.iterations = winner.iterations;
  result.termination = winner.termination;
  result.converged = winner.converged && std::isfinite(winner.final_cost);
  result.solver_message = best_summary.message;

  // Starts that reached the best cost: relative 1e-6, plus an absolute floor of 1e-12 times the
  // cost of predicting black (exact synthetic fits end at costs ~1e-25 that differ relatively).
  const double tolerance = 1e-6 * winner.final_cost + 1e-12 * cost_scale;
  std::vector<int> reached;
  result.coarse_to_fine = coarse;
  for (int s = 0; s < options.starts; ++s) {
    auto& sr = result.start_results[s];
    sr.reached_best = std::isfinite(sr.final_cost) && sr.final_cost <= winner.final_cost + tolerance;
    if (sr.reached_best) reached.push_back(s);
  }
  result.starts_reached_best = static_cast<int>(reached.size());

  result.parameters.resize(n);
  for (int i = 0; i < n; ++i) {
    ParameterEstimate& pe = result.parameters[i];
    pe.name = param.entry(i).name;
    pe.value = result.values[i];
    pe.fixed = param.entry(i).fixed;
    // On a bound: |sin u| = 1 to 1e-9, i.e. y within ~1e-9 of the box's end.
    pe.at_bound = !pe.fixed && std::abs(std::sin(u[i])) > 1.0 - 1e-9;
    std::vector<double> v;
    for (int s : reached) v.push_back(result.start_results[s].params[i]);
    pe.spread_min = *std::min_element(v.begin(), v.end());
    pe.spread_max = *std::max_element(v.begin(), v.end());
    const double mean = Mean(v);
    double var = 0;
    for (double x : v) var += (x - mean) * (x - mean);
    pe.spread_std = std::sqrt(var / v.size());
  }

  // --- Uncertainty: ceres::Covariance at the best start, scaled by the residual variance. --------
  result.covariance_status = "skipped";
  if (options.compute_covariance && std::isfinite(result.final_cost)) {
    try {
      std::vector<double*> blocks;
      std::vector<int> block_entry;  // Tangent column -> entry (n = exposure).
      if (static_cast<int>(fixed.size()) < n) {
        blocks.push_back(u.data());
        for (int i = 0; i < n; ++i) {
          if (!param.entry(i).fixed) block_entry.push_back(i);
        }
      }
      if (result.exposure_free) {
        blocks.push_back(log_exposure);
        block_entry.push_back(n);
      }
      ceres::Problem::EvaluateOptions eval;
      eval.parameter_blocks = blocks;
      eval.num_threads = threads;
      ceres::CRSMatrix jacobian;
      double cost = 0;
      ceres_problem.Evaluate(eval, &cost, nullptr, nullptr, &jacobian);
      const std::vector<bool> undetermined = UndeterminedColumns(jacobian);
      bool any_undetermined = false;
      for (std::size_t k = 0; k < block_entry.size(); ++k) {
        if (!undetermined[k]) continue;
        // At a bound dp/du = 0 makes the column vanish: that is "at bound", not undetermined.
        if (block_entry[k] < n && !result.parameters[block_entry[k]].at_bound) {
          result.parameters[block_entry[k]].undetermined = true;
          any_undetermined = true;
        }
        if (block_entry[k] == n) any_undetermined = true;
      }

      ceres::Covariance::Options cov_options;
      cov_options.algorithm_type = ceres::DENSE_SVD;
      cov_options.null_space_rank = -1;  // Pseudo-inverse: drop directions below the threshold.
      cov_options.min_reciprocal_condition_number = 1e-14;
      cov_options.num_threads = threads;
      ceres::Covariance covariance(cov_options);
      std::vector<std::pair<const double*, const double*>> pairs;
      for (double* b : blocks) pairs.emplace_back(b, b);
      // Residual variance estimate s^2 = sum r^2 / (m - k) (k free parameters): the usual
      // asymptotic least-squares scaling of (J^T J)^-1 (Seber & Wild 1989, sec. 2.1).
      const int free = static_cast<int>(block_entry.size());
      const double s2 = 2.0 * result.final_cost / std::max<long>(1, residual_count - free);
      if (covariance.Compute(pairs, &ceres_problem)) {
        if (static_cast<int>(fixed.size()) < n) {
          std::vector<double> cuu(n * n);
          covariance.GetCovarianceBlock(u.data(), u.data(), cuu.data());
          for (int i = 0; i < n; ++i) {
            ParameterEstimate& pe = result.parameters[i];
            if (pe.fixed || pe.undetermined || pe.at_bound) continue;
            pe.std_error = std::abs(param.NaturalDerivative(i, u[i])) *
                           std::sqrt(std::max(0.0, cuu[i * n + i] * s2));
          }
        }
        if (result.exposure_free) {
          double cee = 0;
          covariance.GetCovarianceBlock(log_exposure, log_exposure, &cee);
          const bool exposure_undetermined = undetermined.back();
          if (!exposure_undetermined) {
            result.exposure_std_error = result.exposure * std::sqrt(std::max(0.0, cee * s2));
          }
        }
        result.covariance_status = any_undetermined ? "rank deficient" : "ok";
      } else {
        result.covariance_status = "failed: ceres::Covariance::Compute returned false";
      }
    } catch (const std::exception& e) {
      result.covariance_status = fmt::format("failed: {}", e.what());
    }
  }

  // --- Per-reference RMSE at the best fit (the fitting path's own predictions). ------------------
  double total_sq = 0;
  long total_n = 0;
  for (auto& r : refs) {
    ReferenceResult rr;
    rr.name = r.source->name;
    rr.pixels = static_cast<int>(r.points.size());
    double sq = 0;
    long count = 0;
    if (gl || r.environment) {
      // A GL render over every valid pixel (the environment twin fitted a subsample).
      Image env_render;
      if (r.environment) env_render = renderer.Render(r.scene, model.id, result.values);
      const Image& image = gl ? r.cache->Get(result.values) : env_render;
      const std::vector<int>& pixels = r.environment ? r.all_pixels : r.pixels;
      const std::vector<double>& linear = r.environment ? r.all_linear : r.linear;
      for (std::size_t k = 0; k < pixels.size(); ++k) {
        for (int c = 0; c < 3; ++c) {
          const double x = image.data[static_cast<std::size_t>(pixels[k]) * image.channels + c];
          const double d = result.exposure * x - linear[3 * k + c];
          sq += d * d;
        }
      }
      count = static_cast<long>(pixels.size());
      rr.pixels = static_cast<int>(count);
    } else {
      for (std::size_t k = 0; k < r.points.size(); ++k) {
        double rgb[3];
        ShadePoint(model.id, result.values.data(), r.points[k], rgb);
        for (int c = 0; c < 3; ++c) {
          const double d = result.exposure * rgb[c] - r.linear[3 * k + c];
          sq += d * d;
        }
      }
      count = static_cast<long>(r.points.size());
    }
    rr.rmse = std::sqrt(sq / (3.0 * count));
    total_sq += sq;
    total_n += 3 * count;
    if (options.render_outputs) {
      const Image render = renderer.Render(r.scene, model.id, result.values);
      const Image& ref = r.source->image;
      rr.prediction = render;
      rr.abs_error = Image(render.width, render.height, 4, 0.0f);
      for (std::size_t p = 0; p < render.PixelCount(); ++p) {
        for (int c = 0; c < 3; ++c) rr.prediction.data[4 * p + c] *= result.exposure;
      }
      for (int k : r.environment ? r.all_pixels : r.pixels) {
        for (int c = 0; c < 3; ++c) {
          rr.abs_error.data[4 * k + c] =
              std::abs(rr.prediction.data[4 * k + c] - ref.data[k * ref.channels + c]);
        }
        rr.abs_error.data[4 * k + 3] = 1.0f;
      }
    }
    result.references.push_back(std::move(rr));
  }
  result.rmse = std::sqrt(total_sq / std::max<long>(1, total_n));
  if (gl) {
    for (auto& r : refs) result.renders += r.cache->renders();
  }

  // --- Provenance. --------------------------------------------------------------------------
  result.inputs = nlohmann::json::object();
  result.inputs["hash"] = "sha256";
  result.inputs["references"] = nlohmann::json::array();
  for (std::size_t i = 0; i < refs.size(); ++i) {
    const FitReference& ref = problem.references[i];
    nlohmann::json j;
    j["name"] = ref.name;
    j["pixels"] = refs[i].environment ? refs[i].all_pixels.size() : refs[i].points.size();
    if (refs[i].environment) {
      j["environment_quadrature"] = {{"fitted_pixels", refs[i].points.size()},
                                     {"samples_per_technique", options.environment_twin_samples},
                                     {"rounds", options.environment_rounds}};
    }
    auto file = [&](const std::string& role, const std::string& p) {
      if (p.empty()) return;
      nlohmann::json f{{"path", p}};
      if (ref.sha256.count(role)) f["sha256"] = ref.sha256.at(role);
      j[role] = f;
    };
    file("image", ref.image_path);
    file("sidecar", ref.sidecar_path);
    file("scene", ref.scene_path);
    file("mask", ref.mask_path);
    if (!ref.scene.source_text.empty()) j["scene_text_sha256"] = Sha256(ref.scene.source_text);
    if (std::isfinite(ref.clip_level)) j["clip_level"] = ref.clip_level;
    if (options.environment_samples > 0 && !TwinSupportsScene(ref.scene)) {
      j["environment_samples"] = options.environment_samples;
    }
    result.inputs["references"].push_back(j);
  }
  result.inputs["fixed"] = problem.fixed;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

double EvaluateModelOnReference(const FitReference& reference, const std::string& model_name,
                                const std::vector<double>& params, double exposure,
                                Renderer* given, Image* prediction) {
  const ModelInfo& model = FindModel(model_name);
  if (static_cast<int>(params.size()) != model.ParamCount()) {
    throw Error("", model.name, fmt::format("expected {} parameter values, got {}",
                                            model.ParamCount(), params.size()));
  }
  RendererHolder holder(given);
  long gbuffers = 0;
  const PreparedReference r = Prepare(reference, *holder.renderer, 0, &gbuffers);
  Image render = holder.renderer->Render(r.scene, model.id, params);
  double sq = 0;
  for (std::size_t k = 0; k < r.pixels.size(); ++k) {
    for (int c = 0; c < 3; ++c) {
      const double d = exposure * render.data[static_cast<std::size_t>(r.pixels[k]) * render.channels + c] -
                       r.linear[3 * k + c];
      sq += d * d;
    }
  }
  if (prediction) {
    for (std::size_t p = 0; p < render.PixelCount(); ++p) {
      for (int c = 0; c < 3; ++c) render.data[render.channels * p + c] *= static_cast<float>(exposure);
    }
    *prediction = std::move(render);
  }
  return std::sqrt(sq / (3.0 * r.pixels.size()));
}

}  // namespace shadefit::fit
