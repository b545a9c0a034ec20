// One file plus one line: tests/render/CMakeLists.txt builds a second render library whose model
// list is the shipped one plus tests/render/models/minnaert.glsl, a model no other code knows.
// This test links that library only and checks that the toy is registered (table, CLI name),
// that its GL program and its C++ twin agree like every shipped model's, that its terms have
// their derived meaning, and that the value matches the formula written out here by hand.
#include <gtest/gtest.h>

#include <cmath>

#include "shadefit/render/gbuffer.h"
#include "shadefit/render/models.h"
#include "shadefit/render/renderer.h"
#include "test_util.h"

namespace shadefit {
namespace {

TEST(ModelRegistry, ToyModelFromOneFileIsRegistered) {
  const ModelInfo& toy = FindModel("minnaert");
  EXPECT_EQ(static_cast<int>(toy.id), kModelCount - 1);  // Appended to the shipped list.
  ASSERT_EQ(toy.params.size(), 2u);
  EXPECT_EQ(toy.params[0].name, "kd");
  EXPECT_EQ(toy.params[0].size, 3);
  EXPECT_EQ(toy.params[1].name, "k");
  EXPECT_EQ(toy.params[1].min, 0.5);
  EXPECT_EQ(toy.params[1].max, 2.0);
  EXPECT_EQ(toy.ParamCount(), 4);
  EXPECT_EQ(toy.glsl_file, "models/minnaert.glsl");
  EXPECT_NO_THROW(FindModel("ggx"));  // The shipped models are all still there.
}

TEST(ModelRegistry, ToyModelMatchesItsFormula) {
  const ModelInfo& toy = FindModel("minnaert");
  const std::vector<double> p = {0.2, 0.5, 0.8, 1.7};
  const Vec3d n{0, 0, 1};
  const Vec3d l = Normalize(Vec3d{0.5, 0.1, 0.7}), v = Normalize(Vec3d{-0.3, 0.2, 0.9});
  double out[3];
  Reflect(toy.id, p.data(), n, l, v, out);
  for (int c = 0; c < 3; ++c) {
    const double expected = p[c] / kPi * std::pow(l.z * v.z, p[3] - 1.0) * l.z;
    EXPECT_NEAR(out[c], expected, 1e-12 * expected);
  }
}

TEST(ModelRegistry, ToyModelGlProgramMatchesCppTwin) {
  const ModelInfo& toy = FindModel("minnaert");
  Renderer& renderer = testing::SharedRenderer();
  const std::string lights =
      "[[lights]]\ntype = \"point\"\nposition = [3.0, -4.0, 3.0]\npower = 800.0\n";
  const Scene scene = ParseScene(testing::SphereSceneToml(64, 64, lights), "toy.toml");
  const GBuffer gbuffer = renderer.RenderGBuffer(scene);
  for (const double k : {0.6, 1.0, 1.9}) {
    const std::vector<double> p = {0.3, 0.6, 0.9, k};
    const Image gl = renderer.Render(scene, toy.id, p);
    const Image twin = ShadeGBuffer(scene, gbuffer, toy.id, p);
    double worst = 0;
    int compared = 0;
    for (int y = 0; y < gl.height; ++y) {
      for (int x = 0; x < gl.width; ++x) {
        if (!gbuffer.Hit(x, y)) continue;
        for (int c = 0; c < 3; ++c) {
          const double a = gl.at(x, y, c), b = twin.at(x, y, c);
          if (std::max(a, b) <= 1e-4) continue;
          worst = std::max(worst, std::abs(a - b) / std::max(a, b));
          ++compared;
        }
      }
    }
    EXPECT_LE(worst, 1e-3) << "k " << k;
    EXPECT_GT(compared, 300) << "k " << k;
  }
}

}  // namespace
}  // namespace shadefit
