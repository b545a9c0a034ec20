// Radiometric agreement with Blender Cycles on the shipped references (references issue): what
// makes every later verdict about models rather than about conventions.
//  - White Lambert: our render matches Cycles' with mean relative error <= 0.5% over interior
//    pixels (full coverage in both, radiance above 1% of the image maximum: the terminator's
//    relative error is meaningless).
//  - Every point-lit Principled single-scatter reference: our cycles-principled twin reproduces
//    it with relative RMSE <= 1%, where relative RMSE = RMSE / RMS(reference) over pixels with
//    full coverage in both images and all three channels. One exception is measured, not
//    waived: a highlight narrower than a pixel (roughness 0.05 at 256^2) puts 90-100% of the
//    squared error into its 1-4 peak pixels, whose value moves 1.1% per 0.002 px of sub-pixel
//    position (our double-precision CPU twin agrees with the GL render to 1e-6 there, so the
//    difference is Cycles' own float ray set-up). For those references the test requires the
//    peak pixels (radiance above half the image maximum) to be at most 16 and within 20%, and
//    every other pixel to meet the 1% bound. Measured: 4 of 42 references take this branch; the
//    worst is silver-mirror-mirror85 (grazing plane: 16 peak pixels, worst 15.9%, rest 0.04%).
//  - Every environment-lit reference (the four *-env, studio.exr): Lambert or cycles-principled
//    at the true parameters, within a per-reference relative RMSE bound just above Cycles' own
//    1024 spp noise (0.55%-0.8%) and 0.3% on 8 x 8 block means (see kEnvSamples).
// The material comes from each reference's sidecar JSON; the scene from its scene TOML.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <stdexcept>

#include "test_util.h"

namespace shadefit {
namespace {

namespace fs = std::filesystem;

const fs::path kCyclesDir = fs::path(SHADEFIT_SOURCE_DIR) / "reference_images" / "cycles";

struct Agreement {
  double mean_relative = 0;  // Mean |ours - ref| / ref.
  double relative_rmse = 0;  // RMSE / RMS(ref).
  int pixels = 0;
  // Sub-pixel highlights: pixels above half the image maximum, their worst relative error, and
  // the relative RMSE of all other pixels.
  int peak_pixels = 0;
  double peak_max_relative = 0;
  double relative_rmse_without_peak = 0;
};

Agreement Compare(const Image& ours, const Image& ref, bool interior_only) {
  float max_ref = 0;
  for (std::size_t i = 0; i < ref.PixelCount(); ++i) max_ref = std::max(max_ref, ref.data[4 * i]);
  double sum_rel = 0, sum_sq = 0, sum_ref_sq = 0, rest_sq = 0, rest_ref_sq = 0;
  Agreement a;
  for (int y = 0; y < ref.height; ++y) {
    for (int x = 0; x < ref.width; ++x) {
      if (ref.at(x, y, 3) < 1.0f || ours.at(x, y, 3) < 1.0f) continue;
      if (interior_only && ref.at(x, y, 0) < 0.01f * max_ref) continue;
      const bool peak = ref.at(x, y, 0) > 0.5f * max_ref;
      for (int c = 0; c < 3; ++c) {
        const double r = ref.at(x, y, c), o = ours.at(x, y, c);
        sum_sq += (o - r) * (o - r);
        sum_ref_sq += r * r;
        if (interior_only) sum_rel += std::abs(o - r) / r;
        if (peak) {
          a.peak_max_relative = std::max(a.peak_max_relative, std::abs(o - r) / r);
        } else {
          rest_sq += (o - r) * (o - r);
          rest_ref_sq += r * r;
        }
      }
      a.peak_pixels += peak;
      ++a.pixels;
    }
  }
  a.mean_relative = a.pixels ? sum_rel / (3.0 * a.pixels) : 0;
  a.relative_rmse = sum_ref_sq > 0 ? std::sqrt(sum_sq / sum_ref_sq) : 0;
  a.relative_rmse_without_peak = rest_ref_sq > 0 ? std::sqrt(rest_sq / rest_ref_sq) : 0;
  return a;
}

struct Case {
  std::string name;
  nlohmann::json sidecar;
};

std::vector<Case> ShippedCases() {
  std::vector<Case> cases;
  if (!fs::is_directory(kCyclesDir)) return cases;
  for (const auto& entry : fs::directory_iterator(kCyclesDir)) {
    if (entry.path().extension() != ".json") continue;
    std::ifstream in(entry.path());
    cases.push_back({entry.path().stem().string(), nlohmann::json::parse(in)});
  }
  std::sort(cases.begin(), cases.end(), [](const Case& a, const Case& b) { return a.name < b.name; });
  return cases;
}

// The sidecar's Principled BSDF as cycles-principled parameters (the model reproduces it).
std::vector<double> PrincipledParams(const Case& c) {
  const ModelInfo& model = FindModel("cycles-principled");
  const auto& m = c.sidecar["material"];
  std::vector<double> p = DefaultParams(model);
  SetParam(model, "base_color", m["base_color"].get<std::vector<double>>(), c.name, &p);
  SetParam(model, "metallic", {m["metallic"].get<double>()}, c.name, &p);
  SetParam(model, "specular", {m["specular"].get<double>()}, c.name, &p);
  SetParam(model, "roughness", {m["roughness"].get<double>()}, c.name, &p);
  return p;
}

bool IsPointLit(const Scene& scene) { return scene.EnvironmentLight() < 0; }

TEST(CyclesAgreement, LambertCalibration) {
  int checked = 0;
  for (const Case& c : ShippedCases()) {
    if (c.sidecar["material"]["type"] != "diffuse") continue;
    const Scene scene = LoadScene((kCyclesDir / c.sidecar["scene_file"].get<std::string>()).string());
    if (!IsPointLit(scene)) continue;
    const auto& bc = c.sidecar["material"]["base_color"];
    const Image ours = testing::SharedRenderer().Render(scene, ModelId::kLambert,
                                                        {bc[0], bc[1], bc[2]});
    const Image ref = ReadImage((kCyclesDir / (c.name + ".exr")).string());
    const Agreement a = Compare(ours, ref, true);
    std::printf("[ cycles ] %-28s lambert mean relative error %.5f over %d px\n", c.name.c_str(),
                a.mean_relative, a.pixels);
    EXPECT_GT(a.pixels, 100) << c.name;
    EXPECT_LE(a.mean_relative, 0.005) << c.name;
    ++checked;
  }
  EXPECT_GE(checked, 3) << "shipped Lambert references missing from " << kCyclesDir;
}

TEST(CyclesAgreement, PrincipledTwinReproducesEveryPointLitSingleScatterReference) {
  const ModelInfo& model = FindModel("cycles-principled");
  int checked = 0;
  for (const Case& c : ShippedCases()) {
    const auto& m = c.sidecar["material"];
    if (m["type"] != "principled" || m.value("distribution", "GGX") != "GGX") continue;
    const Scene scene = LoadScene((kCyclesDir / c.sidecar["scene_file"].get<std::string>()).string());
    if (!IsPointLit(scene)) continue;
    const Image ours = testing::SharedRenderer().Render(scene, model.id, PrincipledParams(c));
    const Image ref = ReadImage((kCyclesDir / (c.name + ".exr")).string());
    const Agreement a = Compare(ours, ref, false);
    std::printf("[ cycles ] %-28s cycles-principled relative RMSE %.5f over %d px "
                "(%d peak px: worst %.4f, rest %.5f)\n",
                c.name.c_str(), a.relative_rmse, a.pixels, a.peak_pixels, a.peak_max_relative,
                a.relative_rmse_without_peak);
    EXPECT_GT(a.pixels, 100) << c.name;
    if (a.relative_rmse > 0.01) {
      // Sub-pixel highlight (see the header): bounded peak, and 1% everywhere else.
      EXPECT_LE(a.peak_pixels, 16) << c.name;
      EXPECT_LE(a.peak_max_relative, 0.2) << c.name;
      EXPECT_LE(a.relative_rmse_without_peak, 0.01) << c.name;
    }
    ++checked;
  }
  EXPECT_GE(checked, 30) << "shipped Principled references missing from " << kCyclesDir;
}

// Relative RMSE of 8 x 8 pixel block means (blocks fully covered in both images): per-pixel
// noise, Cycles' above all, averages out, and what is left is systematic (orientation, scale,
// shape).
double BlockRelativeRmse(const Image& ours, const Image& ref) {
  constexpr int kBlock = 8;
  double sum_sq = 0, sum_ref_sq = 0;
  for (int by = 0; by + kBlock <= ref.height; by += kBlock) {
    for (int bx = 0; bx + kBlock <= ref.width; bx += kBlock) {
      double o[3] = {0, 0, 0}, r[3] = {0, 0, 0};
      bool full = true;
      for (int y = by; y < by + kBlock; ++y) {
        for (int x = bx; x < bx + kBlock; ++x) {
          full = full && ref.at(x, y, 3) >= 1.0f && ours.at(x, y, 3) >= 1.0f;
          for (int c = 0; c < 3; ++c) {
            o[c] += ours.at(x, y, c);
            r[c] += ref.at(x, y, c);
          }
        }
      }
      if (!full) continue;
      for (int c = 0; c < 3; ++c) {
        sum_sq += (o[c] - r[c]) * (o[c] - r[c]);
        sum_ref_sq += r[c] * r[c];
      }
    }
  }
  return sum_ref_sq > 0 ? std::sqrt(sum_sq / sum_ref_sq) : 0;
}

// Every environment-lit reference (studio.exr, rotation 0; Cycles at 1024 spp) at its true
// parameters: what pins Cycles' environment orientation (azimuth sense, +Z up, u = 0.5 on +X)
// and the map's radiance scale. Turning the map by 3 degrees raises the block error to
// 0.027-0.28 and the pixel error to 0.029-0.82; by 180 degrees, to 0.34-1.05 and 0.34-1.75.
// Measured (llvmpipe, 4096 samples per technique; the render is deterministic):
//   reference          pixel rel. RMSE   8x8 block rel. RMSE
//   gold-env           0.00521           0.00093
//   red-plastic-env    0.00749           0.00196
//   white-glossy-env   0.00653           0.00234
//   white-lambert-env  0.00722           0.00242
// The pixel figure is Cycles' own 1024 spp noise: doubling our samples to 8192 lowers it by
// only 0.0002-0.001 (to 0.00497-0.00709), so each pixel bound sits just above its measurement.
// The block figure is what is left of our fixed sample set's error (0.0007-0.0014 at 8192): one
// bound of 0.003 for all four. 4096 samples, not 2048: the environment technique uses one
// direction set for every pixel, and the 2048-point set happens to bias all four renders by
// +0.5% to +2.3% (block error 0.005-0.023); 1024 and 4096 stay within 0.2%.
constexpr int kEnvSamples = 4096;
constexpr double kEnvBlockBound = 0.003;

struct EnvCase {
  const char* name;
  double pixel_bound;  // Relative RMSE per pixel: just above the measurement above.
};
constexpr EnvCase kEnvCases[] = {
    {"gold-env", 0.0055},
    {"red-plastic-env", 0.0080},
    {"white-glossy-env", 0.0070},
    {"white-lambert-env", 0.0077},
};

// Our render of an environment-lit reference at its true parameters: Lambert for Cycles'
// Diffuse BSDF, the cycles-principled twin for the Principled BSDF.
Image RenderEnvCase(const Case& c, int samples) {
  Scene scene = LoadScene((kCyclesDir / c.sidecar["scene_file"].get<std::string>()).string());
  const int env = scene.EnvironmentLight();
  if (env < 0) throw std::runtime_error(c.name + ": scene has no environment light");
  scene.lights[env].samples = samples;
  const auto& m = c.sidecar["material"];
  if (m["type"] == "diffuse") {
    const auto& bc = m["base_color"];
    return testing::SharedRenderer().Render(scene, ModelId::kLambert, {bc[0], bc[1], bc[2]});
  }
  return testing::SharedRenderer().Render(scene, FindModel("cycles-principled").id,
                                         PrincipledParams(c));
}

TEST(CyclesAgreement, EveryEnvironmentLitReferenceAtItsTrueParameters) {
  std::map<std::string, Case> by_name;
  for (Case& c : ShippedCases()) by_name.emplace(c.name, std::move(c));
  for (const EnvCase& e : kEnvCases) {
    SCOPED_TRACE(e.name);
    const auto it = by_name.find(e.name);
    ASSERT_NE(it, by_name.end()) << "shipped reference missing from " << kCyclesDir;
    const Case& c = it->second;
    const Image ref = ReadImage((kCyclesDir / (c.name + ".exr")).string());
    const Image ours = RenderEnvCase(c, kEnvSamples);
    const Agreement a = Compare(ours, ref, false);
    const double block = BlockRelativeRmse(ours, ref);
    std::printf("[ cycles ] %-28s environment relative RMSE %.5f over %d px (bound %.4f), "
                "8x8 blocks %.5f (bound %.4f)\n",
                c.name.c_str(), a.relative_rmse, a.pixels, e.pixel_bound, block, kEnvBlockBound);
    EXPECT_GT(a.pixels, 30000);
    EXPECT_LE(a.relative_rmse, e.pixel_bound);
    EXPECT_LE(block, kEnvBlockBound);
    if (a.relative_rmse > e.pixel_bound || block > kEnvBlockBound) {
      const std::string dir = testing::TestOutputDir("cycles_agreement");
      Image error = ours;
      for (std::size_t i = 0; i < error.data.size(); ++i) {
        error.data[i] = std::abs(ours.data[i] - ref.data[i]);
      }
      WriteExr(dir + "/" + c.name + "-ours.exr", ours);
      WriteExr(dir + "/" + c.name + "-cycles.exr", ref);
      WriteExr(dir + "/" + c.name + "-error.exr", error);
    }
  }
}

}  // namespace
}  // namespace shadefit
