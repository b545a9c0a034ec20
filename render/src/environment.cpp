#include "shadefit/render/environment.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <mutex>
#include <tuple>

#include "shadefit/render/brdf.h"
#include "shadefit/base/error.h"

namespace shadefit {
namespace {

// The distribution is tabulated at most this wide (half as high): finer adds nothing a
// 256-sample budget can resolve, and keeps the table small enough to upload every frame.
constexpr int kMaxPdfWidth = 512;
// Every cell keeps at least this fraction of the mean weight, so no direction has zero density.
constexpr double kPdfFloor = 1e-3;

// Index i with cdf[i] <= x < cdf[i + 1] and the position of x inside that interval.
int SampleCdf(const double* cdf, int n, double x, double* frac) {
  const double* it = std::upper_bound(cdf, cdf + n + 1, x);
  int i = std::clamp(static_cast<int>(it - cdf) - 1, 0, n - 1);
  const double width = cdf[i + 1] - cdf[i];
  *frac = width > 0 ? std::clamp((x - cdf[i]) / width, 0.0, 1.0) : 0.5;
  return i;
}

}  // namespace

std::uint32_t ReverseBits32(std::uint32_t bits) {
  bits = (bits << 16u) | (bits >> 16u);
  bits = ((bits & 0x55555555u) << 1u) | ((bits & 0xAAAAAAAAu) >> 1u);
  bits = ((bits & 0x33333333u) << 2u) | ((bits & 0xCCCCCCCCu) >> 2u);
  bits = ((bits & 0x0F0F0F0Fu) << 4u) | ((bits & 0xF0F0F0F0u) >> 4u);
  return ((bits & 0x00FF00FFu) << 8u) | ((bits & 0xFF00FF00u) >> 8u);
}

double RadicalInverseBase2(std::uint32_t bits) {
  return static_cast<double>(ReverseBits32(bits)) * 2.3283064365386963e-10;
}

double DistantLight::Pdf(const Vec3d& d) const {
  return map ? map->Pdf(d) : 1.0 / (4.0 * kPi);
}

Vec3d DistantLight::Sample(double u1, double u2) const {
  if (map) return map->Sample(u1, u2);
  const double z = 1.0 - 2.0 * u1, r = std::sqrt(std::max(0.0, 1.0 - z * z));
  const double phi = 2.0 * kPi * u2;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

void DirectionToEquirect(const Vec3d& d, double* u, double* v) {
  *u = -std::atan2(d.y, d.x) / (2.0 * kPi) + 0.5;
  *v = std::atan2(d.z, std::hypot(d.x, d.y)) / kPi + 0.5;
}

Vec3d EquirectToDirection(double u, double v) {
  const double phi = (0.5 - u) * 2.0 * kPi;
  const double elev = (v - 0.5) * kPi;
  return {std::cos(elev) * std::cos(phi), std::cos(elev) * std::sin(phi), std::sin(elev)};
}

EnvironmentMap::EnvironmentMap(const std::string& path, double strength, double rotation_z_deg)
    : EnvironmentMap(
          [&] {
            Image img = ReadImage(path);
            if (img.channels < 3) throw Error(path, "channels", "environment map needs RGB");
            Image rgb = img.Channels(0, 3);
            for (float x : rgb.data) {
              if (!std::isfinite(x)) throw Error(path, "pixels", "NaN or Inf in the map");
            }
            return rgb;
          }(),
          strength, rotation_z_deg) {}

EnvironmentMap::EnvironmentMap(Image radiance, double strength, double rotation_z_deg)
    : radiance_(std::move(radiance)), strength_(strength) {
  // Cycles' Mapping node rotates the lookup vector: d_map = Rz(rotation) d_world.
  const double a = rotation_z_deg * kPi / 180.0;
  const double c = std::cos(a), s = std::sin(a);
  const double m[9] = {c, -s, 0, s, c, 0, 0, 0, 1};
  std::copy(m, m + 9, world_to_map_);
  BuildDistribution();
}

Vec3d EnvironmentMap::WorldToMap(const Vec3d& d) const {
  const double* m = world_to_map_;
  return {m[0] * d.x + m[1] * d.y + m[2] * d.z, m[3] * d.x + m[4] * d.y + m[5] * d.z,
          m[6] * d.x + m[7] * d.y + m[8] * d.z};
}

Vec3d EnvironmentMap::MapToWorld(const Vec3d& d) const {
  const double* m = world_to_map_;
  return {m[0] * d.x + m[3] * d.y + m[6] * d.z, m[1] * d.x + m[4] * d.y + m[7] * d.z,
          m[2] * d.x + m[5] * d.y + m[8] * d.z};
}

void EnvironmentMap::BuildDistribution() {
  const int W = radiance_.width, H = radiance_.height;
  const int pw = std::min(W, kMaxPdfWidth);
  const int ph = std::max(1, std::min(H, pw / 2));
  pdf_ = Image(pw, ph, 1);
  double total = 0;
  for (int y = 0; y < ph; ++y) {
    const int y0 = y * H / ph, y1 = std::max(y0 + 1, (y + 1) * H / ph);
    const double v = 1.0 - (y + 0.5) / ph;  // Row 0 is the top of the map.
    const double cos_elev = std::cos((v - 0.5) * kPi);
    for (int x = 0; x < pw; ++x) {
      const int x0 = x * W / pw, x1 = std::max(x0 + 1, (x + 1) * W / pw);
      double lum = 0;
      for (int yy = y0; yy < y1; ++yy) {
        for (int xx = x0; xx < x1; ++xx) {
          // Rec. 709 luminance weights.
          lum += 0.2126 * radiance_.at(xx, yy, 0) + 0.7152 * radiance_.at(xx, yy, 1) +
                 0.0722 * radiance_.at(xx, yy, 2);
        }
      }
      const double w = std::max(lum, 0.0) / ((y1 - y0) * (x1 - x0)) * cos_elev;
      pdf_.at(x, y, 0) = static_cast<float>(w);
      total += w;
    }
  }
  const double mean = total / (pw * ph);
  const double floor = mean > 0 ? kPdfFloor * mean : 1.0;
  total = 0;
  for (float& w : pdf_.data) {
    w = static_cast<float>(w + floor);
    total += w;
  }
  // Density over the unit square: cell weight / total * cell count.
  for (float& w : pdf_.data) w = static_cast<float>(w / total * pw * ph);
  marginal_cdf_.assign(ph + 1, 0.0);
  conditional_cdf_.assign(static_cast<std::size_t>(ph) * (pw + 1), 0.0);
  for (int y = 0; y < ph; ++y) {
    double* row = &conditional_cdf_[static_cast<std::size_t>(y) * (pw + 1)];
    for (int x = 0; x < pw; ++x) row[x + 1] = row[x] + pdf_.at(x, y, 0);
    marginal_cdf_[y + 1] = marginal_cdf_[y] + row[pw];
    for (int x = 1; x <= pw; ++x) row[x] /= row[pw];
  }
  for (int y = 1; y <= ph; ++y) marginal_cdf_[y] /= marginal_cdf_[ph];
}

Vec3d EnvironmentMap::SampleMapSpace(double u1, double u2, double* u, double* v) const {
  const int pw = pdf_.width, ph = pdf_.height;
  double fy, fx;
  const int y = SampleCdf(marginal_cdf_.data(), ph, u2, &fy);
  const int x = SampleCdf(&conditional_cdf_[static_cast<std::size_t>(y) * (pw + 1)], pw, u1, &fx);
  *u = (x + fx) / pw;
  *v = 1.0 - (y + fy) / ph;
  return EquirectToDirection(*u, *v);
}

Vec3d EnvironmentMap::Sample(double u1, double u2) const {
  double u, v;
  return MapToWorld(SampleMapSpace(u1, u2, &u, &v));
}

double EnvironmentMap::Pdf(const Vec3d& dir) const {
  const Vec3d d = WorldToMap(dir);
  const double cos_elev = std::hypot(d.x, d.y);
  if (cos_elev < 1e-6) return 0.0;
  double u, v;
  DirectionToEquirect(d, &u, &v);
  const int x = std::clamp(static_cast<int>(u * pdf_.width), 0, pdf_.width - 1);
  const int y = std::clamp(static_cast<int>((1.0 - v) * pdf_.height), 0, pdf_.height - 1);
  return pdf_.at(x, y, 0) / (2.0 * kPi * kPi * cos_elev);
}

std::vector<float> EnvironmentMap::SampleSetMapSpace(int n) const {
  std::vector<float> out(static_cast<std::size_t>(n) * 4, 0.0f);
  for (int i = 0; i < n; ++i) {
    double u, v;
    const Vec3d d =
        SampleMapSpace((i + 0.5) / n, RadicalInverseBase2(static_cast<std::uint32_t>(i)), &u, &v);
    out[4 * i + 0] = static_cast<float>(d.x);
    out[4 * i + 1] = static_cast<float>(d.y);
    out[4 * i + 2] = static_cast<float>(d.z);
  }
  return out;
}

Vec3d EnvironmentMap::Radiance(const Vec3d& dir) const {
  double u, v;
  DirectionToEquirect(WorldToMap(dir), &u, &v);
  // GL_LINEAR with GL_REPEAT in s and GL_CLAMP_TO_EDGE in t, t = 1 - v, row 0 at t = 0.
  const int W = radiance_.width, H = radiance_.height;
  const double fx = u * W - 0.5, fy = (1.0 - v) * H - 0.5;
  const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
  const double ax = fx - x0, ay = fy - y0;
  Vec3d out{0, 0, 0};
  for (int j = 0; j < 2; ++j) {
    const int y = std::clamp(y0 + j, 0, H - 1);
    const double wy = j ? ay : 1.0 - ay;
    for (int i = 0; i < 2; ++i) {
      const int x = ((x0 + i) % W + W) % W;
      const double w = wy * (i ? ax : 1.0 - ax);
      for (int c = 0; c < 3; ++c) out[c] += w * radiance_.at(x, y, c);
    }
  }
  return out * strength_;
}

std::shared_ptr<const EnvironmentMap> LoadEnvironmentCached(const std::string& path,
                                                            double strength,
                                                            double rotation_z_deg) {
  static std::mutex mutex;
  static std::map<std::tuple<std::string, double, double>, std::shared_ptr<const EnvironmentMap>>
      cache;
  std::lock_guard<std::mutex> lock(mutex);
  auto key = std::make_tuple(path, strength, rotation_z_deg);
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  auto env = std::make_shared<const EnvironmentMap>(path, strength, rotation_z_deg);
  cache[key] = env;
  return env;
}

}  // namespace shadefit
