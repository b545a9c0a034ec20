// Bounded Levenberg-Marquardt for the G-buffer path (internal to fit/): the model's entries in
// their boxes directly (y = p or log p, EntryMap::lower..upper; no sine transform), the log
// exposure unbounded. A tiny dense problem (<= 12 unknowns) with tens of thousands of residuals:
// J^T J and J^T r are accumulated in one pass over the pixels (the Jacobian is never stored), the
// step is a Cholesky solve of the reduced normal equations, and nothing is built per iteration.
//
// Bounds: the projected Newton method of Bertsekas (1982, "Projected Newton methods for
// optimization problems with simple constraints", SIAM J. Control Optim. 20(2), 221-246) with a
// Levenberg-Marquardt damping in place of the line search (Kanzow, Yamashita and Fukushima 2004,
// "Levenberg-Marquardt methods with strong local convergence properties for solving nonlinear
// equations with convex constraints", J. Comput. Appl. Math. 172, the projected LM step). At
// every iterate an entry on (or within eps of) a bound whose gradient points out of the box is in
// the active set (Nocedal and Wright 2006, sec. 16.7, the binding set) and is held; the step is
// the exact Gauss-Newton/LM step of the remaining entries (the reduced system, not a clipped
// full step), then projected onto the box. An entry that belongs on its bound reaches it in one
// projected step and is held there from the next iterate on; one whose gradient turns inward
// leaves it at once. The step is a trust-region LM step with Marquardt's diagonal scaling, and the
// radius follows More 1978 ("The Levenberg-Marquardt algorithm: implementation and theory"):
// a quarter of the step below a gain ratio of 0.25, at least twice the step above 0.75
// (bounded_lm.cpp says how).
//
// With the L2 loss and a fixed exposure the solve is a variable projection (Golub and Pereyra
// 1973; Kaufman 1975): the entries the image is affine in (LinearEntries) are solved exactly at
// every trial point and the trust region steps the others; SolveBoundedLm says how.
#pragma once

#include <memory>
#include <string_view>
#include <vector>

#include "lm_problem.h"

namespace shadefit::fit::internal {

struct BoundedLmOptions {
  int max_iterations = 100;
  double function_tolerance = 1e-9;   // |delta cost| <= tol * cost on an accepted step.
  double gradient_tolerance = 1e-10;  // max |y - P(y - g)|.
  double parameter_tolerance = 1e-8;  // |step| <= tol * (|y| + tol).
  // > 0: the trust radius to start from (a polish continues where the coarse solve's region
  // ended, MultiStart); else kInitialRadiusFactor x |D y|.
  double initial_radius = 0;
  bool trace = false;  // One line per step on stdout (SHADEFIT_FIT_TRACE, multistart.cpp).
};

// Why a solve stopped: Ceres' termination type and message in one value.
enum class LmTermination {
  kMaxIterations,
  kGradientTolerance,       // max |y - P(y - g)| <= gradient_tolerance.
  kEveryUnknownOnBound,     // Every unknown held on a bound, gradient outwards: a KKT point.
  kTrustRegionTolerance,    // The trust radius fell below the parameter tolerance.
  kParameterTolerance,      // The projected step fell below it.
  kPredictedReduction,      // The Gauss-Newton step predicts less than the function tolerance.
  kFunctionTolerance,       // An accepted step gained less than it.
  kNonFiniteStart,          // Non-finite cost at the start point: the solve failed.
  kNonFiniteJacobian,       // Non-finite normal equations at an accepted point.
};
// The message a solve's record carries ("gradient tolerance reached", ...).
std::string_view LmTerminationMessage(LmTermination termination);

struct BoundedLmSummary {
  double initial_cost = 0, final_cost = 0;
  int iterations = 0;  // Steps computed, accepted or not (as Ceres counts them).
  LmTermination termination = LmTermination::kMaxIterations;
  long residual_evaluations = 0, jacobian_evaluations = 0;
  double final_radius = 0;  // The trust radius at the end (0 when it failed at the start).

  // A tolerance was met (Ceres' CONVERGENCE).
  bool converged() const;
  // No step was possible (Ceres' FAILURE).
  bool failed() const { return termination == LmTermination::kNonFiniteStart; }
};

// 0.5 * sum r^2 at (y, e); NaN when a residual is not finite.
double BoundedLmCost(const BoundedLmProblem& problem, const std::vector<double>& y, double e);

// Cost, gradient g = J^T r and Gauss-Newton matrix h = J^T J (row-major, (n+1)^2) at (y, e),
// over the unknowns [y_0 .. y_{n-1}, e] (zero rows for fixed entries): one Jacobian pass, as the
// solver uses it (tests hold it to differences of BoundedLmCost).
double BoundedLmNormalEquations(const BoundedLmProblem& problem, const std::vector<double>& y,
                                double e, std::vector<double>* g, std::vector<double>* h);

// The unknowns [y_0 .. y_{n-1}, e] that variable projection re-optimises (SolveBoundedLm): the
// free LinearEntries the box holds in linear coordinates, with the L2 loss and a fixed exposure,
// where there are nonlinear unknowns too; all false otherwise.
std::vector<bool> ProjectedEntries(const BoundedLmProblem& problem);

// The normal equations at (y, e) moved to (y + delta, e) without a pass over the pixels, as the
// solver's variable projection moves them (delta: [y deltas..., 0], non-zero on ProjectedEntries
// only); false where the pass does not carry what that needs (then the solver makes a fresh
// pass). Tests hold the result to BoundedLmNormalEquations at y + delta.
bool BoundedLmShiftedNormalEquations(const BoundedLmProblem& problem, const std::vector<double>& y,
                                     double e, const std::vector<double>& delta, double* cost,
                                     std::vector<double>* g, std::vector<double>* h);

// Minimises from (y, e); leaves the end point there (bounded_lm.cpp: the minimiser's steps).
BoundedLmSummary SolveBoundedLm(const BoundedLmProblem& problem, const BoundedLmOptions& options,
                                std::vector<double>* y, double* e);

}  // namespace shadefit::fit::internal
