// Acceptance 2, 4, 5 of the fitting issue: cross-fits converge without failure or NaN; an
// uncalibrated, 8-bit, clipped reference fitted with a free exposure keeps the HDR fit's
// roughness; references with nothing to fit are clear errors; a fit stopped early says so.
// Also: every loss runs, --fix holds a parameter.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "fit_test_util.h"
#include "shadefit/base/error.h"
#include "shadefit/fit/encoding_search.h"
#include "shadefit/fit/exposure_pin.h"

namespace shadefit {
namespace {

// The pin of a model named as a user would name it, with `fixed` as a user would write it.
fit::ExposurePin PinOf(const std::string& model, const std::vector<std::string>& fixed = {}) {
  const ModelInfo& info = FindModel(model);
  return fit::ExposurePinOf(info, ParseFixedValues(info, fixed, "--fix"));
}

fit::FitOptions Options() {
  fit::FitOptions options;
  options.renderer = &testing::SharedRenderer();
  options.render_outputs = false;
  return options;
}

std::vector<Scene> TwoLightings() {
  std::vector<Scene> scenes = testing::SyntheticScenes(64);
  scenes.resize(2);
  return scenes;
}

void ExpectSane(const fit::FitResult& r) {
  EXPECT_TRUE(std::isfinite(r.final_cost));
  EXPECT_TRUE(std::isfinite(r.rmse));
  EXPECT_NE(r.termination, fit::Termination::kFailure) << r.solver_message;
  EXPECT_TRUE(r.converged) << fit::TerminationName(r.termination) << ": " << r.solver_message << " "
                           << fit::FitResultToJson(r)["values"].dump() << " iterations "
                           << r.iterations;
  for (const auto& p : r.parameters) EXPECT_TRUE(std::isfinite(p.value)) << p.name;
}

TEST(CrossFitTest, BlinnPhongToGgxImage) {
  const auto refs = testing::SyntheticReferences(
      "ggx", {0.5, 0.2, 0.1, 0.04, 0.04, 0.04, 0.2}, TwoLightings());
  for (const char* model : {"blinn-phong", "blinn-phong-normalized", "phong"}) {
    fit::FitProblem problem{FindModel(model), refs, {}};
    fit::FitOptions options = Options();
    options.starts = 4;
    const fit::FitResult r = fit::Fit(problem, options);
    SCOPED_TRACE(model);
    ExpectSane(r);
    EXPECT_GT(r.rmse, 0);  // A different model: it cannot be exact.
  }
}

TEST(CrossFitTest, GgxToBlinnPhongImage) {
  const auto refs = testing::SyntheticReferences(
      "blinn-phong", {0.05, 0.05, 0.05, 0.6, 0.3, 0.1, 0.8, 0.8, 0.8, 60}, TwoLightings());
  for (const char* model : {"ggx", "ggx-metallic"}) {
    fit::FitProblem problem{FindModel(model), refs, {}};
    fit::FitOptions options = Options();
    options.starts = 4;
    const fit::FitResult r = fit::Fit(problem, options);
    SCOPED_TRACE(model);
    ExpectSane(r);
  }
}

// Acceptance 4. The HDR reference (our GGX render) is scaled by an unknown 1.7, sRGB-encoded,
// quantised to 8 bits and clipped, then decoded back to linear; pixels at code >= 254 are
// excluded (clip_level). The fit with a free exposure must keep the roughness of the HDR fit
// within 5%.
TEST(ExposureTest, ClippedLdrReferenceKeepsRoughness) {
  const std::vector<double> truth = {0.6, 0.3, 0.1, 0.04, 0.04, 0.04, 0.3};
  const auto hdr = testing::SyntheticReferences("ggx", truth, TwoLightings());
  fit::FitProblem hdr_problem{FindModel("ggx"), hdr, {}};
  const fit::FitResult hdr_fit = fit::Fit(hdr_problem, Options());
  ASSERT_TRUE(hdr_fit.converged);

  auto ldr = hdr;
  int clipped = 0;
  for (auto& ref : ldr) {
    for (std::size_t p = 0; p < ref.image.PixelCount(); ++p) {
      for (int c = 0; c < 3; ++c) {
        float& v = ref.image.data[4 * p + c];
        const float code = std::round(std::clamp(SrgbOetf(1.7f * v), 0.0f, 1.0f) * 255.0f);
        clipped += code >= 254.0f;
        v = SrgbToLinear(code / 255.0f);
      }
    }
    ref.clip_level = SrgbToLinear(254.0f / 255.0f) * (1.0f - 1e-6f);
  }
  ASSERT_GT(clipped, 0) << "the test must clip some highlight pixels";
  fit::FitProblem ldr_problem{FindModel("ggx"), ldr, {}};
  fit::FitOptions options = Options();
  options.exposure = fit::Exposure::kFree;
  options.starts = 4;
  const fit::FitResult r = fit::Fit(ldr_problem, options);
  ExpectSane(r);
  EXPECT_TRUE(r.exposure_free);
  EXPECT_NEAR(r.values[6], hdr_fit.values[6], 0.05 * hdr_fit.values[6]);
  // Exposure and albedo trade off almost exactly (only Fresnel's grazing rise breaks it): the
  // fit may choose any split, but their product must match 1.7 x kd.
  EXPECT_NEAR(r.exposure * r.values[0], 1.7 * truth[0], 0.05 * 1.7 * truth[0]);
}

TEST(BadInputTest, AllBlackReferenceIsAnError) {
  auto refs = testing::SyntheticReferences("ggx", {0.5, 0.5, 0.5, 0.04, 0.04, 0.04, 0.5},
                                           TwoLightings());
  for (std::size_t p = 0; p < refs[1].image.PixelCount(); ++p) {
    for (int c = 0; c < 3; ++c) refs[1].image.data[4 * p + c] = 0.0f;
  }
  fit::FitProblem problem{FindModel("ggx"), refs, {}};
  try {
    fit::Fit(problem, Options());
    FAIL() << "expected shadefit::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("synthetic1"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("black"), std::string::npos) << e.what();
  }
}

TEST(BadInputTest, AllMaskedReferenceIsAnError) {
  auto refs = testing::SyntheticReferences("ggx", {0.5, 0.5, 0.5, 0.04, 0.04, 0.04, 0.5},
                                           TwoLightings());
  refs[0].mask = Image(refs[0].image.width, refs[0].image.height, 1, 0.0f);
  fit::FitProblem problem{FindModel("ggx"), refs, {}};
  try {
    fit::Fit(problem, Options());
    FAIL() << "expected shadefit::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("nothing to fit"), std::string::npos) << e.what();
  }
}

TEST(BadInputTest, NanPixelIsAnError) {
  auto refs = testing::SyntheticReferences("ggx", {0.5, 0.5, 0.5, 0.04, 0.04, 0.04, 0.5},
                                           TwoLightings());
  refs[0].image.at(32, 32, 1) = std::nanf("");
  fit::FitProblem problem{FindModel("ggx"), refs, {}};
  EXPECT_THROW(fit::Fit(problem, Options()), Error);
}

TEST(BadInputTest, SizeMismatchIsAnError) {
  auto refs = testing::SyntheticReferences("ggx", {0.5, 0.5, 0.5, 0.04, 0.04, 0.04, 0.5},
                                           TwoLightings());
  refs[0].scene.camera.width = 80;
  fit::FitProblem problem{FindModel("ggx"), refs, {}};
  EXPECT_THROW(fit::Fit(problem, Options()), Error);
}

TEST(BadInputTest, UnknownFixedParameterIsAnError) {
  const auto refs = testing::SyntheticReferences(
      "ggx", {0.5, 0.5, 0.5, 0.04, 0.04, 0.04, 0.5}, TwoLightings());
  // From text, a row must be the model's (ParseFixedValue).
  EXPECT_THROW(ParseFixedValues(FindModel("ggx"), {"shininess=10"}, "--fix"), Error);
  // A value made for another model, even of a row of the same name, is refused by the fitter
  // rather than held at that model's offset.
  const fit::FitProblem problem{FindModel("ggx"), refs,
                                ParseFixedValues(FindModel("blinn-phong"), {"kd=0.5"}, "--fix")};
  EXPECT_THROW(fit::Fit(problem, Options()), Error);
}

TEST(ConvergenceTest, StoppedEarlySaysSo) {
  const auto refs = testing::SyntheticReferences(
      "ggx", {0.6, 0.3, 0.1, 0.04, 0.04, 0.04, 0.3}, TwoLightings());
  fit::FitProblem problem{FindModel("ggx"), refs, {}};
  fit::FitOptions options = Options();
  options.max_iterations = 1;
  const fit::FitResult r = fit::Fit(problem, options);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.termination, fit::Termination::kNoConvergence);
  const nlohmann::json j = fit::FitResultToJson(r);
  EXPECT_FALSE(j["converged"].get<bool>());
  EXPECT_EQ(j["solver"]["termination"], "NO_CONVERGENCE");
}

TEST(LossTest, EveryLossRecoversOwnRender) {
  const std::vector<double> truth = {0.6, 0.3, 0.1, 0.04, 0.04, 0.04, 0.3};
  const auto refs = testing::SyntheticReferences("ggx", truth, TwoLightings());
  for (fit::Loss loss : {fit::Loss::kL2, fit::Loss::kLog, fit::Loss::kCubeRoot,
                         fit::Loss::kHuber, fit::Loss::kCauchy, fit::Loss::kRelative}) {
    fit::FitProblem problem{FindModel("ggx"), refs, {}};
    fit::FitOptions options = Options();
    options.loss = loss;
    const fit::FitResult r = fit::Fit(problem, options);
    SCOPED_TRACE(fit::LossName(loss));
    ExpectSane(r);
    EXPECT_NEAR(r.values[6], truth[6], 0.02 * truth[6]);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.values[c], truth[c], 0.01 * truth[c]);
    // f0 too: the specular colour a loss could trade against kd or roughness.
    for (int c = 3; c < 6; ++c) {
      EXPECT_NEAR(r.values[c], truth[c], 0.01 * truth[c]) << "f0 channel " << c - 3;
    }
    std::printf("[ loss ] %s: kd (%.4f, %.4f, %.4f) f0 (%.5f, %.5f, %.5f) roughness %.4f\n",
                fit::LossName(loss).c_str(), r.values[0], r.values[1], r.values[2], r.values[3],
                r.values[4], r.values[5], r.values[6]);
    if (loss == fit::Loss::kHuber || loss == fit::Loss::kCauchy) {
      EXPECT_GT(r.loss_scale, 0);
    }
  }
}

TEST(FixTest, FixedParameterIsHeldAndReported) {
  const std::vector<double> truth = {0.6, 0.3, 0.1, 0.04, 0.04, 0.04, 0.3};
  const auto refs = testing::SyntheticReferences("ggx", truth, TwoLightings());
  fit::FitProblem problem{
      FindModel("ggx"), refs,
      ParseFixedValues(FindModel("ggx"), {"f0=0.04", "roughness=0.3"}, "--fix")};
  const fit::FitResult r = fit::Fit(problem, Options());
  ExpectSane(r);
  EXPECT_EQ(r.values[6], 0.3);
  EXPECT_TRUE(r.parameters[6].fixed);
  EXPECT_TRUE(std::isnan(r.parameters[6].std_error));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.values[c], truth[c], 1e-3);
}

TEST(MultiStartTest, DeterministicAndReported) {
  const auto refs = testing::SyntheticReferences(
      "blinn-phong-normalized", {0.5, 0.3, 0.2, 0.05, 0.05, 0.05, 300}, TwoLightings());
  fit::FitProblem problem{FindModel("blinn-phong-normalized"), refs, {}};
  fit::FitOptions options = Options();
  options.starts = 5;
  options.seed = 7;
  const fit::FitResult a = fit::Fit(problem, options);
  const fit::FitResult b = fit::Fit(problem, options);
  ASSERT_EQ(a.start_results.size(), 5u);
  for (int s = 0; s < 5; ++s) EXPECT_EQ(a.start_results[s].start, b.start_results[s].start);
  EXPECT_EQ(a.values, b.values);
  EXPECT_GE(a.starts_reached_best, 1);
  // Start 0 is the table defaults.
  const std::vector<double> defaults = DefaultParams(FindModel("blinn-phong-normalized"));
  for (std::size_t i = 0; i < defaults.size(); ++i) {
    EXPECT_NEAR(a.start_results[0].start[i], defaults[i], 1e-9 * defaults[i]);
  }
  options.seed = 8;
  const fit::FitResult c = fit::Fit(problem, options);
  EXPECT_NE(a.start_results[1].start, c.start_results[1].start);
  for (const auto& p : a.parameters) {
    EXPECT_LE(p.spread_min, p.value);
    EXPECT_GE(p.spread_max, p.value);
  }
}

// Issue 33 item 2: with a free exposure, each model pins one scale, chosen from its structure
// (model_structure.h) and roles (kFresnelParam), not from a list of names (exposure_pin.h).
TEST(ExposurePinTest, ChosenFromStructureAndRoles) {
  using fit::PinKind;
  const fit::ExposurePin bp = PinOf("blinn-phong");
  EXPECT_EQ(bp.kind, PinKind::kExposure);
  EXPECT_EQ(bp.entries, (std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7, 8}));  // ka, kd, ks
  EXPECT_EQ(PinOf("ward").kind, PinKind::kExposure);
  EXPECT_EQ(PinOf("lafortune").entries, (std::vector<int>{0, 1, 2, 3, 4, 5}));
  const fit::ExposurePin ggx = PinOf("ggx");
  EXPECT_EQ(ggx.kind, PinKind::kFresnel);
  EXPECT_EQ(ggx.entries, std::vector<int>{4});  // f0.g: a coloured highlight stays free.
  EXPECT_EQ(ggx.values, std::vector<double>{0.04});
  const fit::ExposurePin metallic = PinOf("ggx-metallic");
  EXPECT_EQ(metallic.entries, (std::vector<int>{3, 5}));  // metallic 0, f0_dielectric 0.04
  EXPECT_EQ(metallic.values, (std::vector<double>{0.0, 0.04}));
  EXPECT_EQ(PinOf("ggx-dielectric").values, std::vector<double>{1.5});
  EXPECT_EQ(PinOf("ggx-conductor").kind, PinKind::kUnitExposure);
  // The user's own values: a Fresnel row or a non-zero reflectance already sets the scale; a
  // reflectance fixed at 0 does not.
  EXPECT_EQ(PinOf("ggx", {"f0=0.9"}).kind, PinKind::kNone);
  EXPECT_EQ(PinOf("ggx", {"kd=0.5"}).kind, PinKind::kNone);
  EXPECT_EQ(PinOf("blinn-phong", {"kd=0.3,0.2,0.1"}).kind, PinKind::kNone);
  EXPECT_EQ(PinOf("blinn-phong", {"ka=0"}).entries, (std::vector<int>{3, 4, 5, 6, 7, 8}));
  EXPECT_THROW(PinOf("ggx", {"shininess=3"}), Error);
}

// The references are the truth's renders times an unknown exposure. A free-exposure fit of each
// model must end on the image, with no parameter undetermined: the linear models at exposure 1
// with their reflectances times the exposure (or, where that leaves the box, with the largest at
// 99% of its bound), the Fresnel models at the true exposure with f0.g held at the truth.
TEST(ExposurePinTest, FreeExposureLeavesNothingUndetermined) {
  struct Case {
    const char* model;
    std::vector<double> truth;
    double exposure;
  };
  const std::vector<Case> cases = {
      {"blinn-phong", {0, 0, 0, 0.4, 0.25, 0.1, 0.6, 0.6, 0.6, 40}, 1.7},
      {"blinn-phong", {0, 0, 0, 0.4, 0.25, 0.1, 0.6, 0.6, 0.6, 40}, 3.0},  // kd.r 1.2 > 1
      {"blinn-phong-normalized", {0.4, 0.25, 0.1, 0.3, 0.3, 0.3, 40}, 1.7},
      {"ggx", {0.4, 0.25, 0.1, 0.04, 0.04, 0.04, 0.3}, 1.7},
      {"beckmann", {0.4, 0.25, 0.1, 0.04, 0.04, 0.04, 0.3}, 1.7},
      {"cook-torrance", {0.4, 0.25, 0.1, 0.04, 0.04, 0.04, 0.3}, 1.7}};
  for (const Case& c : cases) {
    SCOPED_TRACE(std::string(c.model) + " x" + std::to_string(c.exposure));
    auto refs = testing::SyntheticReferences(c.model, c.truth, TwoLightings());
    for (auto& ref : refs) {
      for (std::size_t p = 0; p < ref.image.PixelCount(); ++p) {
        for (int ch = 0; ch < 3; ++ch) ref.image.data[4 * p + ch] *= static_cast<float>(c.exposure);
      }
    }
    fit::FitOptions options = Options();
    options.exposure = fit::Exposure::kFree;
    options.starts = 2;
    const fit::FitResult r = fit::Fit(fit::FitProblem{FindModel(c.model), refs, {}}, options);
    ExpectSane(r);
    EXPECT_LT(r.final_cost, 1e-8 * r.initial_cost);
    EXPECT_EQ(r.covariance_status, fit::CovarianceStatus::kOk) << r.CovarianceStatusText();
    for (const auto& p : r.parameters) EXPECT_FALSE(p.undetermined) << p.name;
    const ModelInfo& m = FindModel(c.model);
    const int kd = m.Offset("kd");
    if (m.Find("ka")) {  // The side lighting has ambient light: ka is fitted, not held.
      EXPECT_FALSE(r.parameters[m.Offset("ka")].fixed);
    }
    if (r.exposure_pin.kind == fit::PinKind::kExposure) {
      const double scale = std::max(1.0, c.exposure * c.truth[kd] / 0.99);
      EXPECT_NEAR(r.exposure, scale, 1e-6 * scale);
      for (int ch = 0; ch < 3; ++ch) {
        EXPECT_NEAR(r.values[kd + ch], c.exposure * c.truth[kd + ch] / scale, 1e-4);
      }
    } else {
      EXPECT_EQ(r.exposure_pin.kind, fit::PinKind::kFresnel);
      EXPECT_NEAR(r.exposure, c.exposure, 1e-3 * c.exposure);
      EXPECT_TRUE(r.parameters[m.Offset("f0") + 1].fixed);
      EXPECT_EQ(r.parameters[m.Offset("f0") + 1].fixed_by, "free exposure");
      EXPECT_EQ(r.parameters[m.Offset("f0")].fixed_by, "");  // f0.r stays free.
      for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(r.values[kd + ch], c.truth[kd + ch], 1e-4);
    }
  }
}

// Without ambient light in any reference, classic Blinn-Phong's ka has no effect on a pixel: the
// fit holds it at 0 and says why, instead of leaving it where its start put it, "undetermined".
TEST(ExposurePinTest, AmbientReflectanceHeldWithoutAmbientLight) {
  const std::vector<double> truth = {0, 0, 0, 0.4, 0.25, 0.1, 0.6, 0.6, 0.6, 40};
  std::vector<Scene> key = testing::SyntheticScenes(64);
  key.resize(1);
  const fit::FitResult r = fit::Fit(
      fit::FitProblem{
          FindModel("blinn-phong"), testing::SyntheticReferences("blinn-phong", truth, key), {}},
      Options());
  ExpectSane(r);
  EXPECT_EQ(r.covariance_status, fit::CovarianceStatus::kOk) << r.CovarianceStatusText();
  for (int ch = 0; ch < 3; ++ch) {
    EXPECT_TRUE(r.parameters[ch].fixed);
    EXPECT_EQ(r.parameters[ch].value, 0.0);
    EXPECT_EQ(r.parameters[ch].fixed_by, "no ambient light");
  }
  ASSERT_EQ(r.held.size(), 1u);
  EXPECT_EQ(r.held[0].rfind("ka = 0", 0), 0u) << r.held[0];
  for (const auto& p : r.parameters) EXPECT_FALSE(p.undetermined) << p.name;
}

// The encoding search fits every power after the first from the fit of the nearest exponent tried,
// alone (a continuation, encoding_search.h). Such a fit must end at least as low as the caller's
// own cold multi-start fit at that exponent: each power's score in the trail, against the score
// of Fit() with the caller's options on the references decoded with that power, scored here with
// our own encode of the render (blinn-phong fitted to GGX, stored as a power of 1 / 2.2).
TEST(EncodingSearchTest, ContinuedPowersEndAsLowAsColdFits) {
  const std::vector<fit::FitReference> hdr = testing::SyntheticReferences(
      "ggx", {0.45, 0.3, 0.2, 0.04, 0.04, 0.04, 0.25}, TwoLightings());
  std::vector<fit::FitReference> stored = hdr;
  for (auto& ref : stored) {
    for (std::size_t p = 0; p < ref.image.PixelCount(); ++p) {
      for (int c = 0; c < 3; ++c) {
        float& v = ref.image.data[4 * p + c];
        v = static_cast<float>(std::pow(std::clamp(1.3 * v, 0.0, 1.0), 1.0 / 2.2));
      }
    }
  }
  const fit::FitProblem problem{FindModel("blinn-phong"), stored, {}};
  fit::FitOptions options = Options();
  options.exposure = fit::Exposure::kFree;
  options.starts = 2;
  const fit::EncodingSearchResult search = fit::FitWithEncodingSearch(problem, options);
  ASSERT_GE(search.gamma_trail.size(), 10u);
  EXPECT_EQ(search.chosen.kind, fit::StoredEncoding::Kind::kGamma);
  EXPECT_NEAR(search.chosen.gamma, 2.2, 0.1);
  // The first power is the cold fit itself; check later ones, the last (nearest the optimum) too.
  for (const std::size_t k : {std::size_t{1}, std::size_t{4}, search.gamma_trail.size() - 1}) {
    const auto [gamma, score] = search.gamma_trail[k];
    const fit::StoredEncoding e{fit::StoredEncoding::Kind::kGamma, gamma};
    fit::FitProblem decoded = problem;
    for (auto& r : decoded.references) r = fit::Redecode(r, e);
    const fit::FitResult cold = fit::Fit(decoded, options);
    double sq = 0;
    long n = 0;
    for (std::size_t i = 0; i < stored.size(); ++i) {
      const Image render = testing::SharedRenderer().Render(stored[i].scene,
                                                            FindModel("blinn-phong").id,
                                                            cold.values);
      for (std::size_t p = 0; p < render.PixelCount(); ++p) {
        if (!(stored[i].image.data[4 * p + 3] >= 1.0f - 1e-5f)) continue;  // Full coverage.
        for (int c = 0; c < 3; ++c) {
          const double encoded = std::pow(
              std::clamp(cold.exposure * render.data[4 * p + c], 0.0, 1.0), 1.0 / gamma);
          sq += std::pow(encoded - stored[i].image.data[4 * p + c], 2);
          ++n;
        }
      }
    }
    const double cold_score = std::sqrt(sq / n);
    std::printf("gamma %.4f: continued %.6g, cold %.6g\n", gamma, score, cold_score);
    EXPECT_LE(score, cold_score * (1.0 + 1e-3)) << "gamma " << gamma;
    EXPECT_EQ(n, search.pixels);
  }
}

}  // namespace
}  // namespace shadefit
