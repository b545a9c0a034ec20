#include "multistart.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <numbers>

namespace shadefit::fit::internal {
namespace {

// SHADEFIT_FIT_TRACE=1 (a debugging aid, read here only): the Ceres path prints its
// per-iteration table and, after each iteration, the natural parameters; the bounded LM one line
// per step (BoundedLmOptions::trace).
bool TraceRequested() { return std::getenv("SHADEFIT_FIT_TRACE") != nullptr; }

// Ceres' termination type as a fit's (no callback of ours returns USER_SUCCESS or USER_FAILURE).
Termination TerminationOf(ceres::TerminationType type) {
  switch (type) {
    case ceres::CONVERGENCE:
    case ceres::USER_SUCCESS: return Termination::kConvergence;
    case ceres::NO_CONVERGENCE: return Termination::kNoConvergence;
    default: return Termination::kFailure;
  }
}

class TraceCallback : public ceres::IterationCallback {
 public:
  TraceCallback(const std::vector<double>* u, const Parametrization* param)
      : u_(u), param_(param) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    std::vector<double> p = param_->ToNatural(*u_);
    for (double v : p) fmt::print(" {:.4g}", v);
    fmt::print("\n");
    return ceres::SOLVER_CONTINUE;
  }

 private:
  const std::vector<double>* u_;
  const Parametrization* param_;
};

ceres::Solver::Options SolverOptions(const FitOptions& options, int threads,
                                     TraceCallback* trace_callback) {
  ceres::Solver::Options solver_options;
  solver_options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  // Few parameters, many residuals: J^T J is tiny; QR of the tall J would cost more.
  solver_options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.gradient_tolerance = options.gradient_tolerance;
  solver_options.parameter_tolerance = options.parameter_tolerance;
  solver_options.num_threads = threads;
  const bool trace = TraceRequested();
  solver_options.logging_type = trace ? ceres::PER_MINIMIZER_ITERATION : ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = trace;
  if (trace) {
    solver_options.update_state_every_iteration = true;
    solver_options.callbacks.push_back(trace_callback);
  }
  return solver_options;
}

// Coarse-to-fine (problem.h): the starts that end within kPolishTolerance of the best coarse cost
// are polished on every pixel.
constexpr double kPolishTolerance = 1e-2;

// Active set (bounds without crawling): an optimum on a bound is approached through a
// stationary point of the sine transform, where Levenberg-Marquardt creeps (cost ~ delta^2,
// step ~ delta / 2: linear convergence). So a solve runs in stages of kStageIterations; after a
// stage that has not converged, entries within kSnap of a bound (|sin u| > 1 - kSnap, i.e.
// 0.05% of their box) are snapped onto it and held there, and the rest is solved on. This is
// the working-set treatment of bound constraints (Nocedal and Wright 2006, sec. 16.5 and 16.7:
// a constraint that a stage's iterates press against joins the working set).
constexpr int kStageIterations = 15;
constexpr int kStageRounds = 12;
constexpr double kSnap = 1e-3;
constexpr double kSnapWide = 2e-2;  // 1% of the box.

// One solve's record, from the bounded LM or from Ceres (its termination type read once, by
// TerminationOf, where the Ceres solve returns).
struct Outcome {
  double initial_cost = 0, final_cost = 0;
  Termination termination = Termination::kFailure;
  std::string message;
  int iterations = 0;
  double final_radius = 0;  // The bounded LM's trust radius at the end; 0 from Ceres.
};

// Shading points a bounded-LM problem sums over.
double Pixels(const BoundedLmProblem& problem) {
  double n = 0;
  for (const PixelSpan& span : problem.spans) n += span.count;
  return n;
}

BoundedLmOptions LmOptions(const FitOptions& options) {
  BoundedLmOptions o;
  o.max_iterations = options.max_iterations;
  o.function_tolerance = options.function_tolerance;
  o.gradient_tolerance = options.gradient_tolerance;
  o.parameter_tolerance = options.parameter_tolerance;
  o.trace = TraceRequested();
  return o;
}

// The solves of one fit. Every start's end point is kept (end_u_, end_e_) so that the winner
// can be continued from and the others re-evaluated.
class MultiStart {
 public:
  MultiStart(const Parametrization& param, const FitOptions& options, CeresProblems& p)
      : param_(param),
        options_(options),
        p_(p),
        trace_(&p.u, &param),
        solver_options_(SolverOptions(options, p.threads, &trace_)),
        start_count_(options.starts + static_cast<int>(options.start_points.size())),
        end_u_(start_count_),
        end_e_(start_count_),
        coarse_iterations_(start_count_, 0),
        coarse_cost_(start_count_, std::numeric_limits<double>::quiet_NaN()),
        coarse_radius_(start_count_, 0.0) {}
  MultiStart(const MultiStart&) = delete;
  MultiStart& operator=(const MultiStart&) = delete;

  // Every start: solved on the full problem, or on the coarse one and then polished.
  void RunStarts();
  // Re-centres the quadrature's GGX proposal on the winner's lobe and solves again from it.
  void EnvironmentRounds(const ModelInfo& model, std::vector<PreparedReference>& refs);
  // Moves u and e to the winner's end point and hands the records over.
  MultiStartResult Finish();

 private:
  void EvaluateCost(ceres::Problem& problem, double* cost) const;
  // Cost of the full problem at the current u, e (bounded LM's evaluation when it solves).
  double FullCost();
  // A solve of the full or the coarse problem from the current u, e: the bounded LM where it
  // applies (problem.h), else Ceres in stages.
  // initial_radius > 0: the bounded LM's first trust radius (BoundedLmOptions).
  Outcome SolveFrom(bool coarse, double initial_radius = 0);
  void Solve(ceres::Problem& problem, ceres::Solver::Summary* summary);
  ceres::Solver::Summary StagedSolve(ceres::Problem& problem, int* iterations);
  bool ReleaseHeld(ceres::Problem& problem, std::vector<int>* held);
  bool SnapToBounds(ceres::Problem& problem, std::vector<int>* held);
  void SolveFull(int s, double initial_radius = 0);
  void SolveCoarse(int s);
  void PolishCoarse();
  void LoadEnd(int s);

  const Parametrization& param_;
  const FitOptions& options_;
  CeresProblems& p_;
  TraceCallback trace_;
  ceres::Solver::Options solver_options_;
  MultiStartResult out_;
  int best_ = -1;  // -1 until a start ends usable.
  std::string best_message_;
  const int start_count_;  // options_.starts, then options_.start_points.
  std::vector<std::vector<double>> end_u_;  // Internal end point of each start.
  std::vector<double> end_e_;               // Log-exposure end point of each start.
  std::vector<int> coarse_iterations_;
  std::vector<double> coarse_cost_;  // NaN: not run coarse, or the solve failed.
  std::vector<double> coarse_radius_;  // The coarse solve's final trust radius (0: none).
};

void MultiStart::EvaluateCost(ceres::Problem& problem, double* cost) const {
  ceres::Problem::EvaluateOptions eval;
  eval.num_threads = p_.threads;
  problem.Evaluate(eval, cost, nullptr, nullptr, nullptr);
}

double MultiStart::FullCost() {
  if (p_.Native()) {
    return BoundedLmCost(p_.native_full, BoxOfInternal(param_, p_.u), p_.log_exposure[0]);
  }
  double cost = 0;
  EvaluateCost(p_.full, &cost);
  return cost;
}

Outcome MultiStart::SolveFrom(bool coarse, double initial_radius) {
  Outcome o;
  if (p_.Native()) {
    std::vector<double> y = BoxOfInternal(param_, p_.u);
    double e = p_.log_exposure[0];
    BoundedLmOptions lm = LmOptions(options_);
    lm.initial_radius = initial_radius;
    const BoundedLmSummary s =
        SolveBoundedLm(coarse ? p_.native_coarse : p_.native_full, lm, &y, &e);
    o.final_radius = s.final_radius;
    out_.residual_evaluations += s.residual_evaluations;
    out_.jacobian_evaluations += s.jacobian_evaluations;
    const std::vector<double> u = InternalOfBox(param_, y);
    for (int i = 0; i < p_.n; ++i) {
      if (!param_.entry(i).fixed) p_.u[i] = u[i];
    }
    p_.log_exposure[0] = e;
    o.initial_cost = s.initial_cost;
    o.final_cost = s.final_cost;
    o.termination = s.failed()      ? Termination::kFailure
                    : s.converged() ? Termination::kConvergence
                                    : Termination::kNoConvergence;
    o.message = std::string(LmTerminationMessage(s.termination));
    o.iterations = s.iterations;
    return o;
  }
  const ceres::Solver::Summary summary =
      StagedSolve(coarse ? p_.coarse_problem : p_.full, &o.iterations);
  o.initial_cost = summary.initial_cost;
  o.final_cost = summary.final_cost;
  o.termination = TerminationOf(summary.termination_type);
  o.message = summary.message;
  return o;
}

void MultiStart::Solve(ceres::Problem& problem, ceres::Solver::Summary* summary) {
  ceres::Solve(solver_options_, &problem, summary);
  out_.residual_evaluations += summary->num_residual_evaluations;
  out_.jacobian_evaluations += summary->num_jacobian_evaluations;
}

void MultiStart::LoadEnd(int s) {
  std::copy(end_u_[s].begin(), end_u_[s].end(), p_.u.begin());
  p_.log_exposure[0] = end_e_[s];
}

// Release: a held entry whose step 1% into its box lowers the cost does not belong on the bound
// (its Lagrange multiplier has the wrong sign); it is solved for again.
bool MultiStart::ReleaseHeld(ceres::Problem& problem, std::vector<int>* held) {
  std::vector<double>& u = p_.u;
  bool changed = false;
  double c0 = 0;
  EvaluateCost(problem, &c0);
  for (std::size_t k = 0; k < held->size();) {
    const int i = (*held)[k];
    if (std::find(p_.fixed.begin(), p_.fixed.end(), i) != p_.fixed.end()) {
      ++k;
      continue;
    }
    const double save = u[i];
    u[i] = std::asin(std::sin(save) > 0 ? 1.0 - kSnapWide : -(1.0 - kSnapWide));
    double c = 0;
    EvaluateCost(problem, &c);
    if (std::isfinite(c) && c < c0 * (1 - 1e-9)) {
      held->erase(held->begin() + static_cast<long>(k));
      c0 = c;
      changed = true;
    } else {
      u[i] = save;
      ++k;
    }
  }
  return changed;
}

// Snap: entries within kSnapWide of a bound when snapping them all does not raise the cost
// (relative 1e-6: the bound is where they are going), else those within kSnap.
bool MultiStart::SnapToBounds(ceres::Problem& problem, std::vector<int>* held) {
  std::vector<double>& u = p_.u;
  auto is_held = [&](int i) { return std::find(held->begin(), held->end(), i) != held->end(); };
  bool changed = false;
  const std::vector<double> keep_u = u;
  double c_before = 0;
  EvaluateCost(problem, &c_before);
  std::vector<int> wide;
  for (int i = 0; i < p_.n; ++i) {
    if (is_held(i) || !(std::abs(std::sin(u[i])) > 1.0 - kSnapWide)) continue;
    wide.push_back(i);
    u[i] = std::sin(u[i]) > 0 ? std::numbers::pi / 2 : -std::numbers::pi / 2;
  }
  double c_after = c_before;
  if (!wide.empty()) EvaluateCost(problem, &c_after);
  const bool accept_wide = std::isfinite(c_after) && c_after <= c_before * (1 + 1e-6);
  for (int i : wide) {
    if (accept_wide || std::abs(std::sin(keep_u[i])) > 1.0 - kSnap) {
      held->push_back(i);
      changed = true;
    } else {
      u[i] = keep_u[i];
    }
  }
  return changed;
}

// A solve from the current u, e in stages of kStageIterations, with the working set updated
// between stages. Returns the last stage's summary (initial_cost: the first stage's) and the
// iterations of all stages.
ceres::Solver::Summary MultiStart::StagedSolve(ceres::Problem& problem, int* iterations) {
  const int budget = options_.max_iterations;
  solver_options_.max_num_iterations = std::min(budget, kStageIterations);
  ceres::Solver::Summary summary;
  Solve(problem, &summary);
  int used = static_cast<int>(summary.iterations.size()) - 1;
  std::vector<int> held = p_.fixed;
  for (int round = 0; round < kStageRounds && used < budget; ++round) {
    bool changed = false;
    if (held.size() > p_.fixed.size()) changed = ReleaseHeld(problem, &held);
    if (summary.termination_type == ceres::NO_CONVERGENCE) {
      changed = SnapToBounds(problem, &held) || changed;
      // A stage that stopped at its limit goes on even when the working set is unchanged.
      changed = changed || summary.iterations.size() > 1;
    }
    if (!changed || static_cast<int>(held.size()) >= p_.n) break;
    std::sort(held.begin(), held.end());
    problem.SetManifold(p_.u.data(),
                        held.empty() ? nullptr : new ceres::SubsetManifold(p_.n, held));
    solver_options_.max_num_iterations = std::min(budget - used, kStageIterations);
    ceres::Solver::Summary finish;
    Solve(problem, &finish);
    used += static_cast<int>(finish.iterations.size()) - 1;
    finish.initial_cost = summary.initial_cost;
    summary = finish;
  }
  solver_options_.max_num_iterations = options_.max_iterations;
  if (held.size() > p_.fixed.size()) {
    problem.SetManifold(p_.u.data(),
                        p_.fixed.empty() ? nullptr : new ceres::SubsetManifold(p_.n, p_.fixed));
  }
  *iterations = used;
  return summary;
}

// Full-problem solve of start s from the current u, e; the best usable one so far wins.
void MultiStart::SolveFull(int s, double initial_radius) {
  const Outcome summary = SolveFrom(false, initial_radius);
  const int used = summary.iterations;
  StartResult& start = out_.starts[s];
  start.params = param_.ToNatural(p_.u);
  start.exposure = std::exp(p_.log_exposure[0]);
  if (!p_.coarse) start.initial_cost = summary.initial_cost;
  start.final_cost = summary.final_cost;
  start.iterations = coarse_iterations_[s] + used;
  start.termination = summary.termination;
  start.converged = summary.termination == Termination::kConvergence;
  end_u_[s] = p_.u;
  end_e_[s] = p_.log_exposure[0];
  const bool usable =
      summary.termination != Termination::kFailure && std::isfinite(summary.final_cost);
  if (usable && (best_ < 0 || summary.final_cost < out_.starts[best_].final_cost)) {
    best_ = s;
    best_message_ = summary.message;
  }
}

// Coarse-problem solve of start s from the current u, e; its final cost waits for the polish.
void MultiStart::SolveCoarse(int s) {
  const Outcome summary = SolveFrom(true);
  coarse_iterations_[s] = summary.iterations;
  coarse_radius_[s] = summary.final_radius;
  coarse_cost_[s] = summary.termination == Termination::kFailure
                        ? std::numeric_limits<double>::quiet_NaN()
                        : summary.final_cost;
  end_u_[s] = p_.u;
  end_e_[s] = p_.log_exposure[0];
  StartResult& sr = out_.starts[s];
  sr.coarse_cost = coarse_cost_[s];
  sr.params = param_.ToNatural(p_.u);
  sr.exposure = std::exp(p_.log_exposure[0]);
  sr.iterations = coarse_iterations_[s];
  sr.termination = summary.termination;
  sr.final_cost = std::numeric_limits<double>::quiet_NaN();
}

// Polishes, on every pixel, the coarse starts near the best coarse cost.
void MultiStart::PolishCoarse() {
  double best_coarse = std::numeric_limits<double>::infinity();
  for (double c : coarse_cost_) {
    if (std::isfinite(c)) best_coarse = std::min(best_coarse, c);
  }
  for (int s = 0; s < start_count_; ++s) {
    if (!(coarse_cost_[s] <= best_coarse * (1 + kPolishTolerance) + 1e-12 * p_.cost_scale)) {
      continue;
    }
    LoadEnd(s);
    StartResult& sr = out_.starts[s];
    sr.polished = true;
    // Initial cost of the full problem at the start point, for the record.
    const std::vector<double> start_u = param_.ToInternal(sr.start);
    std::vector<double> keep(p_.u);
    std::copy(start_u.begin(), start_u.end(), p_.u.begin());
    const double keep_e = p_.log_exposure[0];
    p_.log_exposure[0] = 0.0;
    sr.initial_cost = FullCost();
    std::copy(keep.begin(), keep.end(), p_.u.begin());
    p_.log_exposure[0] = keep_e;
    // The polish starts from the coarse solve's trust region, not a fresh one 100 x |D y| wide:
    // near the coarse minimum a step that large is rejected over and over (silver-mirror-rim: ten
    // rejected full passes, from a radius of 1.5e7 down to 2e-3). The region is measured in
    // column norms of J, which grow as the square root of the pixels summed.
    SolveFull(s, coarse_radius_[s] *
                     std::sqrt(Pixels(p_.native_full) / std::max(Pixels(p_.native_coarse), 1.0)));
  }
}

void MultiStart::RunStarts() {
  for (int s = 0; s < start_count_; ++s) {
    // Copy into place: the Problems hold u.data(), a move would swap the storage.
    const std::vector<double> start_u =
        s < options_.starts ? param_.Start(s, options_.seed)
                            : param_.StartAt(options_.start_points[s - options_.starts]);
    std::copy(start_u.begin(), start_u.end(), p_.u.begin());
    p_.log_exposure[0] = 0.0;
    StartResult start;
    start.start = param_.ToNatural(p_.u);
    out_.starts.push_back(start);
    if (p_.coarse) {
      SolveCoarse(s);
    } else {
      SolveFull(s);
    }
  }
  if (p_.coarse) PolishCoarse();
  if (best_ < 0) {
    // Every start failed (NaN residuals, numerical failure): still a result, never a crash.
    best_ = 0;
    best_message_.clear();
  }
}

// Every other start's cost is re-evaluated on the new quadrature, so that costs stay comparable
// between starts.
void MultiStart::EnvironmentRounds(const ModelInfo& model, std::vector<PreparedReference>& refs) {
  for (int round = 0;
       round < options_.environment_rounds && std::isfinite(out_.starts[best_].final_cost);
       ++round) {
    AttachQuadrature(refs, ProposalAlphas(model.id, out_.starts[best_].params, true),
                     2 * std::max(4, options_.environment_twin_samples));
    ForgetGeometry(p_.native_full);
    ForgetGeometry(p_.native_coarse);
    for (int s = 0; s < start_count_; ++s) {
      StartResult& sr = out_.starts[s];
      if (s == best_ || !std::isfinite(sr.final_cost)) continue;
      LoadEnd(s);
      sr.final_cost = FullCost();
    }
    const int winner_before = best_;
    LoadEnd(best_);
    StartResult& sr = out_.starts[winner_before];
    const int previous_iterations = sr.iterations;
    const double initial = sr.initial_cost;
    best_ = -1;  // SolveFull picks the best of the re-evaluated starts and this re-solve.
    for (int s = 0; s < start_count_; ++s) {
      const StartResult& o = out_.starts[s];
      if (s != winner_before && std::isfinite(o.final_cost) &&
          (best_ < 0 || o.final_cost < out_.starts[best_].final_cost)) {
        best_ = s;
      }
    }
    SolveFull(winner_before);
    sr.iterations += previous_iterations;
    sr.initial_cost = initial;
    if (best_ < 0) best_ = winner_before;
  }
}

MultiStartResult MultiStart::Finish() {
  LoadEnd(best_);
  out_.best = best_;
  out_.solver_message = best_message_;
  return std::move(out_);
}

}  // namespace

MultiStartResult RunMultiStart(const ModelInfo& model, const Parametrization& param,
                               const FitOptions& options, bool environment,
                               std::vector<PreparedReference>& refs, CeresProblems* problems) {
  MultiStart multistart(param, options, *problems);
  multistart.RunStarts();
  if (environment) multistart.EnvironmentRounds(model, refs);
  return multistart.Finish();
}

}  // namespace shadefit::fit::internal
