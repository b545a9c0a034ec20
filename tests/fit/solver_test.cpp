// The fitter's solver on the shipped Cycles references (issue 11, items 1-2; docs/fitting.md,
// "Bounds without crawling"):
//  - StoredCost: no fitted cost gets worse. tests/fit/data/stored_costs.tsv holds, per shipped
//    point-lit reference and model, the final cost of the default fit before the bounded LM
//    (the staged Ceres solve at 28afb69); the default fit must end at or below it (relative
//    kCostTolerance).
//  - Iterations: one GGX start reaches its optimum in at most kMaxIterations iterations on the
//    references where the sine transform crawled (entries on a bound: kd = 0 for metals, f0 at
//    its floor for Lambert).
//  - DefaultStart: the default options land within 1% of the best cost of 16 starts, on the
//    references where the default start used to stop in a local minimum (black-glossy-rim; the
//    MERL materials under the key light, rendered from ../shared/brdf-data, skipped with a
//    message when that folder is absent).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "fit_test_util.h"
#include "shadefit/fit/fitter.h"
#include "shadefit/reference_images/render_measured.h"

namespace shadefit {
namespace {

namespace fs = std::filesystem;

constexpr double kCostTolerance = 1e-4;  // Relative; summation order moves costs by ~1e-12.
constexpr int kMaxIterations = 40;       // The maximum for one start.

fs::path CyclesDir() { return fs::path(SHADEFIT_SOURCE_DIR) / "reference_images" / "cycles"; }

fit::FitResult FitReference(const fit::FitReference& ref, const std::string& model,
                            fit::FitOptions options) {
  fit::FitProblem problem;
  problem.model = FindModel(model);
  problem.references.push_back(ref);
  options.renderer = &testing::SharedRenderer();
  options.render_outputs = false;
  options.compute_covariance = false;
  return fit::Fit(problem, options);
}

fit::FitResult FitCycles(const std::string& name, const std::string& model,
                         fit::FitOptions options = {}) {
  return FitReference(fit::LoadReference((CyclesDir() / (name + ".exr")).string()), model,
                      options);
}

std::string TestName(std::string n) {
  for (char& ch : n) ch = std::isalnum(static_cast<unsigned char>(ch)) ? ch : '_';
  return n;
}

// ---- Stored costs ---------------------------------------------------------------------------

struct StoredCost {
  std::string reference, model;
  double cost = 0;
};

void PrintTo(const StoredCost& s, std::ostream* os) { *os << s.reference << " " << s.model; }

std::vector<StoredCost> ReadStoredCosts() {
  std::vector<StoredCost> out;
  std::ifstream in(fs::path(SHADEFIT_SOURCE_DIR) / "tests" / "fit" / "data" / "stored_costs.tsv");
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream row(line);
    StoredCost s;
    row >> s.reference >> s.model >> s.cost;
    if (row) out.push_back(s);
  }
  return out;
}

class StoredCostTest : public ::testing::TestWithParam<StoredCost> {};

TEST_P(StoredCostTest, DefaultFitIsNoWorse) {
  const StoredCost& s = GetParam();
  const fit::FitResult r = FitCycles(s.reference, s.model);
  EXPECT_TRUE(std::isfinite(r.final_cost));
  EXPECT_LE(r.final_cost, s.cost * (1 + kCostTolerance))
      << s.reference << " " << s.model << ": " << r.iterations << " iterations, "
      << fit::TerminationName(r.termination);
  std::printf("[ cost ] %s %s: %.9g (stored %.9g, ratio %.4f), %d iterations\n",
              s.reference.c_str(), s.model.c_str(), r.final_cost, s.cost, r.final_cost / s.cost,
              r.iterations);
}

TEST(StoredCosts, EveryShippedPointLitReferenceIsListed) {
  const std::vector<StoredCost> stored = ReadStoredCosts();
  int listed = 0;
  for (const auto& entry : fs::directory_iterator(CyclesDir())) {
    if (entry.path().extension() != ".exr") continue;
    const std::string name = entry.path().stem().string();
    if (name.ends_with("-env")) continue;  // Environment light: the quadrature path.
    ++listed;
    EXPECT_TRUE(std::any_of(stored.begin(), stored.end(),
                            [&](const StoredCost& s) { return s.reference == name; }))
        << name << " has no stored cost";
  }
  EXPECT_GT(listed, 40);
}

INSTANTIATE_TEST_SUITE_P(Shipped, StoredCostTest, ::testing::ValuesIn(ReadStoredCosts()),
                         [](const auto& info) {
                           return TestName(info.param.reference + "_" + info.param.model);
                         });

// ---- Iterations of one start ----------------------------------------------------------------

class IterationTest : public ::testing::TestWithParam<std::string> {};

TEST_P(IterationTest, OneGgxStartConvergesQuickly) {
  fit::FitOptions options;
  options.starts = 1;
  const fit::FitResult r = FitCycles(GetParam(), "ggx", options);
  EXPECT_TRUE(r.converged) << fit::TerminationName(r.termination) << ": " << r.solver_message;
  EXPECT_LE(r.iterations, kMaxIterations) << r.solver_message;
  std::printf("[ iterations ] %s: %d, cost %.9g\n", GetParam().c_str(), r.iterations,
              r.final_cost);
}

// Variable projection solves only the entries the radiance is affine in (model_structure.h). With
// Lafortune's C_z taken for one (a probe too weak to see its lobe), the bounded LM stopped at its
// start, cost 0.022 where the staged Ceres solve reaches 4e-11 on the same image. Here both
// start from the defaults (C = (-1, 1), n 32) towards C = (-0.8, 0.7), n 20, and the bounded LM
// must reach what Ceres reaches: the image itself.
TEST(ProjectionTest, LafortuneBoundedLmReachesCeres) {
  const std::vector<double> truth = {0.3, 0.2, 0.1, 0.5, 0.5, 0.5, -0.8, 0.7, 20.0};
  const auto refs = testing::SyntheticReferences("lafortune", truth, testing::SyntheticScenes(64));
  fit::FitOptions options;
  options.starts = 1;
  options.renderer = &testing::SharedRenderer();
  options.render_outputs = false;
  options.compute_covariance = false;
  double cost[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    options.solver = k == 0 ? fit::Solver::kBoundedLm : fit::Solver::kCeres;
    const fit::FitResult r = fit::Fit(fit::FitProblem{FindModel("lafortune"), refs, {}}, options);
    cost[k] = r.final_cost;
    std::printf("[ lafortune ] %s: cost %.3g from %.3g, %d iterations\n", r.solver_name.c_str(),
                r.final_cost, r.initial_cost, r.iterations);
    EXPECT_LT(r.final_cost, 1e-6 * r.initial_cost) << r.solver_name;
  }
  EXPECT_LT(cost[0], 10 * cost[1] + 1e-12);
}

// The polish continues the coarse solve's trust region (multistart.cpp). With a fresh one, 100 x
// |D y| wide, silver-mirror-rim's one start spent ten rejected full passes after its coarse
// solve (40 iterations, issue 11's maximum, for the same cost); now 30.
TEST(PolishTest, ContinuesTheCoarseTrustRegion) {
  fit::FitOptions options;
  options.starts = 1;
  const fit::FitResult r = FitCycles("silver-mirror-rim", "ggx", options);
  EXPECT_TRUE(r.converged) << fit::TerminationName(r.termination) << ": " << r.solver_message;
  EXPECT_LE(r.iterations, 33) << r.solver_message;
}

// Every shipped point-lit reference (issue 11's maximum of 40 for one start). The bounds were
// where the sine transform crawled (copper-side 39, aluminium-key 67, white-lambert-rim 45,
// gold-mirror60 46 iterations), curved kd-f0-roughness valleys where the joint Gauss-Newton step
// of the bounded LM did (black-glossy-rim 154, black-glossy-camera 138, silver-mirror-camera 96;
// the scipy peer: 357 evaluations on the first); variable projection makes those
// one-dimensional (BENCHMARKS.md at ea6bddd, in git).
std::vector<std::string> PointLitReferences() {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(CyclesDir())) {
    const std::string name = entry.path().stem().string();
    if (entry.path().extension() == ".exr" && !name.ends_with("-env")) names.push_back(name);
  }
  std::sort(names.begin(), names.end());
  return names;
}

INSTANTIATE_TEST_SUITE_P(Shipped, IterationTest, ::testing::ValuesIn(PointLitReferences()),
                         [](const auto& info) { return TestName(info.param); });

// ---- The default start does not get stuck ---------------------------------------------------

void ExpectDefaultNearBestOf16(const fit::FitReference& ref, const std::string& label) {
  const fit::FitResult def = FitReference(ref, "ggx", {});
  fit::FitOptions many;
  many.starts = 16;
  const fit::FitResult best = FitReference(ref, "ggx", many);
  // Plus 1e-6 absolute: below it (RMSE < 5e-6 on a 256^2 sphere) the fit is exact and the
  // relative gap is the stopping rule's noise (black-glossy-rim: 1.5e-7 against 1.1e-7).
  EXPECT_LE(def.final_cost, 1.01 * best.final_cost + 1e-6)
      << label << ": default cost " << def.final_cost << ", best of 16 " << best.final_cost;
  std::printf("[ default ] %s: default %.9g, 16 starts %.9g (ratio %.4f)\n", label.c_str(),
              def.final_cost, best.final_cost, def.final_cost / best.final_cost);
}

TEST(DefaultStart, BlackGlossyRimNearBestOf16) {
  ExpectDefaultNearBestOf16(
      fit::LoadReference((CyclesDir() / "black-glossy-rim.exr").string()), "black-glossy-rim");
}

fs::path BrdfData() {
  if (const char* env = std::getenv("SHADEFIT_BRDF_DATA")) return env;
  return fs::path(SHADEFIT_SOURCE_DIR) / ".." / "shared" / "brdf-data";
}

class MeasuredDefaultStartTest : public ::testing::TestWithParam<std::string> {};

TEST_P(MeasuredDefaultStartTest, KeyLightNearBestOf16) {
  const fs::path h5 = BrdfData() / "merl-nbrdf" / (GetParam() + ".h5");
  if (!fs::exists(h5)) {
    GTEST_SKIP() << h5.string() << " absent (../shared/brdf-data, or set SHADEFIT_BRDF_DATA): "
                 << "the measured default-start check needs the Neural-BRDF networks";
  }
  reference_images::MeasuredReferenceRequest request;
  request.brdf_path = h5.string();
  request.scene_path = (CyclesDir() / "scenes" / "sphere-key.toml").string();
  request.output = testing::TestOutputDir("fit_solver") + "/" + GetParam() + "-key.exr";
  reference_images::MakeMeasuredReference(request, testing::SharedRenderer());
  const fit::FitReference ref = fit::LoadReference(request.output);
  ExpectDefaultNearBestOf16(ref, GetParam() + "-key");
  // One start within the 40 iterations too. GGX does not fit a measured material
  // exactly, and where the residuals stay large the reduced Gauss-Newton matrix overstates the
  // curvature: without the step extension alum-bronze took 49 iterations at a ratio of 1.65 each.
  fit::FitOptions one;
  one.starts = 1;
  const fit::FitResult r = FitReference(ref, "ggx", one);
  EXPECT_LE(r.iterations, kMaxIterations) << GetParam() << ": " << r.solver_message;
}

INSTANTIATE_TEST_SUITE_P(Merl, MeasuredDefaultStartTest,
                         ::testing::Values("steel", "brass", "aluminium", "alum-bronze",
                                           "white-fabric"),
                         [](const auto& info) { return TestName(info.param); });

// EvaluateModelOnReference compares a render with the reference over the pixels a fit uses, the
// rule written out again here: fully covered in our G-buffer (hit, coverage 1) and in the
// reference's alpha, inside the mask, finite and unclipped. Its reference has all of them: a mask
// over part of the sphere, pixels of partial alpha, clipped highlights. A reference with nothing
// left is refused.
TEST(EvaluateModelOnReferenceTest, RmseOverTheFittersPixels) {
  const std::vector<double> truth = {0.6, 0.2, 0.1, 0.04, 0.04, 0.04, 0.3};  // kd, F0, roughness
  const std::vector<double> other = {0.5, 0.25, 0.1, 0.05, 0.05, 0.05, 0.15};
  const ModelInfo& model = FindModel("ggx");
  ASSERT_EQ(static_cast<int>(truth.size()), model.ParamCount());
  fit::FitReference ref =
      testing::SyntheticReferences("ggx", truth, testing::SyntheticScenes(64))[0];
  const int w = ref.image.width, h = ref.image.height;
  // An opaque image (a photograph's) of a scene whose silhouette pixels our G-buffer covers in
  // part (3 x 3 samples): those are left out by the G-buffer's coverage alone.
  ref.scene.camera.supersample = 3;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) ref.image.at(x, y, 3) = 1.0f;
  }
  ref.mask = Image(w, h, 1, 0.0f);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < 40; ++x) ref.mask.at(x, y, 0) = 1.0f;
  }
  for (int x = 20; x < 30; ++x) ref.image.at(x, 32, 3) = 0.5f;
  std::vector<float> values;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) values.push_back(ref.image.at(x, y, 1));
  }
  std::sort(values.begin(), values.end());
  ref.clip_level = values[values.size() * 99 / 100];
  const double exposure = 1.3;

  Image prediction;
  const double rmse = fit::EvaluateModelOnReference(ref, model, other, exposure,
                                                    &testing::SharedRenderer(), &prediction);

  const GBuffer g = testing::SharedRenderer().RenderGBuffer(ref.scene);
  const Image render = testing::SharedRenderer().Render(ref.scene, model.id, other);
  double sq = 0;
  long n = 0, clipped = 0, partial = 0, silhouette = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (!(ref.mask.at(x, y, 0) > 0.5f)) continue;
      if (g.Hit(x, y) && g.Coverage(x, y) < 1.0f) ++silhouette;
      if (!g.Hit(x, y) || g.Coverage(x, y) < 1.0f) continue;
      if (!(ref.image.at(x, y, 3) >= 1.0f - 1e-5f)) {
        ++partial;
        continue;
      }
      bool clip = false;
      for (int c = 0; c < 3; ++c) clip = clip || ref.image.at(x, y, c) >= ref.clip_level;
      if (clip) {
        ++clipped;
        continue;
      }
      for (int c = 0; c < 3; ++c) {
        const double d = exposure * render.at(x, y, c) - ref.image.at(x, y, c);
        sq += d * d;
      }
      ++n;
    }
  }
  ASSERT_GT(n, 500);
  EXPECT_GT(clipped, 0);
  EXPECT_GT(partial, 0);
  EXPECT_GT(silhouette, 0);
  EXPECT_DOUBLE_EQ(rmse, std::sqrt(sq / (3.0 * n)));
  EXPECT_FLOAT_EQ(prediction.at(10, 32, 0), static_cast<float>(exposure) * render.at(10, 32, 0));

  ref.mask = Image(w, h, 1, 0.0f);
  EXPECT_THROW(fit::EvaluateModelOnReference(ref, model, other, exposure,
                                             &testing::SharedRenderer(), nullptr),
               fit::DegenerateReferenceError);
}

}  // namespace
}  // namespace shadefit
