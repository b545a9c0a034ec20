// Environment lighting: the GL renderer's fixed-sample MIS integration against a brute-force CPU
// estimate with 2^16 independent random samples per technique, at pixels across the sphere.
// The tolerances here are the numbers stated in docs/environment.md.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <algorithm>
#include <random>

#include "shadefit/render/environment.h"
#include "shadefit/render/gbuffer.h"
#include "test_util.h"

namespace shadefit {
namespace {

// A synthetic map with structure in every direction: a sky gradient, a warm ground, and a small
// bright "sun" (HDR: a Gaussian of 0.1 rad width peaking at 100x the sky), so both the map
// sampling and the BRDF sampling matter. (A hard-edged disc is avoided on purpose: GL's bilinear
// weights have 8 fractional bits on llvmpipe, which biases a 300:1 edge by a few percent.)
std::string WriteSyntheticMap() {
  const int w = 256, h = 128;
  Image map(w, h, 3);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double v = 1.0 - (y + 0.5) / h, u = (x + 0.5) / w;
      const Vec3d d = EquirectToDirection(u, v);
      const Vec3d sun = Normalize(Vec3d{0.5, -0.6, 0.6});
      const double angle = std::acos(std::clamp(Dot(d, sun), -1.0, 1.0));
      const double s = 100.0 * std::exp(-(angle / 0.1) * (angle / 0.1));
      const double sky = d.z > 0 ? 0.5 + 0.5 * d.z : 0.0;
      const double ground = d.z <= 0 ? 0.3 : 0.0;
      map.at(x, y, 0) = static_cast<float>(s + 0.6 * sky + 0.5 * ground);
      map.at(x, y, 1) = static_cast<float>(s + 0.8 * sky + 0.35 * ground);
      map.at(x, y, 2) = static_cast<float>(s + 1.0 * sky + 0.2 * ground);
    }
  }
  const std::string path = testing::TestOutputDir("environment") + "/synthetic_sky.exr";
  WriteExr(path, map);
  return path;
}

// Brute-force estimate at one shading point: independent uniform random numbers (not the GL
// point set), environment + cosine + GGX-lobe sampling, balance heuristic.
Vec3d BruteForce(const EnvironmentMap& env, ModelId model, const std::vector<double>& p,
                 const Vec3d& n, const Vec3d& v, int samples) {
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double alpha = SpecularLobeAlpha(model, p.data());
  const Vec3d t = Normalize(std::abs(n.z) < 0.999 ? Cross(Vec3d{0, 0, 1}, n)
                                                   : Cross(Vec3d{1, 0, 0}, n));
  const Vec3d b = Cross(n, t);
  auto to_world = [&](const Vec3d& a) { return t * a.x + b * a.y + n * a.z; };
  auto pdf_sum = [&](const Vec3d& l) {
    double pdf = env.Pdf(l) + std::max(Dot(n, l), 0.0) / kPi;
    if (alpha > 0 && Dot(n, l) > 0) {
      const Vec3d h = Normalize(l + v);
      const double NoH = Dot(n, h), VoH = Dot(v, h);
      if (NoH > 0 && VoH > 0) pdf += D_GGX(NoH, 1.0 - NoH * NoH, alpha) * NoH / (4 * VoH);
    }
    return pdf;
  };
  Vec3d sum{0, 0, 0};
  for (int i = 0; i < samples; ++i) {
    Vec3d ls[3];
    ls[0] = env.Sample(u(rng), u(rng));
    const double u1 = u(rng), u2 = u(rng), r = std::sqrt(u1), phi = 2 * kPi * u2;
    ls[1] = to_world({r * std::cos(phi), r * std::sin(phi), std::sqrt(1 - u1)});
    int count = 2;
    if (alpha > 0) {
      const double a1 = u(rng), a2 = u(rng), al2 = alpha * alpha;
      const double c2 = (1 - a1) / (1 + (al2 - 1) * a1), st = std::sqrt(std::max(0.0, 1 - c2));
      const Vec3d h = to_world({st * std::cos(2 * kPi * a2), st * std::sin(2 * kPi * a2),
                                std::sqrt(c2)});
      ls[2] = h * (2 * Dot(v, h)) - v;
      count = 3;
    }
    for (int k = 0; k < count; ++k) {
      if (Dot(n, ls[k]) <= 0) continue;
      double f[3];
      Reflect(model, p.data(), n, ls[k], v, f);
      const double pdf = pdf_sum(ls[k]);
      if (!(pdf > 0)) continue;
      const Vec3d le = env.Radiance(ls[k]);
      for (int c = 0; c < 3; ++c) sum[c] += f[c] * le[c] / pdf;
    }
  }
  return sum / samples;
}

struct EnvCase {
  const char* model;
  std::vector<double> params;
  double tolerance;  // Mean relative error over the probed pixels.
};

class EnvironmentTest : public ::testing::TestWithParam<EnvCase> {};

TEST_P(EnvironmentTest, FixedSamplesMatchBruteForce) {
  const std::string map = WriteSyntheticMap();
  std::string toml = testing::SphereSceneToml(
      48, 48, "[[lights]]\ntype = \"environment\"\nfile = \"" + map +
                  "\"\nstrength = 1.0\nrotation_z = 30.0\nsamples = 256\n");
  const Scene scene = ParseScene(toml, "env.toml");
  const ModelInfo& model = FindModel(GetParam().model);
  Renderer& renderer = testing::SharedRenderer();
  const Image gl = renderer.Render(scene, model.id, GetParam().params);
  const GBuffer g = renderer.RenderGBuffer(scene);
  const EnvironmentMap env(ReadImage(map), 1.0, 30.0);
  double sum_rel = 0, worst = 0;
  int count = 0;
  for (int y = 4; y < 48; y += 8) {
    for (int x = 4; x < 48; x += 8) {
      if (!g.Hit(x, y) || g.Coverage(x, y) < 1) continue;
      const Vec3d n = Normalize(Vec3d{g.normal.at(x, y, 0), g.normal.at(x, y, 1),
                                      g.normal.at(x, y, 2)});
      const Vec3d v = Normalize(Vec3d{g.view.at(x, y, 0), g.view.at(x, y, 1), g.view.at(x, y, 2)});
      const Vec3d ref = BruteForce(env, model.id, GetParam().params, n, v, 1 << 16);
      const double lum_ref = ref.x + ref.y + ref.z;
      const double lum_gl = gl.at(x, y, 0) + gl.at(x, y, 1) + gl.at(x, y, 2);
      const double rel = std::abs(lum_gl - lum_ref) / lum_ref;
      sum_rel += rel;
      worst = std::max(worst, rel);
      ++count;
    }
  }
  const double mean = sum_rel / count;
  std::printf("[ env ] %s: mean relative error %.4f, worst %.4f over %d pixels\n",
              model.name.c_str(), mean, worst, count);
  EXPECT_GT(count, 15);
  EXPECT_LE(mean, GetParam().tolerance);
}

INSTANTIATE_TEST_SUITE_P(
    Models, EnvironmentTest,
    ::testing::Values(EnvCase{"lambert", {0.8, 0.8, 0.8}, 0.01},
                      EnvCase{"ggx", {0.5, 0.2, 0.1, 0.04, 0.04, 0.04, 0.5}, 0.02},
                      EnvCase{"ggx", {0.0, 0.0, 0.0, 0.9, 0.7, 0.3, 0.15}, 0.03},
                      EnvCase{"blinn-phong-normalized", {0.3, 0.3, 0.3, 0.5, 0.5, 0.5, 80}, 0.03}));

// White furnace: Lambert kd = 1 under a uniform environment of radiance 1 is 1 everywhere.
TEST(Environment, UniformFurnaceLambert) {
  const Scene scene = ParseScene(
      testing::SphereSceneToml(32, 32, "[[lights]]\ntype = \"uniform\"\nradiance = 1.0\n"),
      "furnace.toml");
  const Image img = testing::SharedRenderer().Render(scene, ModelId::kLambert, {1, 1, 1});
  double sum = 0;
  int count = 0;
  for (int y = 0; y < 32; ++y) {
    for (int x = 0; x < 32; ++x) {
      if (img.at(x, y, 3) < 1) continue;
      sum += img.at(x, y, 0);
      ++count;
    }
  }
  EXPECT_NEAR(sum / count, 1.0, 2e-3);
}

}  // namespace
}  // namespace shadefit
