// Environment lighting: the GL renderer's fixed-sample MIS integration against a brute-force CPU
// estimate with 2^16 independent random samples per technique, and against a dense quadrature
// over the map's texels that shares no environment code (layout and Cycles' orientation written
// out here), at pixels across the sphere.
// The tolerances here are the numbers stated in docs/environment.md.
#include <gtest/gtest.h>

#include <ostream>

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
  int quadrature_fine = 2;  // Texel subdivision of the quadrature near the mirror direction.
  // Mean relative error against the texel quadrature; tight enough that the same pixels under
  // the opposite rotation fail it (checked below).
  double quadrature_tolerance = 0.01;
};
// What gtest prints for a case (and CTest puts in the test's name): the model and parameters.
void PrintTo(const EnvCase& c, std::ostream* os) {
  *os << c.model;
  for (double v : c.params) *os << " " << v;
}


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

// --- A reference that shares nothing with the environment code --------------------------------
//
// A dense quadrature over the map's texels, written from the layout docs/scenes.md and
// docs/environment.md give (Cycles' `direction_to_equirectangular`): a world direction d is looked
// up at m = Rz(rotation_z) d, u = -atan2(m.y, m.x) / (2 pi) + 0.5, v = atan2(m.z, hypot(m.x, m.y))
// / pi + 0.5, v = 0 at the bottom row. Inverting: texel column i, row j (row 0 on top) covers
// u in [i, i+1) / w, v in [h-1-j, h-j) / h, i.e. azimuth phi = (0.5 - u) 2 pi and elevation
// e = (v - 0.5) pi; its solid angle is (2 pi / w) (sin e_top - sin e_bottom). Radiance between
// texel centres is bilinear (GL's filter: centres at half-texel offsets, wrapping in u). Neither
// EnvironmentMap's Radiance, Pdf, Sample nor its rotation is used; the BRDF is the model's twin.
struct TexelQuadrature {
  const Image& map;  // RGB, row 0 on top, as read from the file
  double rotation_deg;

  Vec3d Bilinear(double u, double v) const {
    const int w = map.width, h = map.height;
    const double x = u * w - 0.5, y = (1.0 - v) * h - 0.5;
    const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
    const double fx = x - x0, fy = y - y0;
    auto texel = [&](int xi, int yi, int c) {
      xi = ((xi % w) + w) % w;
      yi = std::clamp(yi, 0, h - 1);
      return static_cast<double>(map.at(xi, yi, c));
    };
    Vec3d out;
    for (int c = 0; c < 3; ++c) {
      out[c] = (1 - fy) * ((1 - fx) * texel(x0, y0, c) + fx * texel(x0 + 1, y0, c)) +
               fy * ((1 - fx) * texel(x0, y0 + 1, c) + fx * texel(x0 + 1, y0 + 1, c));
    }
    return out;
  }

  // Map-space direction (u, v) -> world: m = Rz(rotation) d, so d = Rz(-rotation) m.
  Vec3d World(double u, double v) const {
    const double phi = (0.5 - u) * 2 * kPi, e = (v - 0.5) * kPi;
    const double mx = std::cos(e) * std::cos(phi), my = std::cos(e) * std::sin(phi),
                 mz = std::sin(e);
    const double t = -rotation_deg * kPi / 180.0;
    return {std::cos(t) * mx - std::sin(t) * my, std::sin(t) * mx + std::cos(t) * my, mz};
  }

  // Integral of Reflect(l, v) L(l) over the sphere. Each texel is split into k x k cells, and
  // into fine x fine cells within 0.25 rad of the mirror direction (narrow lobes).
  Vec3d Integrate(ModelId model, const std::vector<double>& p, const Vec3d& n, const Vec3d& v,
                  int k, int fine) const {
    const int w = map.width, h = map.height;
    const Vec3d r = n * (2 * Dot(n, v)) - v;
    Vec3d sum{0, 0, 0};
    for (int j = 0; j < h; ++j) {
      for (int i = 0; i < w; ++i) {
        const double u0 = static_cast<double>(i) / w, v0 = static_cast<double>(h - 1 - j) / h;
        const Vec3d centre = World(u0 + 0.5 / w, v0 + 0.5 / h);
        if (Dot(centre, n) < -0.05) continue;  // fully below the horizon (texels < 0.05 rad)
        const int s = Dot(centre, r) > std::cos(0.25) ? fine : k;
        for (int b = 0; b < s; ++b) {
          const double vb = v0 + b / static_cast<double>(s * h), vt = vb + 1.0 / (s * h);
          const double solid = 2 * kPi / (w * s) * (std::sin((vt - 0.5) * kPi) -
                                                    std::sin((vb - 0.5) * kPi));
          for (int a = 0; a < s; ++a) {
            const double uc = u0 + (a + 0.5) / (s * w), vc = 0.5 * (vb + vt);
            const Vec3d l = World(uc, vc);
            if (Dot(n, l) <= 0) continue;
            double f[3];
            Reflect(model, p.data(), n, l, v, f);
            const Vec3d le = Bilinear(uc, vc);
            for (int c = 0; c < 3; ++c) sum[c] += f[c] * le[c] * solid;
          }
        }
      }
    }
    return sum;
  }
};

TEST_P(EnvironmentTest, MatchesTexelQuadrature) {
  const std::string map_path = WriteSyntheticMap();
  const double rotation = 30.0;
  const std::string toml = testing::SphereSceneToml(
      48, 48, "[[lights]]\ntype = \"environment\"\nfile = \"" + map_path +
                  "\"\nstrength = 1.0\nrotation_z = " + std::to_string(rotation) +
                  "\nsamples = 256\n");
  const Scene scene = ParseScene(toml, "env.toml");
  const ModelInfo& model = FindModel(GetParam().model);
  Renderer& renderer = testing::SharedRenderer();
  const Image gl = renderer.Render(scene, model.id, GetParam().params);
  const GBuffer g = renderer.RenderGBuffer(scene);
  const Image map = ReadImage(map_path);
  const TexelQuadrature quadrature{map, rotation};
  // The same pixels under the opposite rotation: a flipped rotation must be told apart.
  const TexelQuadrature flipped{map, -rotation};
  double sum_rel = 0, worst = 0, sum_flipped = 0;
  int count = 0;
  for (int y = 4; y < 48; y += 8) {
    for (int x = 4; x < 48; x += 8) {
      if (!g.Hit(x, y) || g.Coverage(x, y) < 1) continue;
      const Vec3d n = Normalize(Vec3d{g.normal.at(x, y, 0), g.normal.at(x, y, 1),
                                      g.normal.at(x, y, 2)});
      const Vec3d v = Normalize(Vec3d{g.view.at(x, y, 0), g.view.at(x, y, 1), g.view.at(x, y, 2)});
      const int fine = GetParam().quadrature_fine;
      const Vec3d ref = quadrature.Integrate(model.id, GetParam().params, n, v, 2, fine);
      const Vec3d other = flipped.Integrate(model.id, GetParam().params, n, v, 2, fine);
      const double lum_ref = ref.x + ref.y + ref.z;
      const double lum_gl = gl.at(x, y, 0) + gl.at(x, y, 1) + gl.at(x, y, 2);
      const double rel = std::abs(lum_gl - lum_ref) / lum_ref;
      sum_rel += rel;
      sum_flipped += std::abs(lum_gl - (other.x + other.y + other.z)) / lum_ref;
      worst = std::max(worst, rel);
      ++count;
    }
  }
  const double mean = sum_rel / count, mean_flipped = sum_flipped / count;
  std::printf(
      "[ env ] %s vs texel quadrature: mean relative error %.4f, worst %.4f over %d pixels; "
      "against the flipped rotation %.4f\n",
      model.name.c_str(), mean, worst, count, mean_flipped);
  EXPECT_GT(count, 15);
  EXPECT_LE(mean, GetParam().quadrature_tolerance);
  EXPECT_GT(mean_flipped, 3 * GetParam().quadrature_tolerance);
}

INSTANTIATE_TEST_SUITE_P(
    Models, EnvironmentTest,
    ::testing::Values(EnvCase{"lambert", {0.8, 0.8, 0.8}, 0.01},
                      EnvCase{"ggx", {0.5, 0.2, 0.1, 0.04, 0.04, 0.04, 0.5}, 0.02},
                      EnvCase{"ggx", {0.0, 0.0, 0.0, 0.9, 0.7, 0.3, 0.15}, 0.03, 16, 0.005},
                      EnvCase{"blinn-phong-normalized", {0.3, 0.3, 0.3, 0.5, 0.5, 0.5, 80}, 0.03}),
    // Stable names ("<index>_<model>"): the default prints the struct's bytes, pointers
    // included, so the CTest names changed with every build.
    [](const ::testing::TestParamInfo<EnvCase>& info) {
      std::string name = std::to_string(info.index) + "_" + info.param.model;
      for (char& c : name) c = (c == '-') ? '_' : c;
      return name;
    });

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
