// Objects against Cycles (issue 45, acceptance): GGX fitted by `shadefit fit` to the direct-light
// Cycles render of each shipped mesh (reference_images/objects; Principled BSDF is GGX) must
// recover the truth: relative RMSE at most 1% on the lit, unshadowed pixels, roughness within 0.02,
// and black wherever Cycles cast a shadow. The pixel classes come from a CPU ray cast of the
// scene and from the Cycles image itself, never from the GL render under test.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "shadefit/render/image.h"
#include "shadefit/render/scene.h"
#include "shadefit/render/shadows.h"

namespace {
namespace fs = std::filesystem;
using shadefit::Vec3d;

struct Case {
  std::string name;
  double roughness;  // The manifest's.
};

class ObjectsAgainstCycles : public ::testing::TestWithParam<Case> {};

// Whether every one of 3 x 3 camera rays through the pixel hits (a CPU ray cast of the scene).
bool WholePixel(const shadefit::Scene& scene, int x, int y) {
  for (int k = 0; k < 9; ++k) {
    if (!shadefit::Intersect(scene, shadefit::CameraRay(scene.camera, x + (k % 3 + 0.5) / 3,
                                                        y + (k / 3 + 0.5) / 3),
                             0, 1e30, nullptr)) {
      return false;
    }
  }
  return true;
}

// The pixel's squared relative error summed over RGB (the relative RMSE's, offset 0.01).
double RelativeSquaredError(const shadefit::Image& ref, const shadefit::Image& img, int x, int y) {
  double sum = 0;
  for (int ch = 0; ch < 3; ++ch) {
    const double r = ref.at(x, y, ch), t = img.at(x, y, ch);
    sum += std::pow((t - r) / (std::abs(r) + 0.01), 2);
  }
  return sum;
}

TEST_P(ObjectsAgainstCycles, GgxRecoversTheTruthOnTheUnshadowedPixels) {
  const Case c = GetParam();
  const std::string src = std::string(SHADEFIT_SOURCE_DIR) + "/reference_images/objects/";
  const fs::path out = fs::path(SHADEFIT_TEST_OUTPUT) / "objects_acceptance" / c.name;
  fs::create_directories(out);
  const std::string cmd = std::string(SHADEFIT_EXE) + " fit --ref " + src + c.name +
                          ".exr --model ggx --loss cuberoot --pixel-stride 2 -o " +
                          (out / "fit.json").string() + " > " + (out / "log.txt").string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream in(out / "fit.json");
  const nlohmann::json fit = nlohmann::json::parse(in);
  for (const auto& p : fit.at("parameters")) {
    if (p.at("name") == "roughness") {
      EXPECT_NEAR(p.at("value").get<double>(), c.roughness, 0.02);
    }
  }
  const shadefit::Image ref = shadefit::ReadImage(src + c.name + ".exr");
  const shadefit::Image img = shadefit::ReadImage((out / ("fit." + c.name + ".fit.exr")).string());
  // The scene the sidecar names: scenes/<mesh>-<lighting>.toml.
  std::ifstream sidecar(src + c.name + ".json");
  const nlohmann::json meta = nlohmann::json::parse(sidecar);
  const shadefit::Scene scene = shadefit::LoadScene(src + meta.at("scene_file").get<std::string>());
  const shadefit::Image edges = shadefit::ShadowEdgeMask(scene);
  const shadefit::Light& light = scene.lights.at(0);
  double sum = 0;
  long lit = 0, cast = 0;
  for (int y = 0; y < ref.height; ++y) {
    for (int x = 0; x < ref.width; ++x) {
      // Whole pixels only: every one of 3 x 3 rays hits.
      const bool whole = WholePixel(scene, x, y);
      if (!whole || edges.at(x, y, 0) > 0.5f) continue;
      shadefit::Hit hit;
      shadefit::Intersect(scene, shadefit::CameraRay(scene.camera, x + 0.5, y + 0.5), 0, 1e30, &hit);
      const Vec3d d = light.position - hit.position;
      const double dist = shadefit::Length(d);
      const Vec3d l = d / dist;
      const double ndotl = shadefit::Dot(hit.normal, l);
      if (ndotl < 0.1) continue;  // The terminator's facets: smooth normals over a polygon.
      const double ref_lum = ref.at(x, y, 0) + ref.at(x, y, 1) + ref.at(x, y, 2);
      if (ref_lum == 0.0) {  // Cycles cast a shadow here: the fit must be black too.
        ++cast;
        for (int ch = 0; ch < 3; ++ch) EXPECT_LT(img.at(x, y, ch), 1e-4) << c.name << " " << x << "," << y;
        continue;
      }
      if (!shadefit::LightReaches(scene, hit.object, hit.position, hit.normal, l, dist)) continue;
      ++lit;
      sum += RelativeSquaredError(ref, img, x, y);
    }
  }
  const double relative_rmse = std::sqrt(sum / (3.0 * lit));
  RecordProperty("relative_rmse", std::to_string(relative_rmse));
  RecordProperty("cast_shadow_pixels", std::to_string(cast));
  EXPECT_GT(lit, 2000);
  EXPECT_LE(relative_rmse, 0.01) << c.name << " over " << lit << " lit pixels";
}

// Environment light on an object: Suzanne under the studio HDRI (Cycles, 1024 spp, direct light
// only), where her ears, brow and eye sockets hide part of the sky from her own surface. The fit
// (the fitter's quadrature) and its GL render (the per-direction visibility bits) must recover
// the truth and reproduce Cycles on every whole pixel as on the sphere (the sphere under the same
// light: relative RMSE 0.032, measured; here 0.031); without the occlusion the sockets and the
// ears' inner sides are far too bright and neither holds.
TEST(ObjectsAgainstCyclesEnvironment, GgxRecoversTheTruthUnderTheStudioHdri) {
  const std::string name = "suzanne-red-plastic-env";
  const std::string src = std::string(SHADEFIT_SOURCE_DIR) + "/reference_images/objects/";
  const fs::path out = fs::path(SHADEFIT_TEST_OUTPUT) / "objects_acceptance" / name;
  fs::create_directories(out);
  const std::string cmd = std::string(SHADEFIT_EXE) + " fit --ref " + src + name +
                          ".exr --model ggx --loss cuberoot --pixel-stride 2 -o " +
                          (out / "fit.json").string() + " > " + (out / "log.txt").string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream in(out / "fit.json");
  const nlohmann::json fit = nlohmann::json::parse(in);
  for (const auto& p : fit.at("parameters")) {
    if (p.at("name") == "roughness") {
      EXPECT_NEAR(p.at("value").get<double>(), 0.3, 0.02);
    } else if (p.at("name") == "kd.r") {
      EXPECT_NEAR(p.at("value").get<double>(), 0.8, 0.02);
    }
  }
  const shadefit::Image ref = shadefit::ReadImage(src + name + ".exr");
  const shadefit::Image img = shadefit::ReadImage((out / ("fit." + name + ".fit.exr")).string());
  const shadefit::Scene scene = shadefit::LoadScene(src + "scenes/suzanne-env.toml");
  double sum = 0;
  long whole_pixels = 0;
  for (int y = 0; y < ref.height; ++y) {
    for (int x = 0; x < ref.width; ++x) {
      const bool whole = WholePixel(scene, x, y);
      if (!whole) continue;
      ++whole_pixels;
      sum += RelativeSquaredError(ref, img, x, y);
    }
  }
  const double relative_rmse = std::sqrt(sum / (3.0 * whole_pixels));
  RecordProperty("relative_rmse", std::to_string(relative_rmse));
  EXPECT_GT(whole_pixels, 10000);
  EXPECT_LE(relative_rmse, 0.035) << name << " over " << whole_pixels << " whole pixels";
}

// Interreflection: the full global-illumination Cycles render of Suzanne (8 bounces) holds light
// her ears and brow reflect onto her, which this renderer (direct light only) cannot make. Its
// sidecar does not state direct light only, so the pixels whose hemisphere she hides by more than
// kInterreflectionShareMax leave the measured domain (a reason of their own in the job records):
// fitted to the rest, GGX recovers the diffuse colour within 2.5% (measured: kd.r 0.815; with
// every pixel, 0.839), and the direct-light twin of the same view keeps every pixel.
TEST(ObjectsAgainstCyclesInterreflection, StrongInterreflectionIsLeftOutOfTheFit) {
  const std::string src = std::string(SHADEFIT_SOURCE_DIR) + "/reference_images/objects/";
  const fs::path out = fs::path(SHADEFIT_TEST_OUTPUT) / "objects_acceptance" / "gi";
  fs::create_directories(out);
  // The fit's record of one reference: its parameters and how many pixels it fitted.
  auto fit = [&](const std::string& name) {
    const std::string json = (out / (name + ".json")).string();
    const std::string cmd = std::string(SHADEFIT_EXE) + " fit --ref " + src + name +
                            ".exr --model ggx --loss cuberoot --pixel-stride 2 -o " + json +
                            " > " + (out / (name + ".log")).string() + " 2>&1";
    EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
    std::ifstream in(json);
    return nlohmann::json::parse(in);
  };
  const nlohmann::json gi = fit("suzanne-gi-red-plastic-key");
  for (const auto& p : gi.at("parameters")) {
    if (p.at("name") == "kd.r") {
      EXPECT_NEAR(p.at("value").get<double>(), 0.8, 0.02);
    } else if (p.at("name") == "roughness") {
      EXPECT_NEAR(p.at("value").get<double>(), 0.3, 0.02);
    }
  }
  const nlohmann::json direct = fit("suzanne-red-plastic-key");
  const double gi_pixels = gi.at("rmse").at("per_reference").at(0).at("pixels").get<double>();
  const double direct_pixels =
      direct.at("rmse").at("per_reference").at(0).at("pixels").get<double>();
  // Suzanne hides more than a tenth of her sky at about a sixth of her lit pixels.
  EXPECT_LT(gi_pixels, 0.9 * direct_pixels) << gi_pixels << " of " << direct_pixels;
  EXPECT_GT(gi_pixels, 0.6 * direct_pixels) << gi_pixels << " of " << direct_pixels;
}

INSTANTIATE_TEST_SUITE_P(
    Meshes, ObjectsAgainstCycles,
    ::testing::Values(Case{"suzanne-red-plastic-key", 0.3}, Case{"suzanne-gold-key", 0.25},
                      Case{"suzanne-aluminium-key", 0.15}, Case{"torus-red-plastic-key", 0.3},
                      Case{"torus-gold-key", 0.25}, Case{"torus-aluminium-key", 0.15},
                      Case{"torus-knot-red-plastic-key", 0.3}, Case{"torus-knot-gold-key", 0.25},
                      Case{"torus-knot-aluminium-key", 0.15}),
    [](const ::testing::TestParamInfo<Case>& info) {
      std::string n = info.param.name;
      for (char& ch : n) ch = std::isalnum(static_cast<unsigned char>(ch)) ? ch : '_';
      return n;
    });

}  // namespace
