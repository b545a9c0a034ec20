// Acceptance 1 of the renderer issue: the GLSL copy of every model against its C++ twin.
// For each model and >= 50 parameter sets (roughness 0.02..1, shininess 1..10000, metals and
// dielectrics, grazing lights) a 64x64 sphere is rendered by GL; the twin is evaluated on the
// G-buffer GL wrote; wherever the value exceeds 1e-4 the relative difference must be <= 1e-3.
// On failure the two images and an error map go to <build>/test_output/glsl_twin/.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "shadefit/render/gbuffer.h"
#include "shadefit/render/image.h"
#include "test_util.h"

namespace shadefit {
namespace {

constexpr int kSetsPerModel = 50;
constexpr double kTolerance = 1e-3;
constexpr double kFloor = 1e-4;

// Parameter sets spread over each row's range; shininess and classic ks log-uniformly.
std::vector<std::vector<double>> ParameterSets(const ModelInfo& model) {
  std::mt19937 rng(1234);  // Fixed seed.
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::vector<std::vector<double>> sets;
  for (int s = 0; s < kSetsPerModel; ++s) {
    std::vector<double> p = DefaultParams(model);
    int offset = 0;
    for (const ParamSpec& spec : model.params) {
      for (int c = 0; c < spec.size; ++c) {
        double v;
        if (spec.name == "shininess") {
          v = std::pow(10.0, 4.0 * u01(rng));  // 1 .. 10000
        } else if (spec.name == "roughness") {
          v = 0.02 + 0.98 * (s + 0.5) / kSetsPerModel;  // 0.02 .. 1, evenly
        } else if (spec.name == "metallic") {
          v = s % 2;  // Alternate dielectrics and metals.
        } else if (spec.log_scale) {
          v = std::pow(10.0, -2.0 + 4.0 * u01(rng));
        } else {
          const double hi = std::min(spec.max, spec.name == "ior" ? 3.0 : 10.0);
          v = spec.min + (hi - spec.min) * u01(rng);
        }
        p[offset + c] = v;
      }
      offset += spec.size;
    }
    sets.push_back(p);
  }
  return sets;
}

// Light positions cycled through the sets: key, camera-side, grazing (90 deg) and rim.
std::string LightsFor(int s) {
  static const char* kPositions[] = {"[3.0, -4.0, 3.0]", "[0.3, -6.0, 0.3]",
                                     "[6.0, 0.0, 0.5]", "[-4.0, 2.0, 2.0]"};
  std::string lights = std::string("[[lights]]\ntype = \"point\"\nposition = ") +
                       kPositions[s % 4] + "\npower = 800.0\n";
  if (s % 5 == 0) {
    lights += "[[lights]]\ntype = \"directional\"\ndirection = [-0.3, 0.2, -1.0]\n"
              "irradiance = [1.0, 0.8, 0.6]\n";
  }
  if (s % 7 == 0) lights += "[[lights]]\ntype = \"ambient\"\nradiance = 0.2\n";
  return lights;
}

// Holds a GL image to its C++ twin on the G-buffer's hit pixels; writes both and an error map
// to test_output/glsl_twin/<stem>_* on failure.
// At least `min_compared` values must be above the floor: a whole sphere for the full model, a
// highlight's worth for a sharp lobe alone.
void ExpectTwins(const Image& gl, const Image& twin, const GBuffer& gbuffer,
                 const std::string& stem, const std::string& what, int min_compared) {
  double worst = 0;
  int compared = 0;
  Image error(gl.width, gl.height, 1);
  for (int y = 0; y < gl.height; ++y) {
    for (int x = 0; x < gl.width; ++x) {
      if (!gbuffer.Hit(x, y)) continue;
      for (int c = 0; c < 3; ++c) {
        const double a = gl.at(x, y, c), b = twin.at(x, y, c);
        if (std::max(std::abs(a), std::abs(b)) <= kFloor) continue;
        const double rel = std::abs(a - b) / std::max(std::abs(a), std::abs(b));
        error.at(x, y, 0) = std::max(error.at(x, y, 0), static_cast<float>(rel / kTolerance));
        worst = std::max(worst, rel);
        ++compared;
      }
    }
  }
  if (worst > kTolerance) {
    const std::string base = testing::TestOutputDir("glsl_twin") + "/" + stem;
    WriteExr(base + "_gl.exr", gl);
    WriteExr(base + "_twin.exr", twin);
    WriteExr(base + "_error.exr", error);
  }
  EXPECT_LE(worst, kTolerance) << what << " (" << compared
                               << " values compared; images in test_output/glsl_twin)";
  EXPECT_GE(compared, min_compared) << what << ": too few lit pixels for a meaningful comparison";
}

class GlslTwinTest : public ::testing::TestWithParam<std::string> {};

TEST_P(GlslTwinTest, GlRenderMatchesCppTwin) {
  const ModelInfo& model = FindModel(GetParam());
  Renderer& renderer = testing::SharedRenderer();
  const auto sets = ParameterSets(model);
  for (std::size_t s = 0; s < sets.size(); ++s) {
    const Scene scene = ParseScene(testing::SphereSceneToml(64, 64, LightsFor(s)), "twin.toml");
    const GBuffer gbuffer = renderer.RenderGBuffer(scene);
    const Image gl = renderer.Render(scene, model.id, sets[s]);
    const Image twin = ShadeGBuffer(scene, gbuffer, model.id, sets[s]);
    ExpectTwins(gl, twin, gbuffer, model.name + "_" + std::to_string(s),
                model.name + " set " + std::to_string(s), 300);
  }
}

// Each term the rest of shadefit derives from the model's one definition (the probes' diffuse /
// lobe split, the Fresnel curve) rendered alone by the GL program and evaluated by the C++ twin.
// A term that is 0 everywhere for a model (Lambert's lobe) compares nothing and is skipped.
TEST_P(GlslTwinTest, EveryTermMatchesCppTwin) {
  const ModelInfo& model = FindModel(GetParam());
  Renderer& renderer = testing::SharedRenderer();
  const auto sets = ParameterSets(model);
  const std::pair<ModelTerm, const char*> terms[] = {
      {ModelTerm::kDiffuse, "diffuse"},
      {ModelTerm::kLobe, "lobe"},
      {ModelTerm::kFresnel, "fresnel"}};
  int terms_compared = 0;
  for (std::size_t s = 0; s < sets.size(); s += 5) {
    const Scene scene = ParseScene(testing::SphereSceneToml(64, 64, LightsFor(s)), "twin.toml");
    const GBuffer gbuffer = renderer.RenderGBuffer(scene);
    for (const auto& [term, term_name] : terms) {
      const Image twin = ShadeGBuffer(scene, gbuffer, model.id, sets[s], term);
      double peak = 0;
      for (int y = 0; y < twin.height; ++y) {
        for (int x = 0; x < twin.width; ++x) {
          for (int c = 0; c < 3; ++c) peak = std::max(peak, std::abs(double(twin.at(x, y, c))));
        }
      }
      if (peak <= kFloor) continue;
      const Image gl = renderer.Render(scene, model.id, sets[s], term);
      ExpectTwins(gl, twin, gbuffer, model.name + "_" + term_name + "_" + std::to_string(s),
                  model.name + " " + term_name + " set " + std::to_string(s), 20);
      ++terms_compared;
    }
  }
  EXPECT_GE(terms_compared, 10) << "too few terms compared for " << model.name;
}

std::vector<std::string> AllModelNames() {
  std::vector<std::string> names;
  for (const auto& m : AllModels()) names.push_back(m.name);
  return names;
}

INSTANTIATE_TEST_SUITE_P(AllModels, GlslTwinTest, ::testing::ValuesIn(AllModelNames()),
                         [](const auto& info) {
                           std::string n = info.param;
                           for (char& ch : n) if (ch == '-') ch = '_';
                           return n;
                         });

}  // namespace
}  // namespace shadefit
