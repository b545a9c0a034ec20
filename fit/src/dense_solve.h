// The bounded LM's dense linear algebra (internal to fit/): its systems have at most 13
// unknowns (a model's entries and the log exposure), so every solve is a small dense one.
#pragma once

#include <Eigen/Core>
#include <Eigen/Eigenvalues>

namespace shadefit::fit::internal {

// The pseudo-inverse of a small symmetric positive semi-definite matrix, by its eigenvectors:
// directions whose eigenvalue is below kPseudoInverseCut of the largest are left out (a linear
// entry the image does not see, a rank-deficient block), the one rule for every solve here.
inline constexpr double kPseudoInverseCut = 1e-12;
class PsdPseudoInverse {
 public:
  explicit PsdPseudoInverse(const Eigen::MatrixXd& a);
  // a^+ b.
  Eigen::VectorXd Solve(const Eigen::VectorXd& b) const;
  // a^+ itself.
  Eigen::MatrixXd Matrix() const;

 private:
  bool Kept(int i) const;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig_;
  double max_lambda_ = 0;
};

// min over z in [lo, hi] of g.(z - z0) + 0.5 (z - z0)' H (z - z0), H positive semi-definite,
// from z0 inside the box (dense_solve.cpp says how).
Eigen::VectorXd BoxQp(const Eigen::MatrixXd& h, const Eigen::VectorXd& g, const Eigen::VectorXd& z0,
                      const Eigen::VectorXd& lo, const Eigen::VectorXd& hi);

// The Levenberg-Marquardt step d of the Gauss-Newton model (h, g) within |scale .* d| <=
// radius, and its damping lambda (0: the Gauss-Newton step itself); false where no step could
// be computed (dense_solve.cpp says how).
bool TrustRegionStep(const Eigen::MatrixXd& h, const Eigen::VectorXd& g,
                     const Eigen::VectorXd& scale, double radius, Eigen::VectorXd* d,
                     double* lambda_out);

}  // namespace shadefit::fit::internal
