// Helpers shared by the refs tests: output and data folders, an analytic BRDF to tabulate.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "shadefit/reference_images/measured_brdf.h"
#include "shadefit/render/brdf.h"
#include "shadefit/render/vec.h"

namespace shadefit::reference_images::testing {

inline std::string OutputDir() {
  const std::filesystem::path dir = std::filesystem::path(SHADEFIT_TEST_OUTPUT) / "refs";
  std::filesystem::create_directories(dir);
  return dir.string();
}

// ../shared/brdf-data beside the repository, or $SHADEFIT_BRDF_DATA; "" when absent.
inline std::string BrdfDataDir() {
  namespace fs = std::filesystem;
  if (const char* env = std::getenv("SHADEFIT_BRDF_DATA")) {
    if (fs::is_directory(env)) return env;
  }
  const fs::path dir = fs::path(SHADEFIT_SOURCE_DIR) / ".." / "shared" / "brdf-data";
  return fs::is_directory(dir) ? fs::canonical(dir).string() : std::string();
}

// Lambert + GGX (Walter et al. 2007, eqs. 33 and 34: D and separable Smith G1) with a coloured
// specular weight, in 1/sr, cosine not included. A smooth stand-in for a measured material.
struct AnalyticBrdf {
  Vec3d kd{0.30, 0.20, 0.10};
  Vec3d ks{0.90, 0.60, 0.30};
  double alpha = 0.3;

  Vec3d operator()(const Vec3d& wi, const Vec3d& wo) const {
    if (wi.z <= 0 || wo.z <= 0) return {0, 0, 0};
    const Vec3d h = Normalize(wi + wo);
    const double a2 = alpha * alpha;
    const double c2 = h.z * h.z;
    const double denom = c2 * (a2 - 1.0) + 1.0;
    const double d = a2 / (kPi * denom * denom);
    auto g1 = [&](const Vec3d& w) {
      const double t2 = std::max(0.0, 1.0 - w.z * w.z) / (w.z * w.z);
      return 2.0 / (1.0 + std::sqrt(1.0 + a2 * t2));
    };
    const double spec = d * g1(wi) * g1(wo) / (4.0 * wi.z * wo.z);
    return kd * kInvPi + ks * spec;
  }
  // The same on MERL's angles (phi_h = 0).
  Vec3d Angles(double theta_h, double theta_d, double phi_d) const {
    Vec3d wi, wo;
    FromHalfDiff(theta_h, theta_d, phi_d, &wi, &wo);
    return (*this)(wi, wo);
  }
};

inline double MaxRelativeDifference(const Vec3d& a, const Vec3d& b) {
  double m = 0;
  for (int c = 0; c < 3; ++c) {
    m = std::max(m, std::abs(a[c] - b[c]) / std::max(std::abs(b[c]), 1e-300));
  }
  return m;
}

}  // namespace shadefit::reference_images::testing
