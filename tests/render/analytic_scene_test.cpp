// Acceptance 3 of the renderer issue: a Lambert sphere of albedo rho lit by a point light of
// intensity I. Each interior pixel must equal rho / pi * I * cos(theta) / d^2 within 1e-4
// relative (pbrt's analytic-scene idea), computed here in double from the hit point.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "shadefit/render/scene.h"
#include "test_util.h"

namespace shadefit {
namespace {

TEST(AnalyticScene, LambertSpherePointLight) {
  const double rho = 0.6, intensity = 7.5;
  const Vec3d light{2.0, -3.0, 1.5};
  const Scene scene = ParseScene(
      testing::SphereSceneToml(96, 96,
                               "[[lights]]\ntype = \"point\"\nposition = [2.0, -3.0, 1.5]\n"
                               "intensity = 7.5\n"),
      "analytic.toml");
  const Image image = testing::SharedRenderer().Render(scene, ModelId::kLambert, {rho, rho, rho});
  int checked = 0;
  double worst = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      Hit hit;
      if (!Intersect(scene, CameraRay(scene.camera, x + 0.5, y + 0.5), 0.0, 1e30, &hit)) continue;
      if (image.at(x, y, 3) < 1.0f) continue;
      const Vec3d d = light - hit.position;
      const double d2 = Dot(d, d);
      const double cos_theta = Dot(hit.normal, d / std::sqrt(d2));
      if (cos_theta < 0.05) continue;  // Interior of the lit region, away from the terminator.
      const double expected = rho / kPi * intensity * cos_theta / d2;
      const double rel = std::abs(image.at(x, y, 0) - expected) / expected;
      worst = std::max(worst, rel);
      ++checked;
    }
  }
  EXPECT_GT(checked, 2000);
  EXPECT_LE(worst, 1e-4) << "over " << checked << " pixels";
}

// Row 0 is the top: a light above the sphere (+Z, the camera's up) lights the top rows.
TEST(AnalyticScene, RowZeroIsTop) {
  const Scene scene = ParseScene(
      testing::SphereSceneToml(32, 32,
                               "[[lights]]\ntype = \"directional\"\ndirection = [0.0, 0.0, -1.0]\n"
                               "irradiance = 1.0\n"),
      "top.toml");
  const Image image = testing::SharedRenderer().Render(scene, ModelId::kLambert, {1, 1, 1});
  EXPECT_GT(image.at(16, 6, 0), 0.1f);
  EXPECT_EQ(image.at(16, 26, 0), 0.0f);
}

// Supersampling: coverage on the silhouette equals the analytic fraction. The unit sphere seen
// from distance 6 on the optical axis projects to a disc of angular radius asin(1/6), i.e. of
// radius R = tan(asin(1/6)) / tan(fov/2) * 24 = (1/sqrt(35)) / tan(11 deg) * 24 = 20.87 px about
// the image centre (24, 24). With supersample = 4 the renderer takes the 4 x 4 grid of points
// (i + 0.5) / 4 in each pixel (docs/scenes.md: N x N stratified samples), so a pixel's coverage
// is the count of those points inside the disc over 16; and it approximates the area fraction.
TEST(AnalyticScene, SupersamplingGivesCoverage) {
  std::string toml = testing::SphereSceneToml(
      48, 48, "[[lights]]\ntype = \"point\"\nposition = [0.0, -6.0, 0.0]\npower = 100.0\n");
  toml.insert(toml.find("[[objects]]"), "supersample = 4\n");
  const Scene scene = ParseScene(toml, "ss.toml");
  const Image image = testing::SharedRenderer().Render(scene, ModelId::kLambert, {1, 1, 1});
  const double radius = (1.0 / std::sqrt(35.0)) / std::tan(11.0 * kPi / 180.0) * 24.0;
  auto inside = [&](double px, double py) { return std::hypot(px - 24.0, py - 24.0) < radius; };
  int partial = 0, exact = 0, off_by_one = 0;
  double total = 0, worst_area = 0;
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 48; ++x) {
      const float a = image.at(x, y, 3);
      total += a;
      int grid = 0;
      for (int sy = 0; sy < 4; ++sy) {
        for (int sx = 0; sx < 4; ++sx) grid += inside(x + (sx + 0.5) / 4, y + (sy + 0.5) / 4);
      }
      int fine = 0;
      for (int sy = 0; sy < 64; ++sy) {
        for (int sx = 0; sx < 64; ++sx) fine += inside(x + (sx + 0.5) / 64, y + (sy + 0.5) / 64);
      }
      const double area = fine / 4096.0;
      if (a > 0.0f && a < 1.0f) ++partial;
      // Float rays can flip a sample that lies within ~1e-5 px of the silhouette.
      const double diff = std::abs(a - grid / 16.0);
      if (diff < 1e-6) {
        ++exact;
      } else {
        EXPECT_LE(diff, 1.0 / 16 + 1e-6) << "pixel " << x << ", " << y;
        ++off_by_one;
      }
      if (area > 0 && area < 1) worst_area = std::max(worst_area, std::abs(a - area));
    }
  }
  std::printf("[ coverage ] %d partial pixels, %d match the 4x4 grid count, %d off by one sample; "
              "total %.2f px^2 (disc %.2f), worst |coverage - area| %.3f\n",
              partial, exact, off_by_one, total, kPi * radius * radius, worst_area);
  EXPECT_GT(partial, 100);
  EXPECT_LE(off_by_one, 2);
  EXPECT_NEAR(total, kPi * radius * radius, 0.005 * kPi * radius * radius);
  EXPECT_LT(worst_area, 0.2);
  EXPECT_EQ(image.at(24, 24, 3), 1.0f);
  EXPECT_EQ(image.at(0, 0, 3), 0.0f);
}

}  // namespace
}  // namespace shadefit

namespace shadefit {
namespace {

// Orthographic camera: `height` is the full vertical extent (Cycles' ortho_scale with vertical
// sensor fit), so a unit sphere seen with height 2.4 on 240 rows has a radius of 100 pixels.
TEST(AnalyticScene, OrthographicCameraScale) {
  const Scene scene = ParseScene(
      "[camera]\ntype = \"orthographic\"\nposition = [0.0, -6.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\n"
      "up = [0.0, 0.0, 1.0]\nheight = 2.4\nresolution = [320, 240]\nsupersample = 4\n"
      "[[objects]]\ntype = \"sphere\"\n"
      "[[lights]]\ntype = \"directional\"\ndirection = [0.0, 1.0, 0.0]\nirradiance = 1.0\n",
      "ortho.toml");
  const Image image = testing::SharedRenderer().Render(scene, ModelId::kLambert, {1, 1, 1});
  double covered = 0;
  for (std::size_t i = 0; i < image.PixelCount(); ++i) covered += image.data[4 * i + 3];
  EXPECT_NEAR(covered, kPi * 100.0 * 100.0, 0.002 * kPi * 1e4);  // Area of the disc in pixels.
  // The disc is centred: coverage is symmetric about the image centre (160, 120).
  EXPECT_FLOAT_EQ(image.at(60, 120, 3), image.at(259, 120, 3));
  EXPECT_FLOAT_EQ(image.at(160, 20, 3), image.at(160, 219, 3));
}

}  // namespace
}  // namespace shadefit
