// Study file parsing: globs, lightings, quick overrides, labels and the errors bad files give.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "shadefit/base/error.h"
#include "shadefit/studies/study.h"

namespace shadefit::studies {
namespace {
namespace fs = std::filesystem;

const std::string kRefs = std::string(SHADEFIT_SOURCE_DIR) + "/reference_images/cycles";

// In a folder of the running test's own: ctest runs this file's tests as processes side by side,
// and two of them writing "g1.toml" in one folder read each other's (a failure seen once in 784).
std::string WriteStudy(const std::string& name, const std::string& text) {
  const fs::path dir = fs::path(SHADEFIT_TEST_OUTPUT) / "studies" / "files" /
                       ::testing::UnitTest::GetInstance()->current_test_info()->name();
  fs::create_directories(dir);
  const fs::path p = dir / name;
  std::ofstream(p) << text;
  return p.string();
}

std::string Base(const std::string& extra = "") {
  return "[study]\nname = \"t\"\n[[group]]\nmaterial = \"gold\"\nimages = [\"" + kRefs +
         "/gold-*.exr\"]\nexclude = [\"*-env.exr\"]\n[fit]\nmodels = [\"ggx\", \"blinn-phong\"]\n"
         "train = [[\"key\"]]\n" +
         extra;
}

TEST(StudyFile, GlobsLightingsAndDefaults) {
  const StudySpec s = LoadStudy(WriteStudy("a.toml", Base()));
  ASSERT_EQ(s.groups.size(), 1u);
  std::vector<std::string> lightings;
  for (const auto& r : s.groups[0].references) lightings.push_back(r.lighting);
  EXPECT_EQ(lightings, (std::vector<std::string>{"camera", "key", "mirror60", "mirror75",
                                                 "mirror85", "rim", "side"}));
  EXPECT_EQ(s.Label("ggx", {"key"}), "ggx");
  EXPECT_TRUE(s.IsTest("rim", {"key"}));
  EXPECT_FALSE(s.IsTest("key", {"key"}));
  EXPECT_EQ(s.model_settings.at("ggx").loss, fit::Loss::kCubeRoot);
}

TEST(StudyFile, QuickAndOverrides) {
  const std::string text = Base(
      "starts = 5\n[fit.override.ggx]\nstarts = 7\n[quick]\nlightings = [\"key\", \"rim\"]\n"
      "max_iterations = 9\nmodels = [\"ggx\"]\n");
  const StudySpec full = LoadStudy(WriteStudy("b.toml", text));
  EXPECT_EQ(full.models.size(), 2u);
  EXPECT_EQ(full.model_settings.at("ggx").starts, 7);
  EXPECT_EQ(full.model_settings.at("blinn-phong").starts, 5);
  const StudySpec quick = LoadStudy(WriteStudy("b.toml", text), true);
  EXPECT_EQ(quick.models, std::vector<ModelRef>{FindModel("ggx")});
  EXPECT_EQ(quick.groups[0].references.size(), 2u);
  EXPECT_EQ(quick.model_settings.at("ggx").max_iterations, 9);
  EXPECT_EQ(quick.model_settings.at("ggx").starts, 7);
}

TEST(StudyFile, TwoTrainingSetsLabelFits) {
  const StudySpec s = LoadStudy(WriteStudy(
      "c.toml",
      "[study]\nname = \"t\"\n[[group]]\nmaterial = \"gold\"\nimages = [\"" + kRefs +
          "/gold-*.exr\"]\n[fit]\nmodels = [\"ggx\"]\ntrain = [\"key\", [\"key\", \"rim\"]]\n"));
  ASSERT_EQ(s.training_sets.size(), 2u);
  EXPECT_EQ(s.Label("ggx", {"key", "rim"}), "ggx@key+rim");
}

std::string Replace(std::string s, const std::string& from, const std::string& to) {
  s.replace(s.find(from), from.size(), to);
  return s;
}

void ExpectError(const std::string& file, const std::string& text, const std::string& what) {
  try {
    LoadStudy(WriteStudy(file, text));
    FAIL() << "no error for " << file;
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
  }
}

TEST(StudyFile, BadFilesNameTheKey) {
  ExpectError("e1.toml", Base("colour = 1\n"), "fit.colour: unknown key");
  ExpectError("e2.toml", Base("loss = \"l3\"\n"), "fit.loss: unknown loss 'l3'");
  ExpectError("e3.toml", Base("[probes]\nrun = [\"sheen\"]\n"), "probes.run: unknown probe");
  ExpectError("e4.toml",
              "[study]\nname = \"t\"\n[[group]]\nmaterial = \"x\"\nimages = [\"nothing-*.exr\"]\n"
              "[fit]\nmodels = [\"ggx\"]\ntrain = [\"key\"]\n",
              "group.images: 'nothing-*.exr' matches no file");
  ExpectError("e5.toml", Base("[verdicts.fresnel]\nsource = \"fresnel\"\n"),
              "verdicts.fresnel.tolerance: missing");
  ExpectError("e6.toml", Replace(Base(), "train = [[\"key\"]]", "train = [[\"noon\"]]"),
              "material 'gold' has no reference under lighting 'noon'");
  ExpectError("e7.toml", Replace(Base(), "\"ggx\", ", "\"gxx\", "), "unknown model 'gxx'");
}

// [study] baseline and compare (docs/studies.md, "Comparative answers"): the first model by
// default, names checked against fit.models, a model [quick] drops falls back or drops its pair.
TEST(StudyFile, BaselineAndComparisons) {
  const StudySpec plain = LoadStudy(WriteStudy("f1.toml", Base()));
  EXPECT_EQ(plain.baseline, "ggx");
  EXPECT_TRUE(plain.comparisons.empty());
  EXPECT_EQ(plain.ToJson()["baseline"], "ggx");
  const std::string text =
      Replace(Base("[quick]\nmodels = [\"ggx\"]\n"), "name = \"t\"\n",
              "name = \"t\"\nbaseline = \"blinn-phong\"\ncompare = [[\"ggx\", \"blinn-phong\"]]\n");
  const StudySpec s = LoadStudy(WriteStudy("f2.toml", text));
  EXPECT_EQ(s.baseline, "blinn-phong");
  ASSERT_EQ(s.comparisons.size(), 1u);
  EXPECT_EQ(s.comparisons[0][0], "ggx");
  EXPECT_EQ(s.ToJson()["compare"][0][1], "blinn-phong");
  const StudySpec quick = LoadStudy(WriteStudy("f2.toml", text), true);
  EXPECT_EQ(quick.baseline, "ggx");
  EXPECT_TRUE(quick.comparisons.empty());
  ExpectError("f3.toml", Replace(Base(), "name = \"t\"\n", "name = \"t\"\nbaseline = \"phong\"\n"),
              "study.baseline: 'phong' is not one of fit.models");
  ExpectError(
      "f4.toml",
      Replace(Base(), "name = \"t\"\n", "name = \"t\"\ncompare = [[\"ggx\", \"beckmann\"]]\n"),
      "study.compare: 'beckmann' is not one of fit.models");
  ExpectError("f5.toml", Replace(Base(), "name = \"t\"\n", "name = \"t\"\ncompare = [\"ggx\"]\n"),
              "study.compare: expected a pair of model names");
}

// [fit] start = "brdf" (issue 32, item 2): read per model, written into the settings (and so the
// job hashes) only when not the default; any other value is refused with its key.
TEST(StudyFile, StartFromTheBrdfSpaceFit) {
  const StudySpec plain = LoadStudy(WriteStudy("g1.toml", Base()));
  EXPECT_EQ(plain.model_settings.at("ggx").start, StartFrom::kDefault);
  EXPECT_FALSE(plain.model_settings.at("ggx").ToJson().contains("start"));
  const StudySpec s =
      LoadStudy(WriteStudy("g2.toml", Base("[fit.override.ggx]\nstart = \"brdf\"\n")));
  EXPECT_EQ(s.model_settings.at("ggx").start, StartFrom::kBrdf);
  EXPECT_EQ(s.model_settings.at("ggx").ToJson()["start"], "brdf");
  EXPECT_EQ(s.model_settings.at("blinn-phong").start, StartFrom::kDefault);
  ExpectError("g3.toml", Base("start = \"ngan\"\n"),
              "fit.start: expected \"default\" or \"brdf\"");
}

// fit.fixed is checked against every listed model's parameter table when the file is loaded
// (issue 33, item 1): a name one model lacks is an error with file, line and key, and the way out
// is to write it per model; values out of a model's range fail the same way.
TEST(StudyFile, FixedNamesAParameterOfEveryModel) {
  // Base() lists ggx and blinn-phong; blinn-phong has no f0. The [fit] table's `fixed` is on
  // line 10 of the file Base() writes.
  const std::string bad = Base("fixed = [\"f0=0.04\"]\n");
  try {
    LoadStudy(WriteStudy("g1.toml", bad));
    FAIL() << "no error for fit.fixed naming a parameter blinn-phong lacks";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("g1.toml:10: fit.fixed: 'f0' is not a parameter of model 'blinn-phong'"),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("[fit.override.<model>]"), std::string::npos) << what;
  }
  // Written per model, it loads, and each model gets only its own list.
  const StudySpec s = LoadStudy(WriteStudy(
      "g2.toml", Base("fixed = [\"kd=0.5\"]\n[fit.override.ggx]\nfixed = [\"f0=0.04\"]\n")));
  // Typed for each model: the row of its own table and the value spread over the colour.
  const std::vector<FixedValue>& ggx = s.model_settings.at("ggx").fixed;
  ASSERT_EQ(ggx.size(), 1u);
  EXPECT_EQ(ggx[0].param, FindModel("ggx").Find("f0"));
  EXPECT_EQ(ggx[0].values, (std::vector<double>{0.04, 0.04, 0.04}));
  EXPECT_EQ(FixedTexts(s.model_settings.at("blinn-phong").fixed),
            std::vector<std::string>{"kd=0.5"});
  EXPECT_EQ(s.model_settings.at("blinn-phong").fixed[0].param, FindModel("blinn-phong").Find("kd"));
  // A per-model list is checked against its own model, and names its key.
  ExpectError("g3.toml", Base("[fit.override.blinn-phong]\nfixed = [\"f0=0.04\"]\n"),
              "fit.override.blinn-phong.fixed: 'f0' is not a parameter of model 'blinn-phong'");
  ExpectError("g4.toml", Base("fixed = [\"kd=2\"]\n"),
              "fit.fixed: model 'ggx': kd: value 2 outside [0, 1]");
  ExpectError("g5.toml",
              Base("fixed = [\"roughnes=0.3\"]\n[fit.override.blinn-phong]\nfixed = []\n"),
              "'roughnes' is not a parameter of model 'ggx' (did you mean 'roughness'?)");
  // [quick] fixed replaces the list under --quick and is checked there.
  try {
    LoadStudy(WriteStudy("g6.toml", Base("[quick]\nfixed = [\"shininess=10\"]\n")), true);
    FAIL() << "no error for quick.fixed naming a parameter ggx lacks";
  } catch (const Error& e) {
    EXPECT_NE(
        std::string(e.what()).find("quick.fixed: 'shininess' is not a parameter of model 'ggx'"),
        std::string::npos)
        << e.what();
  }
}

// The shipped photograph template loads with any list of models: it fixes nothing, since each
// model's scale under a free exposure is pinned by the fitter (fit/exposure_pin.h).
TEST(StudyFile, PhotoTemplateFixedIsPerModel) {
  std::ifstream in(std::string(SHADEFIT_SOURCE_DIR) + "/studies/photo_set_template.toml");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_FALSE(text.empty());
  // Point its images at the shipped gold renders, train on key, and list models without f0.
  std::string t = Replace(text, "refs/sphere-*.exr", kRefs + "/gold-*.exr");
  t = Replace(t, "\"sphere\"", "\"gold\"");
  t = Replace(t, "[[\"L0\", \"L3\", \"L4\", \"L7\"]]", "[[\"key\", \"rim\"]]");
  const std::size_t from = t.find("models = [");
  t.replace(from, t.find('\n', from) - from,
            "models = [\"blinn-phong\", \"blinn-phong-normalized\", \"ggx\", \"beckmann\", "
            "\"cook-torrance\"]");
  const StudySpec s = LoadStudy(WriteStudy("photo_set.toml", t));
  EXPECT_EQ(s.models.size(), 5u);
  for (ModelRef model : s.models) {
    EXPECT_TRUE(s.SettingsOf(model).fixed.empty()) << model->name;
  }
}

// Every study file the repository ships loads as it is (those of measured materials with or
// without ../shared beside the clone: a missing folder is skipped, not an error). The photo
// template points at the user's images: PhotoTemplateFixedIsPerModel loads it, filled in.
TEST(StudyFile, EveryShippedStudyLoads) {
  int loaded = 0;
  for (const auto& entry : fs::directory_iterator(std::string(SHADEFIT_SOURCE_DIR) + "/studies")) {
    if (entry.path().extension() != ".toml") continue;
    if (entry.path().stem().string().ends_with("_template")) continue;
    try {
      LoadStudy(entry.path().string());
      ++loaded;
    } catch (const std::exception& e) {
      ADD_FAILURE() << e.what();
    }
  }
  EXPECT_GE(loaded, 6);
}

}  // namespace
}  // namespace shadefit::studies

// Losses and floors (docs/studies.md, "Losses and floors"): a list of losses is a fit per loss,
// labelled and listed like training sets; the floor is one more training set, labelled "floor".
namespace shadefit::studies {
namespace {

TEST(StudyFile, LossListAndFloorAreFitsOfTheirOwn) {
  const StudySpec s = LoadStudy(WriteStudy(
      "losses.toml", Base("loss = [\"l2\", \"relative\"]\nfloor = [\"camera\", \"key\", \"side\"]\n")));
  EXPECT_EQ(s.losses, (std::vector<fit::Loss>{fit::Loss::kL2, fit::Loss::kRelative}));
  EXPECT_EQ(s.floor_lightings, (std::vector<std::string>{"camera", "key", "side"}));
  ASSERT_EQ(s.training_sets.size(), 2u);
  std::vector<std::string> labels, roles;
  for (const FitSpec& f : s.Fits()) {
    labels.push_back(f.label);
    roles.push_back(FitRoleName(f.role));
    EXPECT_EQ(s.SettingsOf(f.model, f.loss).loss, f.loss);
  }
  EXPECT_EQ(labels, (std::vector<std::string>{
                        "ggx@key:l2", "ggx@key:relative", "blinn-phong@key:l2",
                        "blinn-phong@key:relative", "ggx@floor:l2", "ggx@floor:relative",
                        "blinn-phong@floor:l2", "blinn-phong@floor:relative"}));
  EXPECT_EQ(roles[0], "train");
  EXPECT_EQ(roles[4], "floor");
  const nlohmann::json j = s.ToJson();
  EXPECT_EQ(j["losses"], (nlohmann::json{"l2", "relative"}));
  EXPECT_EQ(j["floor"], (nlohmann::json{"camera", "key", "side"}));
  EXPECT_EQ(j["fits"][5]["loss"], "relative");
  EXPECT_EQ(j["fits"][5]["role"], "floor");
  EXPECT_TRUE(j["judging"].is_null());
  // One loss as a list: no suffix, the loss everywhere.
  const StudySpec one = LoadStudy(WriteStudy("one-loss.toml", Base("loss = [\"log\"]\n")));
  ASSERT_EQ(one.Fits().size(), 2u);
  EXPECT_EQ(one.Fits()[0].label, "ggx");
  EXPECT_EQ(one.Fits()[0].loss, fit::Loss::kLog);
}

TEST(StudyFile, JudgingMetricsAreChecked) {
  std::string text = Base() + "[verdicts]\njudging = [\"relative_rmse\", \"ms_ssim\"]\n";
  const StudySpec s = LoadStudy(WriteStudy("judging.toml", text));
  ASSERT_TRUE(s.judging.has_value());
  EXPECT_EQ(*s.judging, (std::vector<std::string>{"relative_rmse", "ms_ssim"}));
  EXPECT_EQ(s.ToJson()["judging"], (nlohmann::json{"relative_rmse", "ms_ssim"}));
}

TEST(StudyFile, BadLossesFloorsAndJudging) {
  ExpectError("l1.toml", Base("loss = [\"l2\", \"l3\"]\n"), "fit.loss: unknown loss 'l3'");
  ExpectError("l2.toml", Base("loss = [\"l2\", \"l2\"]\n"), "fit.loss: 'l2' listed twice");
  ExpectError("l3.toml", Base("loss = []\n"), "fit.loss: empty list of losses");
  ExpectError("l4.toml", Base("loss = [\"l2\", \"log\"]\n[fit.override.ggx]\nloss = \"log\"\n"),
              "fit.override.ggx.loss: fit.loss lists the losses");
  ExpectError("f1.toml", Base("floor = [\"key\", \"nowhere\"]\n"),
              "has no reference under lighting 'nowhere'");
  ExpectError("f2.toml", Base("floor = [\"key\"]\n"), "fit.floor: the floor equals a training set");
  ExpectError("f3.toml", Base("floor = []\n"), "fit.floor: empty");
  ExpectError("j1.toml", Base() + "[verdicts]\njudging = [\"relative_rmes\"]\n",
              "verdicts.judging: unknown metric 'relative_rmes' (did you mean 'relative_rmse'?)");
  ExpectError("j2.toml", Base() + "[verdicts]\njudging = 3\n", "verdicts.judging: expected metric names");
}

}  // namespace
}  // namespace shadefit::studies
