// MERL .binary reader: coordinates, exact grid values, interpolation error, reciprocity, and
// bad files. Uses a table written from an analytic BRDF, and one written byte by byte from the
// published layout; no outside data.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <vector>

#include "reference_images_test_util.h"
#include "shadefit/base/error.h"
#include "shadefit/reference_images/measured_brdf.h"

namespace shadefit::reference_images {
namespace {

using testing::AnalyticBrdf;
using testing::MaxRelativeDifference;
namespace fs = std::filesystem;

// Written once per process: 35 MB in the build tree's test_output.
const std::string& SyntheticMerl(double alpha) {
  static std::map<double, std::string> paths;
  auto it = paths.find(alpha);
  if (it != paths.end()) return it->second;
  AnalyticBrdf brdf;
  brdf.alpha = alpha;
  const std::string path =
      testing::OutputDir() + "/synthetic-ggx-" + std::to_string(alpha) + ".binary";
  WriteMerlBinary(path, [&](double th, double td, double pd) { return brdf.Angles(th, td, pd); });
  return paths[alpha] = path;
}

TEST(HalfDiffTest, RoundTripAndKnownAngles) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int n = 0; n < 1000; ++n) {
    const double th = u(rng) * 1.5, td = u(rng) * 1.5, pd = (u(rng) * 2 - 1) * 3.1;
    Vec3d wi, wo;
    FromHalfDiff(th, td, pd, &wi, &wo);
    const HalfDiff hd = ToHalfDiff(wi, wo);
    EXPECT_NEAR(hd.theta_h, th, 1e-9);
    EXPECT_NEAR(hd.theta_d, td, 1e-9);
    if (th > 1e-6 && td > 1e-6) {
      EXPECT_NEAR(std::remainder(hd.phi_d - pd, 2 * kPi), 0.0, 1e-9);
    }
  }
  // theta_h = 0: d is wi itself.
  Vec3d wi, wo;
  FromHalfDiff(0.0, 0.3, 0.0, &wi, &wo);
  EXPECT_NEAR(wi.x, std::sin(0.3), 1e-15);
  EXPECT_NEAR(wi.z, std::cos(0.3), 1e-15);
  EXPECT_NEAR(wo.x, -std::sin(0.3), 1e-15);
  // Swapping wi and wo adds pi to phi_d (MERL's reciprocity fold).
  FromHalfDiff(0.4, 0.5, 0.7, &wi, &wo);
  const HalfDiff a = ToHalfDiff(wi, wo), b = ToHalfDiff(wo, wi);
  EXPECT_NEAR(std::remainder(b.phi_d - a.phi_d - kPi, 2 * kPi), 0.0, 1e-12);
}

TEST(MerlBrdfTest, GridPointsAreExact) {
  const AnalyticBrdf analytic;
  const MerlBrdf trilinear(SyntheticMerl(0.3));
  const MerlBrdf truncate(SyntheticMerl(0.3), MerlLookup::kTruncate);
  std::mt19937 rng(11);
  double worst = 0;
  int checked = 0;
  for (int n = 0; n < 20000; ++n) {
    const int i = static_cast<int>(rng() % kMerlThetaH), j = static_cast<int>(rng() % kMerlThetaD),
              k = static_cast<int>(rng() % kMerlPhiD);
    const Vec3d expected = analytic.Angles(MerlThetaH(i), MerlThetaD(j), MerlPhiD(k));
    if (expected.x <= 0) continue;  // below the horizon: stored as 0
    worst = std::max(
        worst, MaxRelativeDifference(
                   trilinear.EvalAngles(MerlThetaH(i), MerlThetaD(j), MerlPhiD(k)), expected));
    worst = std::max(
        worst, MaxRelativeDifference(truncate.EvalAngles(MerlThetaH(i), MerlThetaD(j), MerlPhiD(k)),
                                     expected));
    worst = std::max(worst, MaxRelativeDifference(trilinear.Cell(i, j, k), expected));
    ++checked;
  }
  std::printf("grid points: %d checked, max relative difference %.3g\n", checked, worst);
  EXPECT_GT(checked, 5000);
  EXPECT_LT(worst, 1e-13);  // value / scale * scale in double
}

// Relative interpolation error of the trilinear lookup between grid points, away from grazing
// (both directions at least 17 degrees above the horizon, the cells around them valid).
struct ErrorStats {
  double median = 0, p99 = 0, max = 0;
};
ErrorStats InterpolationError(double alpha, MerlLookup lookup) {
  AnalyticBrdf analytic;
  analytic.alpha = alpha;
  const MerlBrdf merl(SyntheticMerl(alpha), lookup);
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> errors;
  while (errors.size() < 20000) {
    const double th = u(rng) * 0.5 * kPi, td = u(rng) * 0.5 * kPi, pd = (u(rng) * 2 - 1) * kPi;
    Vec3d wi, wo;
    FromHalfDiff(th, td, pd, &wi, &wo);
    if (wi.z < 0.3 || wo.z < 0.3) continue;
    errors.push_back(MaxRelativeDifference(merl.Eval(wi, wo), analytic(wi, wo)));
  }
  std::sort(errors.begin(), errors.end());
  return {errors[errors.size() / 2], errors[errors.size() * 99 / 100], errors.back()};
}

TEST(MerlBrdfTest, InterpolationErrorBetweenGridPoints) {
  // The bounds are the ones stated in docs/measured_and_imported.md (measured, then rounded up).
  const ErrorStats broad = InterpolationError(0.3, MerlLookup::kTrilinear);
  const ErrorStats sharp = InterpolationError(0.1, MerlLookup::kTrilinear);
  const ErrorStats broad_trunc = InterpolationError(0.3, MerlLookup::kTruncate);
  std::printf("trilinear alpha 0.3: median %.3g p99 %.3g max %.3g\n", broad.median, broad.p99,
              broad.max);
  std::printf("trilinear alpha 0.1: median %.3g p99 %.3g max %.3g\n", sharp.median, sharp.p99,
              sharp.max);
  std::printf("truncate  alpha 0.3: median %.3g p99 %.3g max %.3g\n", broad_trunc.median,
              broad_trunc.p99, broad_trunc.max);
  EXPECT_LT(broad.median, 5e-4);
  EXPECT_LT(broad.p99, 2e-3);
  EXPECT_LT(broad.max, 5e-3);
  EXPECT_LT(sharp.median, 1e-3);
  EXPECT_LT(sharp.p99, 1e-2);
  EXPECT_LT(sharp.max, 2e-2);
  // Interpolation is what makes the table usable for fitting: truncation is far worse.
  EXPECT_GT(broad_trunc.median, 5 * broad.median);
}

TEST(MerlBrdfTest, ReciprocityAndHemisphere) {
  const MerlBrdf merl(SyntheticMerl(0.3));
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int n = 0; n < 2000; ++n) {
    auto dir = [&] {
      const double z = u(rng), phi = 2 * kPi * u(rng), r = std::sqrt(1 - z * z);
      return Vec3d{r * std::cos(phi), r * std::sin(phi), z};
    };
    const Vec3d wi = dir(), wo = dir();
    const Vec3d a = merl.Eval(wi, wo), b = merl.Eval(wo, wi);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c], b[c], 1e-12 * std::max(1.0, a[c]));
    const Vec3d below = merl.Eval(Vec3d{wi.x, wi.y, -wi.z}, wo);
    EXPECT_EQ(below.x, 0.0);
  }
}

// --- The published layout, checked by a reader written here -------------------------------------
//
// Matusik, Pfister, Brand, McMillan 2003 ("A Data-Driven Reflectance Model") and the MERL BRDF
// database's description of its files: a .binary file is three little-endian int32 (90, 90, 180)
// followed by three channel blocks (R, G, B) of 90 * 90 * 180 float64. Within a block the cell of
// (theta_h index i, theta_d index j, phi_d index k) is at phi_d_idx + 180 * (theta_d_idx + 90 *
// theta_h_idx). A direction pair maps to indices through Rusinkiewicz's half/difference angles:
// i = sqrt(theta_h / (pi/2)) * 90, j = theta_d / (pi/2) * 90, k = phi_d / pi * 180 with phi_d
// folded into [0, pi) by adding pi to negative values (reciprocity); the stored numbers are scaled
// by 1/1500, 1.15/1500 and 1.66/1500 for R, G and B. Everything below is written from that
// description and shares no code with the reader under test (nor with WriteMerlBinary).
namespace published {

constexpr int kTh = 90, kTd = 90, kPd = 180;
constexpr std::size_t kBlock = static_cast<std::size_t>(kTh) * kTd * kPd;
constexpr double kScale[3] = {1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0};

// Stored value of (i, j, k, c): distinct for every cell and channel (c * 1e7 + i * 1e5 + j * 1e3
// + k + 1 with k < 1000, j * 1e3 + k < 1e5, i * 1e5 + ... < 1e7) and affine in (i, j, k), so a
// trilinear lookup at continuous indices (u, v, w) inside the table must return Stored(u, v, w).
double Stored(double i, double j, double k, int c) { return c * 1e7 + i * 1e5 + j * 1e3 + k + 1; }

void AppendLittleEndian(std::vector<unsigned char>* bytes, std::uint64_t bits, int n) {
  for (int b = 0; b < n; ++b)
    bytes->push_back(static_cast<unsigned char>((bits >> (8 * b)) & 0xff));
}

// Writes the table byte by byte.
std::string WriteLayoutFile() {
  const std::string path = testing::OutputDir() + "/published-layout.binary";
  std::vector<unsigned char> bytes;
  bytes.reserve(12 + 3 * kBlock * 8);
  for (std::int32_t d : {kTh, kTd, kPd})
    AppendLittleEndian(&bytes, static_cast<std::uint32_t>(d), 4);
  for (int c = 0; c < 3; ++c) {
    for (std::size_t n = 0; n < kBlock; ++n) {
      // Invert n = k + 180 * (j + 90 * i).
      const int k = static_cast<int>(n % kPd);
      const int j = static_cast<int>((n / kPd) % kTd);
      const int i = static_cast<int>(n / (static_cast<std::size_t>(kPd) * kTd));
      const double v = Stored(i, j, k, c);
      std::uint64_t bits;
      std::memcpy(&bits, &v, sizeof(bits));
      AppendLittleEndian(&bytes, bits, 8);
    }
  }
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
  EXPECT_TRUE(out.good()) << path;
  return path;
}

struct Direction {
  double x, y, z;
};
// MERL's standard coordinates: (theta, phi) of a direction about the normal +z.
Direction FromSpherical(double theta, double phi) {
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

// Continuous indices (u, v, w) of an incoming/outgoing pair: half vector h = (in + out)/|in + out|,
// theta_h, phi_h its spherical angles; the difference vector is `in` rotated by -phi_h about the
// normal, then by -theta_h about the binormal (0, 1, 0) (Rusinkiewicz 1998, section 3).
void Indices(const Direction& in, const Direction& out, double* u, double* v, double* w) {
  const double hx = in.x + out.x, hy = in.y + out.y, hz = in.z + out.z;
  const double len = std::sqrt(hx * hx + hy * hy + hz * hz);
  const double theta_h = std::acos(hz / len), phi_h = std::atan2(hy, hx);
  // Rotation about z by angle a: (x cos a - y sin a, x sin a + y cos a, z), here a = -phi_h.
  const double a = -phi_h;
  const double x1 = in.x * std::cos(a) - in.y * std::sin(a);
  const double y1 = in.x * std::sin(a) + in.y * std::cos(a);
  const double z1 = in.z;
  // Rotation about y by angle b: (x cos b + z sin b, y, -x sin b + z cos b), here b = -theta_h.
  const double b = -theta_h;
  const double dx = x1 * std::cos(b) + z1 * std::sin(b);
  const double dy = y1;
  const double dz = -x1 * std::sin(b) + z1 * std::cos(b);
  const double theta_d = std::acos(std::clamp(dz, -1.0, 1.0));
  double phi_d = std::atan2(dy, dx);
  if (phi_d < 0) phi_d += kPi;
  *u = std::sqrt(theta_h / (kPi / 2)) * kTh;
  *v = theta_d / (kPi / 2) * kTd;
  *w = phi_d / kPi * kPd;
}

}  // namespace published

TEST(MerlBrdfTest, PublishedLayoutReadBack) {
  const std::string path = published::WriteLayoutFile();
  const MerlBrdf trilinear(path);
  const MerlBrdf truncate(path, MerlLookup::kTruncate);

  // Every cell through Cell(): a channel swap, an index transpose or a wrong scale fails here.
  std::mt19937 rng(23);
  for (int n = 0; n < 5000; ++n) {
    const int i = static_cast<int>(rng() % 90), j = static_cast<int>(rng() % 90),
              k = static_cast<int>(rng() % 180);
    const Vec3d cell = trilinear.Cell(i, j, k);
    for (int c = 0; c < 3; ++c) {
      const double expected = published::Stored(i, j, k, c) * published::kScale[c];
      ASSERT_NEAR(cell[c], expected, 1e-12 * expected) << i << " " << j << " " << k << " " << c;
    }
  }

  // Direction pairs in MERL's standard coordinates: the truncating lookup returns the cell the
  // published description selects, the trilinear one the affine table at the continuous index.
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  int truncated_checked = 0, trilinear_checked = 0;
  for (int n = 0; n < 20000; ++n) {
    const published::Direction in = published::FromSpherical(uni(rng) * 1.5, uni(rng) * 2 * kPi);
    const published::Direction out = published::FromSpherical(uni(rng) * 1.5, uni(rng) * 2 * kPi);
    double u, v, w;
    published::Indices(in, out, &u, &v, &w);
    const Vec3d wi{in.x, in.y, in.z}, wo{out.x, out.y, out.z};
    // Away from cell borders (1e-6 of an index) the truncation is unambiguous.
    auto near_border = [](double t) { return std::abs(t - std::round(t)) < 1e-6; };
    if (!near_border(u) && !near_border(v) && !near_border(w) && u < 90 && v < 90) {
      const int i = static_cast<int>(u), j = static_cast<int>(v), k = static_cast<int>(w) % 180;
      const Vec3d got = truncate.Eval(wi, wo);
      for (int c = 0; c < 3; ++c) {
        const double expected = published::Stored(i, j, k, c) * published::kScale[c];
        ASSERT_NEAR(got[c], expected, 1e-12 * expected)
            << "u " << u << " v " << v << " w " << w << " channel " << c;
      }
      ++truncated_checked;
    }
    // Inside the table, off the last theta cells (clamped) and the phi_d wrap (179 -> 0).
    if (u < 89 && v < 89 && w < 179) {
      const Vec3d got = trilinear.Eval(wi, wo);
      const Vec3d swapped = trilinear.Eval(wo, wi);  // phi_d + pi folds to the same index
      for (int c = 0; c < 3; ++c) {
        const double expected = published::Stored(u, v, w, c) * published::kScale[c];
        ASSERT_NEAR(got[c], expected, 1e-9 * expected)
            << "u " << u << " v " << v << " w " << w << " channel " << c;
        ASSERT_NEAR(swapped[c], expected, 1e-9 * expected) << "swapped, channel " << c;
      }
      ++trilinear_checked;
    }
  }
  std::printf("published layout: %d truncated and %d trilinear lookups checked\n",
              truncated_checked, trilinear_checked);
  EXPECT_GT(truncated_checked, 15000);
  EXPECT_GT(trilinear_checked, 15000);
}

// --- Bad files: one-line errors naming the file and the field. ---

void ExpectError(const std::function<void()>& f, const std::string& file,
                 const std::string& field) {
  try {
    f();
    ADD_FAILURE() << "no error for " << file;
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(file), std::string::npos) << what;
    EXPECT_NE(what.find(": " + field + ":"), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

TEST(MerlBrdfTest, WrongSizeIsAnError) {
  const std::string path = testing::OutputDir() + "/truncated.binary";
  {
    std::ifstream in(SyntheticMerl(0.3), std::ios::binary);
    std::vector<char> bytes(1000000);
    in.read(bytes.data(), bytes.size());
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), bytes.size());
  }
  ExpectError([&] { MerlBrdf b(path); }, path, "size");
  const std::string tiny = testing::OutputDir() + "/tiny.binary";
  std::ofstream(tiny, std::ios::binary) << "abc";
  ExpectError([&] { MerlBrdf b(tiny); }, tiny, "dims");
}

TEST(MerlBrdfTest, WrongHeaderIsAnError) {
  const std::string path = testing::OutputDir() + "/bad-dims.binary";
  fs::copy_file(SyntheticMerl(0.3), path, fs::copy_options::overwrite_existing);
  {
    std::fstream f(path, std::ios::binary | std::ios::in | std::ios::out);
    const std::int32_t dims[3] = {90, 90, 360};  // a full-phi table: not the MERL layout
    f.write(reinterpret_cast<const char*>(dims), sizeof(dims));
  }
  ExpectError([&] { MerlBrdf b(path); }, path, "dims");
}

TEST(MerlBrdfTest, MissingFileIsAnError) {
  const std::string path = testing::OutputDir() + "/no-such-file.binary";
  ExpectError([&] { LoadMeasuredBrdf(path); }, path, "brdf");
  const std::string txt = testing::OutputDir() + "/not-a-brdf.txt";
  std::ofstream(txt) << "x";
  ExpectError([&] { LoadMeasuredBrdf(txt); }, txt, "brdf");
}

}  // namespace
}  // namespace shadefit::reference_images
