#include "dense_solve.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <vector>

namespace shadefit::fit::internal {

PsdPseudoInverse::PsdPseudoInverse(const Eigen::MatrixXd& a) : eig_(a) {
  const Eigen::VectorXd& lambda = eig_.eigenvalues();
  max_lambda_ = lambda.size() > 0 ? lambda.maxCoeff() : 0.0;
}

bool PsdPseudoInverse::Kept(int i) const {
  return max_lambda_ > 0 && eig_.eigenvalues()[i] > kPseudoInverseCut * max_lambda_;
}

Eigen::VectorXd PsdPseudoInverse::Solve(const Eigen::VectorXd& b) const {
  const Eigen::VectorXd& lambda = eig_.eigenvalues();
  Eigen::VectorXd coeff = eig_.eigenvectors().transpose() * b;
  for (int i = 0; i < coeff.size(); ++i) coeff[i] = Kept(i) ? coeff[i] / lambda[i] : 0.0;
  return eig_.eigenvectors() * coeff;
}

Eigen::MatrixXd PsdPseudoInverse::Matrix() const {
  const Eigen::VectorXd& lambda = eig_.eigenvalues();
  Eigen::VectorXd inverse(lambda.size());
  for (int i = 0; i < lambda.size(); ++i) inverse[i] = Kept(i) ? 1.0 / lambda[i] : 0.0;
  return eig_.eigenvectors() * inverse.asDiagonal() * eig_.eigenvectors().transpose();
}

// min over z in [lo, hi] of q(z) = g.(z - z0) + 0.5 (z - z0)' H (z - z0), H positive
// semi-definite, from z0 inside the box: projected Newton with an Armijo search along the
// projection arc (Bertsekas 1982; for a quadratic the Newton step on the free entries is exact,
// so this ends after one step per change of the active set). Returns z.
Eigen::VectorXd BoxQp(const Eigen::MatrixXd& h, const Eigen::VectorXd& g, const Eigen::VectorXd& z0,
                      const Eigen::VectorXd& lo, const Eigen::VectorXd& hi) {
  const int m = static_cast<int>(g.size());
  auto q = [&](const Eigen::VectorXd& z) {
    const Eigen::VectorXd d = z - z0;
    return g.dot(d) + 0.5 * d.dot(h * d);
  };
  Eigen::VectorXd z = z0;
  for (int it = 0; it < 4 * m + 8; ++it) {
    const Eigen::VectorXd grad = g + h * (z - z0);
    std::vector<int> free;
    for (int i = 0; i < m; ++i) {
      const bool out_low = z[i] <= lo[i] && grad[i] > 0;
      const bool out_high = z[i] >= hi[i] && grad[i] < 0;
      if (!out_low && !out_high) free.push_back(i);
    }
    if (free.empty()) break;
    const int f = static_cast<int>(free.size());
    Eigen::MatrixXd hf(f, f);
    Eigen::VectorXd gf(f);
    for (int a = 0; a < f; ++a) {
      gf[a] = grad[free[a]];
      for (int b = 0; b < f; ++b) hf(a, b) = h(free[a], free[b]);
    }
    const Eigen::VectorXd step = PsdPseudoInverse(hf).Solve(-gf);
    const double q0 = q(z);
    bool moved = false;
    for (double t = 1.0; t > 1e-10; t *= 0.5) {
      Eigen::VectorXd trial = z;
      for (int a = 0; a < f; ++a) {
        const int i = free[a];
        trial[i] = std::clamp(z[i] + t * step[a], lo[i], hi[i]);
      }
      if (q(trial) <= q0 + 1e-4 * grad.dot(trial - z)) {
        moved = (trial - z).lpNorm<Eigen::Infinity>() > 0;
        z = trial;
        break;
      }
    }
    if (!moved) break;
  }
  return z;
}

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

}  // namespace shadefit::fit::internal
