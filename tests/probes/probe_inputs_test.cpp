// Bad input to the probes (one-line shadefit::Error naming the reference/label and the field)
// and the output files (JSON + PNG, atomic).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <limits>

#include "probe_test_util.h"
#include "shadefit/base/error.h"

namespace shadefit::testing {
namespace {

probes::ProbeInputs Inputs() {
  probes::ProbeInputs in;
  in.renderer = &SharedRenderer();
  in.truth = MakeModel("ggx", "ggx", {"kd=0.3", "f0=0.04", "roughness=0.3"});
  in.references.push_back(MakeReference(*in.truth, "key", 32));
  return in;
}

std::string ErrorOf(const probes::ProbeInputs& in) {
  try {
    probes::FresnelProbe(in);
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(ProbeInputs, SizeMismatch) {
  auto in = Inputs();
  in.references[0].image = Image(16, 32, 4, 0.5f);
  EXPECT_EQ(ErrorOf(in), "ggx-key: image: size 16x32 differs from the G-buffer's 32x32");
}

TEST(ProbeInputs, NaNPixel) {
  auto in = Inputs();
  in.references[0].image.at(3, 4, 1) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(ErrorOf(in), "ggx-key: image: non-finite value at pixel (3, 4) channel 1");
}

TEST(ProbeInputs, EmptyMask) {
  auto in = Inputs();
  for (std::size_t i = 0; i < in.references[0].image.PixelCount(); ++i) {
    in.references[0].image.data[i * 4 + 3] = 0.0f;
  }
  EXPECT_EQ(ErrorOf(in),
            "ggx-key: image: empty mask: no pixel with coverage >= 0.999 on an object");
}

TEST(ProbeInputs, NotRgba) {
  auto in = Inputs();
  in.references[0].image = in.references[0].image.Channels(0, 3);
  EXPECT_EQ(ErrorOf(in), "ggx-key: image: expected RGBA (alpha = coverage), got 3 channel(s)");
}

TEST(ProbeInputs, BadModels) {
  auto in = Inputs();
  in.models.push_back(MakeModel("m", "ggx", {}));
  in.models.back().model = ModelRef();
  EXPECT_EQ(ErrorOf(in), "m: model: no model given");
  in.models.back().model = FindModel("lambert");
  EXPECT_EQ(ErrorOf(in), "m: params: model lambert takes 3 values, got 7");
  in.models.back() = MakeModel("m", "ggx", {});
  in.models.back().params[6] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(ErrorOf(in), "m: params.roughness: value nan outside [0.01, 1]");
}

TEST(ProbeInputs, NoReferences) {
  probes::ProbeInputs in;
  EXPECT_EQ(ErrorOf(in), "fresnel: references: no reference given");
}

TEST(ProbeOutputs, WritesJsonAndPngAtomically) {
  const auto in = Inputs();
  const auto result = probes::FresnelProbe(in);
  const std::string dir = TestOutputDir("probes/outputs");
  probes::WriteProbeOutputs(result, dir);
  namespace fs = std::filesystem;
  ASSERT_TRUE(fs::exists(fs::path(dir) / "fresnel.json"));
  ASSERT_TRUE(fs::exists(fs::path(dir) / "fresnel.png"));
  EXPECT_GT(fs::file_size(fs::path(dir) / "fresnel.png"), 1000u);
  std::ifstream f(fs::path(dir) / "fresnel.json");
  const auto j = nlohmann::json::parse(f);
  EXPECT_EQ(j["schema"], probes::kProbeResultSchema);
  EXPECT_EQ(j["probe"], "fresnel");
  ASSERT_TRUE(j["curves"].is_array());
  ASSERT_EQ(j["curves"].size(), result.curves.size());
  EXPECT_EQ(j["curves"][0]["series"], result.curves[0].series);
  for (const auto& e : fs::directory_iterator(dir)) {
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
  }
}

TEST(ProbeOutputs, UnwritableDirectoryIsAnError) {
  const std::string dir = TestOutputDir("probes");
  { std::ofstream(dir + "/a_file") << "x"; }
  probes::ProbeResult r(probes::ProbeKind::kEnergy);
  try {
    probes::WriteProbeOutputs(r, dir + "/a_file/sub");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("a_file/sub"), std::string::npos) << e.what();
  }
}

// A curve is written as one record whose fields are the typed curve's, value for value: no name
// to parse back (docs/probes.md).
TEST(ProbeOutputs, CurvesAreWrittenAsRecords) {
  probes::ProbeResult r(probes::ProbeKind::kHighlight);
  r.curves.push_back({.series = "ggx",
                      .reference = "gold-key",
                      .lighting = "key",
                      .kind = probes::CurveKind::kFalloff,
                      .x = {0.25, 0.75},
                      .y = {1.0, std::numeric_limits<double>::quiet_NaN()},
                      .x_label = "theta_h (deg)",
                      .y_label = "specular / peak",
                      .y_scale = probes::AxisScale::kLog});
  r.curves.push_back({.series = "truth",
                      .kind = probes::CurveKind::kRmsePerReference,
                      .x = {0.0},
                      .y = {0.5},
                      .x_ticks = {"gold-key"}});
  const nlohmann::json j = probes::ProbeResultToJson(r);
  EXPECT_EQ(j["probe"], "highlight");
  ASSERT_EQ(j["curves"].size(), 2u);
  const nlohmann::json& a = j["curves"][0];
  EXPECT_EQ(a["series"], "ggx");
  EXPECT_EQ(a["reference"], "gold-key");
  EXPECT_EQ(a["lighting"], "key");
  EXPECT_EQ(a["kind"], "falloff");
  EXPECT_EQ(a["x"], nlohmann::json({0.25, 0.75}));
  EXPECT_EQ(a["y"][0], 1.0);
  EXPECT_TRUE(a["y"][1].is_null());
  EXPECT_EQ(a["x_label"], "theta_h (deg)");
  EXPECT_EQ(a["x_scale"], "linear");
  EXPECT_EQ(a["y_scale"], "log");
  EXPECT_TRUE(a["x_ticks"].empty());
  const nlohmann::json& b = j["curves"][1];
  EXPECT_TRUE(b["reference"].is_null());
  EXPECT_TRUE(b["lighting"].is_null());
  EXPECT_EQ(b["kind"], "RMSE per reference");
  EXPECT_EQ(b["x_ticks"], nlohmann::json({"gold-key"}));
  EXPECT_EQ(probes::FindCurve(r, probes::CurveKind::kFalloff, "ggx", "gold-key"), &r.curves[0]);
  EXPECT_EQ(probes::FindCurve(r, probes::CurveKind::kFalloff, "ggx"), nullptr);

  r.curves[1].y.push_back(1.0);  // x and y of different lengths: a bug, not a file
  EXPECT_THROW(probes::ProbeResultToJson(r), Error);
}

// Probe names are parsed once into kinds; every kind's name parses back to it.
// Kept renders (ModelRenders, as a study's probe job keeps them across its probes) give the
// numbers of fresh renders, and a model with other parameters under the same label and name is
// rendered anew rather than given the kept image.
TEST(ProbeInputs, KeptRendersGiveTheNumbersOfFreshRenders) {
  probes::ProbeInputs in;
  in.renderer = &SharedRenderer();
  in.truth = MakeModel("ggx", "ggx", {"kd=0.4,0.3,0.2", "f0=0.04", "roughness=0.3"});
  for (const char* l : {"key", "side"}) in.references.push_back(MakeReference(*in.truth, l, 48));
  const probes::ModelUnderTest sharp = MakeModel("fit", "ggx", {"kd=0.4", "roughness=0.15"});
  probes::ModelUnderTest broad = MakeModel("fit", "ggx", {"kd=0.4", "roughness=0.6"});
  broad.trained_on = {in.references.front().name};
  probes::ModelRenders renders;
  in.models = {sharp};
  in.renders = &renders;
  probes::FresnelProbe(in);
  EXPECT_EQ(renders.size(), 2u);  // one per reference
  in.models = {broad};
  for (const probes::ProbeKind kind : {probes::ProbeKind::kFresnel, probes::ProbeKind::kHighlight,
                                       probes::ProbeKind::kPortability}) {
    in.renders = &renders;
    const nlohmann::json kept = probes::ProbeResultToJson(probes::RunProbe(kind, in));
    in.renders = nullptr;
    const nlohmann::json fresh = probes::ProbeResultToJson(probes::RunProbe(kind, in));
    EXPECT_TRUE(kept == fresh) << probes::ProbeName(kind) << ": kept renders changed a number";
  }
  // Both models and the truth (portability's) under both references, each rendered once.
  EXPECT_EQ(renders.size(), 6u);
  // Past its byte budget a ModelRenders keeps nothing more, and the numbers stay the same.
  probes::ModelRenders small(1);
  in.renders = &small;
  const nlohmann::json unkept = probes::ProbeResultToJson(probes::FresnelProbe(in));
  in.renders = nullptr;
  EXPECT_TRUE(unkept == probes::ProbeResultToJson(probes::FresnelProbe(in)));
  EXPECT_EQ(small.size(), 0u);
}

TEST(ProbeKind, NamesRoundTrip) {
  ASSERT_EQ(probes::AllProbeKinds().size(), 5u);
  for (probes::ProbeKind kind : probes::AllProbeKinds()) {
    EXPECT_EQ(probes::ParseProbeKind(probes::ProbeName(kind)), kind);
  }
  EXPECT_EQ(probes::ProbeNames(),
            (std::vector<std::string>{"fresnel", "highlight", "energy", "portability", "brdf"}));
  EXPECT_FALSE(probes::ParseProbeKind("fresnell").has_value());
  EXPECT_FALSE(probes::ParseProbeKind("").has_value());
}

}  // namespace
}  // namespace shadefit::testing
