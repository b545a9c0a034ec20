// Rusinkiewicz half/difference coordinates and the by-extension loader.
#include "shadefit/reference_images/measured_brdf.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "shadefit/base/error.h"
#include "shadefit/base/files.h"

namespace shadefit::reference_images {

HalfDiff ToHalfDiff(const Vec3d& wi, const Vec3d& wo) {
  HalfDiff r;
  Vec3d sum = wi + wo;
  const double len = Length(sum);
  // wi = -wo has no half vector; callers reject such pairs (one of them is below the surface).
  r.h = len > 1e-12 ? sum / len : Vec3d{0, 0, 1};
  r.theta_h = std::acos(std::clamp(r.h.z, -1.0, 1.0));
  r.phi_h = std::atan2(r.h.y, r.h.x);
  // Rusinkiewicz 1998, section 3: d = R_y(-theta_h) R_z(-phi_h) wi.
  const double cp = std::cos(r.phi_h), sp = std::sin(r.phi_h);
  const Vec3d t{wi.x * cp + wi.y * sp, -wi.x * sp + wi.y * cp, wi.z};
  const double ct = std::cos(r.theta_h), st = std::sin(r.theta_h);
  r.d = {t.x * ct - t.z * st, t.y, t.x * st + t.z * ct};
  r.theta_d = std::acos(std::clamp(r.d.z, -1.0, 1.0));
  r.phi_d = std::atan2(r.d.y, r.d.x);
  return r;
}

void FromHalfDiff(double theta_h, double theta_d, double phi_d, Vec3d* wi, Vec3d* wo) {
  const Vec3d d{std::sin(theta_d) * std::cos(phi_d), std::sin(theta_d) * std::sin(phi_d),
                std::cos(theta_d)};
  // wo is d mirrored about the pole of the half frame: (-d.x, -d.y, d.z). Both are rotated back
  // by R_y(theta_h) (phi_h = 0).
  const double ct = std::cos(theta_h), st = std::sin(theta_h);
  auto back = [&](const Vec3d& v) { return Vec3d{v.x * ct + v.z * st, v.y, -v.x * st + v.z * ct}; };
  *wi = back(d);
  *wo = back(Vec3d{-d.x, -d.y, d.z});
}

std::vector<std::string> MeasuredBrdfFiles(const std::string& path) {
  namespace fs = std::filesystem;
  if (fs::path(path).extension() != ".h5") return {path};
  return {path, fs::path(path).replace_extension(".json").string()};
}

std::unique_ptr<MeasuredBrdf> LoadMeasuredBrdf(const std::string& path) {
  namespace fs = std::filesystem;
  const std::string ext = fs::path(path).extension().string();
  if (!PathExists(path)) throw Error(path, "brdf", "file not found");
  if (ext == ".binary") return std::make_unique<MerlBrdf>(path);
  if (ext == ".h5") {
    const std::string json = MeasuredBrdfFiles(path)[1];
    if (!PathExists(json)) {
      throw Error(path, "config", "the Keras model config " + json + " is missing beside it");
    }
    return std::make_unique<NeuralBrdf>(path, json);
  }
  throw Error(path, "brdf",
              "expected a MERL .binary file or a Neural-BRDF .h5 (with its .json beside it)");
}

}  // namespace shadefit::reference_images
