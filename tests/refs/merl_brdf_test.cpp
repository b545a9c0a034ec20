// MERL .binary reader: coordinates, exact grid values, interpolation error, reciprocity, and
// bad files. Uses a table written from an analytic BRDF, no outside data.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <vector>

#include "refs_test_util.h"
#include "shadefit/refs/measured_brdf.h"
#include "shadefit/render/error.h"

namespace shadefit::refs {
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
}  // namespace shadefit::refs
