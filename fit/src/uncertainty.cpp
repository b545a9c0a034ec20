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

// Marks the undetermined entries (undetermined: per column of `free`); returns whether any
// column is undetermined (the exposure's included).
bool MarkUndetermined(const FreeColumns& free, const std::vector<bool>& undetermined, int n,
                      FitResult* result) {
  bool any_undetermined = false;
  for (std::size_t k = 0; k < free.entry.size(); ++k) {
    if (!undetermined[k]) continue;
    // At a bound dp/du = 0 makes the column vanish: that is "at bound", not undetermined.
    if (free.entry[k] < n && !result->parameters[free.entry[k]].at_bound) {
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
  // Residual variance estimate s^2 = sum r^2 / (m - k) (k free parameters): the usual
  // asymptotic least-squares scaling of (J^T J)^-1 (Seber & Wild 1989, sec. 2.1).
  const int free_count = static_cast<int>(free.entry.size());
  const double s2 = 2.0 * result->final_cost / std::max<long>(1, p.residual_count - free_count);
  if (!covariance.Compute(pairs, &p.full)) {
    result->covariance_status = "failed: ceres::Covariance::Compute returned false";
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
  result->covariance_status = any_undetermined ? "rank deficient" : "ok";
}

}  // namespace

void EstimateUncertainty(const Parametrization& param, CeresProblems& problems, FitResult* result) {
  try {
    const FreeColumns free = FreeColumnsOf(param, problems);
    ceres::Problem::EvaluateOptions eval;
    eval.parameter_blocks = free.blocks;
    eval.num_threads = problems.threads;
    ceres::CRSMatrix jacobian;
    double cost = 0;
    problems.full.Evaluate(eval, &cost, nullptr, nullptr, &jacobian);
    if (problems.native) {
      // The bounded LM ends entries on, or within 1e-6 of their box from, a bound, where
      // cos u ~ 1e-3 shrinks a column of J by 1e3 (J^T J by 1e6) and tilts a null vector onto
      // that entry alone (grey dielectric, metallic 1e-6 from 0: f0_dielectric no longer
      // showed). In s = sin u, the fraction of the box, columns keep their size up to the
      // bound; one exactly on it (cos u = 0) stays a zero column, reported as at_bound.
      for (int r = 0; r < jacobian.num_rows; ++r) {
        for (int a = jacobian.rows[r]; a < jacobian.rows[r + 1]; ++a) {
          const int entry = free.entry[jacobian.cols[a]];
          if (entry >= problems.n) continue;
          const double c = std::cos(problems.u[entry]);
          if (std::abs(c) > 1e-12) jacobian.values[a] /= c;
        }
      }
    }
    const std::vector<bool> undetermined = UndeterminedColumns(jacobian);
    const bool any_undetermined = MarkUndetermined(free, undetermined, problems.n, result);
    StandardErrors(param, problems, free, undetermined, any_undetermined, result);
  } catch (const std::exception& e) {
    result->covariance_status = fmt::format("failed: {}", e.what());
  }
}

}  // namespace shadefit::fit::internal
