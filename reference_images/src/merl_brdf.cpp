// MERL .binary tables (Matusik et al. 2003). The layout and the lookup follow the paper's
// description of the database: theta_h sampled on a square-root scale (dense near the specular
// peak), theta_d and phi_d uniformly, phi_d over [0, pi) only because reciprocity makes phi_d and
// phi_d + pi the same point.
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "shadefit/reference_images/measured_brdf.h"
#include "shadefit/render/brdf.h"
#include "shadefit/base/error.h"
#include "shadefit/base/files.h"

namespace shadefit::reference_images {
namespace {

static_assert(std::endian::native == std::endian::little,
              "MERL .binary files are little-endian; add byte swapping for this host");

constexpr std::uint64_t kMerlHeaderBytes = 3 * sizeof(std::int32_t);
constexpr std::uint64_t kMerlFileBytes = kMerlHeaderBytes + 3 * kMerlCells * sizeof(double);

std::size_t CellIndex(int i, int j, int k) {
  return (static_cast<std::size_t>(i) * kMerlThetaD + j) * kMerlPhiD + k;
}

// Continuous table coordinates of a direction pair (inverse of MerlThetaH/ThetaD/PhiD).
void ContinuousIndex(double theta_h, double theta_d, double phi_d, double* u, double* v,
                     double* w) {
  *u = kMerlThetaH * std::sqrt(std::max(theta_h, 0.0) / (0.5 * kPi));
  *v = std::max(theta_d, 0.0) / (0.5 * kPi) * kMerlThetaD;
  if (phi_d < 0) phi_d += kPi;  // reciprocity fold: (-pi, 0) -> (0, pi)
  *w = phi_d / kPi * kMerlPhiD;
}

}  // namespace

double MerlThetaH(int i) {
  const double x = static_cast<double>(i) / kMerlThetaH;
  return x * x * 0.5 * kPi;
}
double MerlThetaD(int j) { return j * 0.5 * kPi / kMerlThetaD; }
double MerlPhiD(int k) { return k * kPi / kMerlPhiD; }

MerlBrdf::MerlBrdf(const std::string& path, MerlLookup lookup) : path_(path), lookup_(lookup) {
  namespace fs = std::filesystem;
  if (!PathExists(path)) throw Error(path, "", "file not found");
  std::error_code ec;
  const std::uint64_t size = fs::file_size(path, ec);
  if (ec) throw Error(path, "", "cannot read file size");
  if (size < kMerlHeaderBytes) {
    throw Error(
        path, "dims",
        "file is " + std::to_string(size) + " bytes, too short for the 12-byte int32 header");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "", "cannot open file");
  std::int32_t dims[3];
  in.read(reinterpret_cast<char*>(dims), sizeof(dims));
  if (dims[0] != kMerlThetaH || dims[1] != kMerlThetaD || dims[2] != kMerlPhiD) {
    throw Error(path, "dims",
                "header is (" + std::to_string(dims[0]) + ", " + std::to_string(dims[1]) + ", " +
                    std::to_string(dims[2]) + "), expected (90, 90, 180)");
  }
  if (size != kMerlFileBytes) {
    throw Error(path, "size",
                "file is " + std::to_string(size) + " bytes, expected " +
                    std::to_string(kMerlFileBytes) + " (12-byte header + 3 x 1,458,000 float64)");
  }
  data_.resize(3 * kMerlCells);
  in.read(reinterpret_cast<char*>(data_.data()),
          static_cast<std::streamsize>(data_.size() * sizeof(double)));
  if (!in) throw Error(path, "data", "read error");
  for (int c = 0; c < 3; ++c) {
    double* channel = &data_[c * kMerlCells];
    for (std::size_t n = 0; n < kMerlCells; ++n) {
      if (!std::isfinite(channel[n])) {
        throw Error(path, "data",
                    "NaN or Inf in channel " + std::to_string(c) + " at cell " + std::to_string(n));
      }
      channel[n] *= kMerlScale[c];
    }
  }
}

Vec3d MerlBrdf::Cell(int i, int j, int k) const {
  const std::size_t n = CellIndex(i, j, k);
  return {data_[n], data_[kMerlCells + n], data_[2 * kMerlCells + n]};
}

Vec3d MerlBrdf::EvalAngles(double theta_h, double theta_d, double phi_d) const {
  double u, v, w;
  ContinuousIndex(theta_h, theta_d, phi_d, &u, &v, &w);
  Vec3d out{0, 0, 0};
  if (lookup_ == MerlLookup::kTruncate) {
    // An index within 1e-9 below an integer is that integer: the cell angles themselves must
    // not fall into the previous cell through rounding (sqrt((i/90)^2) * 90 = i - ulp).
    const int i = std::clamp(static_cast<int>(u + 1e-9), 0, kMerlThetaH - 1);
    const int j = std::clamp(static_cast<int>(v + 1e-9), 0, kMerlThetaD - 1);
    const int k = std::clamp(static_cast<int>(w + 1e-9), 0, kMerlPhiD - 1);
    out = Cell(i, j, k);
  } else {
    // Trilinear in the table coordinates. theta_h and theta_d clamp at the last cell (89 of 90:
    // nothing is stored beyond 87.9 and 89 degrees); phi_d wraps (phi_d = pi is phi_d = 0).
    const int i0 = std::clamp(static_cast<int>(std::floor(u)), 0, kMerlThetaH - 1);
    const int j0 = std::clamp(static_cast<int>(std::floor(v)), 0, kMerlThetaD - 1);
    const int k0f = static_cast<int>(std::floor(w));
    const double tu = std::clamp(u - i0, 0.0, 1.0), tv = std::clamp(v - j0, 0.0, 1.0),
                 tw = std::clamp(w - k0f, 0.0, 1.0);
    const int i1 = std::min(i0 + 1, kMerlThetaH - 1), j1 = std::min(j0 + 1, kMerlThetaD - 1);
    const int k0 = ((k0f % kMerlPhiD) + kMerlPhiD) % kMerlPhiD, k1 = (k0 + 1) % kMerlPhiD;
    // Negative cells mark missing measurements: they get no weight and the rest is renormalised.
    double sum[3] = {0, 0, 0}, weight[3] = {0, 0, 0};
    for (int a = 0; a < 2; ++a) {
      for (int b = 0; b < 2; ++b) {
        for (int c = 0; c < 2; ++c) {
          const double wt = (a ? tu : 1 - tu) * (b ? tv : 1 - tv) * (c ? tw : 1 - tw);
          if (wt == 0) continue;
          const Vec3d cell = Cell(a ? i1 : i0, b ? j1 : j0, c ? k1 : k0);
          for (int ch = 0; ch < 3; ++ch) {
            if (cell[ch] < 0) continue;
            sum[ch] += wt * cell[ch];
            weight[ch] += wt;
          }
        }
      }
    }
    for (int ch = 0; ch < 3; ++ch) out[ch] = weight[ch] > 0 ? sum[ch] / weight[ch] : 0.0;
  }
  for (int ch = 0; ch < 3; ++ch) out[ch] = std::max(out[ch], 0.0);
  return out;
}

Vec3d MerlBrdf::Eval(const Vec3d& wi, const Vec3d& wo) const {
  if (wi.z <= 0 || wo.z <= 0) return {0, 0, 0};
  const HalfDiff hd = ToHalfDiff(wi, wo);
  return EvalAngles(hd.theta_h, hd.theta_d, hd.phi_d);
}

void WriteMerlBinary(const std::string& path,
                     const std::function<Vec3d(double, double, double)>& f) {
  namespace fs = std::filesystem;
  std::vector<double> data(3 * kMerlCells);
  for (int i = 0; i < kMerlThetaH; ++i) {
    for (int j = 0; j < kMerlThetaD; ++j) {
      for (int k = 0; k < kMerlPhiD; ++k) {
        const Vec3d v = f(MerlThetaH(i), MerlThetaD(j), MerlPhiD(k));
        const std::size_t n = CellIndex(i, j, k);
        for (int c = 0; c < 3; ++c) data[c * kMerlCells + n] = v[c] / kMerlScale[c];
      }
    }
  }
  const std::int32_t dims[3] = {kMerlThetaH, kMerlThetaD, kMerlPhiD};
  std::string bytes(reinterpret_cast<const char*>(dims), sizeof(dims));
  bytes.append(reinterpret_cast<const char*>(data.data()), data.size() * sizeof(double));
  WriteTextAtomic(path, bytes);  // Binary-safe: a temporary sibling, then a rename.
}

}  // namespace shadefit::reference_images
