#include "uncertainty.h"

#include <ceres/ceres.h>
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <exception>
#include <utility>
#include <vector>

namespace shadefit::fit::internal {
namespace {

// Which free entries lie in the numerical null space of J at the optimum. J is taken in the
// internal coordinates u, where every column means "move this entry through a comparable part
// of its box" (the sine transform maps the whole box to u in [-pi/2, pi/2]), so column sizes
// compare across entries without units. An eigenvector of J^T J with eigenvalue below
// kNullEigen * max marks every entry with a component above kNullComponent as undetermined:
// exact degeneracies (a grey dielectric in ggx-metallic: base, metallic and f0_dielectric trade
// off) and entries whose effect vanishes (f0_dielectric of a pure metal).
constexpr double kNullEigen = 1e-12;
constexpr double kNullComponent = 0.1;

Eigen::MatrixXd GramOf(const ceres::CRSMatrix& jacobian) {
  const int n = jacobian.num_cols;
  Eigen::MatrixXd jtj = Eigen::MatrixXd::Zero(n, n);
  for (int r = 0; r < jacobian.num_rows; ++r) {
    for (int a = jacobian.rows[r]; a < jacobian.rows[r + 1]; ++a) {
      for (int b = jacobian.rows[r]; b < jacobian.rows[r + 1]; ++b) {
        jtj(jacobian.cols[a], jacobian.cols[b]) += jacobian.values[a] * jacobian.values[b];
      }
    }
  }
  return jtj;
}

std::vector<bool> UndeterminedColumns(const Eigen::MatrixXd& jtj) {
  const int n = static_cast<int>(jtj.rows());
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

// The free parameter blocks and, per tangent column, its entry (n = the exposure).
struct FreeColumns {
  std::vector<double*> blocks;
  std::vector<int> entry;
};

FreeColumns FreeColumnsOf(const Parametrization& param, CeresProblems& p) {
  FreeColumns free;
  if (static_cast<int>(p.fixed.size()) < p.n) {
    free.blocks.push_back(p.u.data());
    for (int i = 0; i < p.n; ++i) {
      if (!param.entry(i).fixed) free.entry.push_back(i);
    }
  }
  if (p.exposure_free) {
    free.blocks.push_back(p.log_exposure);
    free.entry.push_back(p.n);
  }
  return free;
}

// The residual variance estimate s^2 = sum r^2 / (m - k) (k free parameters): the usual
// asymptotic least-squares scaling of (J^T J)^-1 (Seber & Wild 1989, sec. 2.1).
double ResidualVariance(const CeresProblems& p, const FreeColumns& free, const FitResult& result) {
  const int free_count = static_cast<int>(free.entry.size());
  return 2.0 * result.final_cost / std::max<long>(1, p.residual_count - free_count);
}

// Marks the undetermined entries (undetermined: per column of `free`); returns whether any
// column is undetermined (the exposure's included).
// `columns_at_bounds`: whether the columns of entries on a bound kept their size (the native
// path's s coordinates); then such an entry in a null direction is undetermined too (it can
// move into the box at no cost), else its column vanished and says nothing.
bool MarkUndetermined(const FreeColumns& free, const std::vector<bool>& undetermined, int n,
                      bool columns_at_bounds, FitResult* result) {
  bool any_undetermined = false;
  for (std::size_t k = 0; k < free.entry.size(); ++k) {
    if (!undetermined[k]) continue;
    // At a bound dp/du = 0 makes the column vanish: that is "at bound", not undetermined.
    if (free.entry[k] < n &&
        (columns_at_bounds || !result->parameters[free.entry[k]].at_bound)) {
      result->parameters[free.entry[k]].undetermined = true;
      any_undetermined = true;
    }
    if (free.entry[k] == n) any_undetermined = true;
  }
  return any_undetermined;
}

// Ceres' covariance of the free blocks, scaled by the residual variance into standard errors.
void StandardErrors(const Parametrization& param, CeresProblems& p, const FreeColumns& free,
                    const std::vector<bool>& undetermined, bool any_undetermined,
                    FitResult* result) {
  const int n = p.n;
  ceres::Covariance::Options cov_options;
  cov_options.algorithm_type = ceres::DENSE_SVD;
  cov_options.null_space_rank = -1;  // Pseudo-inverse: drop directions below the threshold.
  cov_options.min_reciprocal_condition_number = 1e-14;
  cov_options.num_threads = p.threads;
  ceres::Covariance covariance(cov_options);
  std::vector<std::pair<const double*, const double*>> pairs;
  for (double* b : free.blocks) pairs.emplace_back(b, b);
  const double s2 = ResidualVariance(p, free, *result);
  if (!covariance.Compute(pairs, &p.full)) {
    result->covariance_status = CovarianceStatus::kFailed;
    result->covariance_failure = "ceres::Covariance::Compute returned false";
    return;
  }
  if (static_cast<int>(p.fixed.size()) < n) {
    std::vector<double> cuu(n * n);
    covariance.GetCovarianceBlock(p.u.data(), p.u.data(), cuu.data());
    for (int i = 0; i < n; ++i) {
      ParameterEstimate& pe = result->parameters[i];
      if (pe.fixed || pe.undetermined || pe.at_bound) continue;
      pe.std_error = std::abs(param.NaturalDerivative(i, p.u[i])) *
                     std::sqrt(std::max(0.0, cuu[i * n + i] * s2));
    }
  }
  if (p.exposure_free) {
    double cee = 0;
    covariance.GetCovarianceBlock(p.log_exposure, p.log_exposure, &cee);
    const bool exposure_undetermined = undetermined.back();
    if (!exposure_undetermined) {
      result->exposure_std_error = result->exposure * std::sqrt(std::max(0.0, cee * s2));
    }
  }
  result->covariance_status =
      any_undetermined ? CovarianceStatus::kRankDeficient : CovarianceStatus::kOk;
}

// The bounded LM's problems (problem.h, native): J^T J comes from the solver's own one-pass
// normal equations (bounded_lm.h) at the winner instead of a Jacobian of every residual and a
// dense SVD of it (which took longer than the solve: 143,274 x 7 for a 256^2 sphere). Both
// matrices below are that J^T J with its columns rescaled (J diag(c)), so they are what the
// Ceres path computes, up to rounding:
//  - undetermined entries in s = sin u, the fraction of the box: c = dy/du / cos u. Not in u:
//    the bounded LM ends entries on, or within 1e-6 of their box from, a bound, where
//    cos u ~ 1e-3 shrinks a column by 1e3 (J^T J by 1e6) and tilts a null vector onto that
//    entry alone (grey dielectric, metallic 1e-6 from 0: f0_dielectric no longer showed). In s
//    columns keep their size up to and on the bound, so an entry on its bound in a null direction
//    (ggx-metallic's grey dielectric ends with metallic exactly 0, where base, metallic and
//    f0_dielectric still trade off inwards) is reported undetermined as well as at_bound;
//  - standard errors from the pseudo-inverse of J_u^T J_u in the internal coordinates u
//    (c = dy/du), eigenvalues below 1e-14 of the largest dropped: Ceres' DENSE_SVD with
//    min_reciprocal_condition_number 1e-14 and null_space_rank -1, on the squared singular
//    values.
void NativeUncertainty(const Parametrization& param, CeresProblems& p, const FreeColumns& free,
                       FitResult* result) {
  const int n = p.n;
  const int N = n + 1;
  std::vector<double> g, h;
  const double cost = BoundedLmNormalEquations(p.native_full, BoxOfInternal(param, p.u),
                                               p.log_exposure[0], &g, &h);
  if (!std::isfinite(cost)) {
    result->covariance_status = CovarianceStatus::kFailed;
    result->covariance_failure = "non-finite normal equations at the optimum";
    return;
  }
  const int k = static_cast<int>(free.entry.size());
  Eigen::VectorXd du(k), ds(k);
  for (int a = 0; a < k; ++a) {
    const int i = free.entry[a];
    if (i == n) {
      du[a] = ds[a] = 1.0;  // The log exposure is the LM's own coordinate.
      continue;
    }
    du[a] = BoxDerivative(param, i, p.u[i]);
    ds[a] = FractionDerivative(param, i, p.u[i]);
  }
  Eigen::MatrixXd jtj(k, k);
  for (int a = 0; a < k; ++a) {
    for (int b = 0; b < k; ++b) jtj(a, b) = h[free.entry[a] * N + free.entry[b]];
  }
  const Eigen::MatrixXd in_s = ds.asDiagonal() * jtj * ds.asDiagonal();
  const std::vector<bool> undetermined = UndeterminedColumns(in_s);
  const bool any_undetermined = MarkUndetermined(free, undetermined, n, true, result);

  const Eigen::MatrixXd in_u = du.asDiagonal() * jtj * du.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(in_u);
  if (eig.info() != Eigen::Success) {
    result->covariance_status = CovarianceStatus::kFailed;
    result->covariance_failure = "eigen-decomposition of J^T J";
    return;
  }
  const double max_eigen = eig.eigenvalues().maxCoeff();
  Eigen::VectorXd inverse = Eigen::VectorXd::Zero(k);
  for (int a = 0; a < k; ++a) {
    const double lambda = eig.eigenvalues()[a];
    if (max_eigen > 0 && lambda >= 1e-14 * max_eigen) inverse[a] = 1.0 / lambda;
  }
  const Eigen::MatrixXd cov =
      eig.eigenvectors() * inverse.asDiagonal() * eig.eigenvectors().transpose();
  const double s2 = ResidualVariance(p, free, *result);
  for (int a = 0; a < k; ++a) {
    const int i = free.entry[a];
    const double variance = std::max(0.0, cov(a, a) * s2);
    if (i == n) {
      if (!undetermined[a]) result->exposure_std_error = result->exposure * std::sqrt(variance);
      continue;
    }
    ParameterEstimate& pe = result->parameters[i];
    if (pe.fixed || pe.undetermined || pe.at_bound) continue;
    pe.std_error = std::abs(param.NaturalDerivative(i, p.u[i])) * std::sqrt(variance);
  }
  result->covariance_status =
      any_undetermined ? CovarianceStatus::kRankDeficient : CovarianceStatus::kOk;
}

}  // namespace

void EstimateUncertainty(const Parametrization& param, CeresProblems& problems, FitResult* result) {
  try {
    const FreeColumns free = FreeColumnsOf(param, problems);
    if (problems.Native()) {
      result->covariance_method =
          "pseudo-inverse of the bounded LM's J^T J in the internal coordinates (eigenvalues "
          "below 1e-14 of the largest dropped), scaled by s^2 = 2 cost / (residuals - free "
          "parameters)";
      NativeUncertainty(param, problems, free, result);
      return;
    }
    result->covariance_method =
        "ceres::Covariance DENSE_SVD, null_space_rank -1, scaled by s^2 = 2 cost / (residuals - "
        "free parameters)";
    ceres::Problem::EvaluateOptions eval;
    eval.parameter_blocks = free.blocks;
    eval.num_threads = problems.threads;
    ceres::CRSMatrix jacobian;
    double cost = 0;
    problems.full.Evaluate(eval, &cost, nullptr, nullptr, &jacobian);
    const std::vector<bool> undetermined = UndeterminedColumns(GramOf(jacobian));
    const bool any_undetermined =
        MarkUndetermined(free, undetermined, problems.n, false, result);
    StandardErrors(param, problems, free, undetermined, any_undetermined, result);
  } catch (const std::exception& e) {
    result->covariance_status = CovarianceStatus::kFailed;
    result->covariance_failure = e.what();
  }
}

}  // namespace shadefit::fit::internal
