// The two derivative paths reach the same optimum (acceptance: parameters within 1%) on
// point-lit references, and --path auto picks the G-buffer path for them and the GL path for
// environment lighting.
#include <gtest/gtest.h>

#include <cmath>

#include "fit_test_util.h"
#include "shadefit/base/error.h"

namespace shadefit {
namespace {

fit::FitResult FitWith(const std::string& model, const std::vector<fit::FitReference>& refs,
                       fit::DerivativePath path) {
  fit::FitProblem problem;
  problem.model = FindModel(model);
  problem.references = refs;
  fit::FitOptions options;
  options.renderer = &testing::SharedRenderer();
  options.path = path;
  options.render_outputs = false;
  return fit::Fit(problem, options);
}

void ExpectSameOptimum(const std::string& model, const std::string& truth_model,
                       const std::vector<double>& truth) {
  std::vector<Scene> scenes = testing::SyntheticScenes(64);
  scenes.resize(2);
  const auto refs = testing::SyntheticReferences(truth_model, truth, scenes);
  const fit::FitResult a = FitWith(model, refs, fit::DerivativePath::kGBuffer);
  const fit::FitResult b = FitWith(model, refs, fit::DerivativePath::kGl);
  EXPECT_EQ(a.path, fit::DerivativePath::kGBuffer);
  EXPECT_EQ(b.path, fit::DerivativePath::kGl);
  EXPECT_TRUE(a.converged) << a.solver_message;
  EXPECT_TRUE(b.converged) << b.solver_message;
  EXPECT_GT(b.renders, 0);
  EXPECT_EQ(a.renders, 0);
  for (std::size_t i = 0; i < a.values.size(); ++i) {
    // 1% of the value, or 1e-3 absolute for values near 0 (float renders on the GL path).
    EXPECT_NEAR(a.values[i], b.values[i], std::max(0.01 * std::abs(a.values[i]), 1e-3))
        << model << " " << a.parameters[i].name;
  }
  EXPECT_NEAR(a.rmse, b.rmse, 0.01 * a.rmse + 1e-5);
}

TEST(PathsTest, GgxSameOptimumOnOwnRender) {
  ExpectSameOptimum("ggx", "ggx", {0.6, 0.3, 0.1, 0.04, 0.04, 0.04, 0.3});
}

// A residual that does not vanish: Blinn-Phong (normalised) fitted to a GGX image. The optimum
// then depends on the Jacobian's accuracy, which is what tells the paths apart.
TEST(PathsTest, BlinnPhongSameOptimumOnGgxRender) {
  ExpectSameOptimum("blinn-phong-normalized", "ggx", {0.5, 0.4, 0.3, 0.04, 0.04, 0.04, 0.25});
}

TEST(PathsTest, AutoPicksTwinQuadratureForUniformLightAndGlStillFits) {
  // A uniform environment (white furnace light): the twin shades it through its fixed
  // quadrature (render/gbuffer.h), so auto picks the G-buffer path and recovers kd and the
  // roughness; the GL path (finite differences of renders) still fits kd.
  const Scene scene = ParseScene(testing::CameraToml("[0.0, -6.0, 0.0]", 22.0, 32) +
                                     testing::kSphere +
                                     "[[lights]]\ntype = \"uniform\"\nradiance = 1.0\n"
                                     "samples = 64\n",
                                 "furnace.toml");
  const std::vector<double> truth = {0.6, 0.5, 0.4, 0.04, 0.04, 0.04, 0.4};
  auto refs = testing::SyntheticReferences("ggx", truth, {scene});
  fit::FitProblem problem;
  problem.model = FindModel("ggx");
  problem.references = refs;
  problem.fixed = ParseFixedValues(*problem.model, {"f0=0.04"}, "--fix");
  fit::FitOptions options;
  options.renderer = &testing::SharedRenderer();
  options.render_outputs = false;
  const fit::FitResult twin = fit::Fit(problem, options);
  EXPECT_EQ(twin.path, fit::DerivativePath::kGBuffer);
  EXPECT_TRUE(twin.converged) << twin.solver_message;
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(twin.values[c], truth[c], 0.02 * truth[c]) << c;
  // Under uniform light a sphere's roughness shows only through the Fresnel-weighted rim and the
  // lobe's energy: it is weakly determined, so the bound is wider than kd's.
  EXPECT_NEAR(twin.values[6], truth[6], 0.15 * truth[6]);
  EXPECT_EQ(twin.renders, 0);  // No GL render in the loop.

  // Keep the GL-path test cheap: kd only.
  problem.fixed = ParseFixedValues(*problem.model, {"f0=0.04", "roughness=0.4"}, "--fix");
  options.path = fit::DerivativePath::kGl;
  options.starts = 1;  // The render bound below counts one start's iterations.
  const fit::FitResult r = fit::Fit(problem, options);
  EXPECT_EQ(r.path, fit::DerivativePath::kGl);
  EXPECT_TRUE(r.converged) << r.solver_message;
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.values[c], truth[c], 0.01 * truth[c]);
  EXPECT_TRUE(r.parameters[6].fixed);
  EXPECT_EQ(r.values[6], 0.4);
  // Fixed entries are never perturbed: 3 free entries -> at most 3 renders per Jacobian + trials.
  EXPECT_LE(r.renders, 4 * (r.iterations + 2));
}

}  // namespace
}  // namespace shadefit
