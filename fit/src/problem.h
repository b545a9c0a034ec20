// Problem building (internal to fit/): the Ceres problems of one fit, their parameter blocks and
// residual blocks. One model block u (internal coordinates, residuals.h: the sine transform keeps
// every entry in its box, so there are no bounds) and one log-exposure block e; fixed entries are
// held by a SubsetManifold, a fixed exposure by a constant block.
#pragma once

#include <ceres/ceres.h>

#include <memory>
#include <vector>

#include "bounded_lm.h"
#include "prepared_reference.h"
#include "shadefit/fit/fit_types.h"
#include "shadefit/fit/residuals.h"

namespace shadefit::fit::internal {

// The full problem (every valid pixel) and, for large G-buffer fits, a coarse one on a
// subsample (multistart.h polishes its best starts on the full one). Both hold u.data() and
// log_exposure, and the residual blocks point into the PreparedReferences and coarse_*:
// built in place by BuildProblems, never copied or moved.
struct CeresProblems {
  CeresProblems();
  CeresProblems(const CeresProblems&) = delete;
  CeresProblems& operator=(const CeresProblems&) = delete;

  int n = 0;               // Flattened entries of the model block.
  std::vector<int> fixed;  // Entries held constant (Parametrization::FixedIndices).
  bool exposure_free = false;
  std::vector<double> u;           // Model block, internal coordinates.
  double log_exposure[1] = {0.0};  // Exposure block: the scale is exp(e).
  // Huber/Cauchy (nullptr otherwise), shared by every block and owned here.
  std::unique_ptr<ceres::LossFunction> loss_function;
  double loss_scale = 0;  // The robust losses' scale; 0 for the others.
  int pixels_per_block = 1;
  long residual_count = 0;  // Residuals of the full problem.
  double cost_scale = 0;    // 0.5 * sum of squared targets: the cost of predicting nothing.
  int threads = 1;          // Solve and evaluation threads (1 on the GL path).
  ceres::Problem full;
  bool coarse = false;  // Whether `coarse_problem` is built (and the multi-start uses it).
  std::vector<std::vector<ShadingPoint>> coarse_points;  // Per reference.
  std::vector<std::vector<double>> coarse_targets;       // 3 compressed values per coarse point.
  ceres::Problem coarse_problem;
  // The solver that runs, resolved from FitOptions::solver (never kAuto). kBoundedLm (G-buffer
  // path, non-robust loss): the same two problems for the bounded LM (bounded_lm.h), which
  // solves them; the Ceres problems then serve the covariance only.
  Solver solver = Solver::kCeres;
  bool Native() const { return solver == Solver::kBoundedLm; }
  BoundedLmProblem native_full, native_coarse;
};

// Builds `out` for the prepared references (fills their targets and, on the GL path, their render
// caches). `gl`: the GL path (finite differences of renders) rather than the G-buffer twin;
// `renderer` is used on it only (null is fine otherwise).
void BuildProblems(const ModelInfo& model, const Parametrization& param, const FitOptions& options,
                   bool gl, Renderer* renderer, std::vector<PreparedReference>& refs,
                   CeresProblems* out);

// The scale of Huber/Cauchy: FitOptions::loss_scale when given, else kRobustScaleFraction of the
// largest p99 over the references; 0 for losses without a scale.
double RobustLossScale(const FitOptions& options, const std::vector<PreparedReference>& refs);

// Robust losses act on each residual block's squared norm, so their blocks are single pixels.
bool IsRobust(Loss loss);

}  // namespace shadefit::fit::internal
