// Fit failure modes in a study (issue 14): a fit that does not converge, one whose residuals
// come back NaN, a degenerate (all-black) reference and a lost GL context are each recorded in
// results.csv's `status` column and the job JSON, and the study carries on: every other job
// runs, results.csv and the probes are written, and RunStudy reports no failed job.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "shadefit/render/image.h"
#include "shadefit/studies/runner.h"
#include "shadefit/studies/study.h"

namespace shadefit::studies {
namespace {
namespace fs = std::filesystem;
using json = nlohmann::json;

struct Row {
  std::string material, lighting, label, converged, status, rmse;
};

std::vector<Row> ReadResults(const fs::path& csv) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  for (std::stringstream ss(line); std::getline(ss, line, ',');) header.push_back(line);
  std::vector<Row> rows;
  while (std::getline(in, line)) {
    std::map<std::string, std::string> cell;
    std::stringstream ss(line);
    for (const std::string& h : header) std::getline(ss, cell[h], ',');
    rows.push_back({cell["material"], cell["lighting"], cell["label"], cell["converged"],
                    cell["status"], cell["rmse"]});
  }
  return rows;
}

json ReadJson(const fs::path& p) {
  std::ifstream in(p);
  return json::parse(in);
}

StudySpec QuickSpec() {
  return LoadStudy(std::string(SHADEFIT_SOURCE_DIR) + "/studies/pbs_vs_blinn_phong.toml", true);
}

RunSummary RunWithFault(const StudySpec& spec, const fs::path& out, const char* fault = nullptr) {
  fs::remove_all(out);
  if (fault != nullptr) setenv("SHADEFIT_TEST_FAULT", fault, 1);
  RunOptions options;
  options.out_dir = out.string();
  options.jobs = 2;
  options.quiet = true;
  const RunSummary s = RunStudy(spec, options);
  unsetenv("SHADEFIT_TEST_FAULT");
  return s;
}

// The study finished: nothing failed or was left unrun, results.csv and every probe job exist.
void ExpectCarriedOn(const RunSummary& s, const StudySpec& spec) {
  EXPECT_EQ(s.failed, 0);
  EXPECT_EQ(s.not_run, 0);
  EXPECT_TRUE(fs::exists(fs::path(s.study_dir) / "results.csv"));
  for (const ReferenceGroup& g : spec.groups) {
    EXPECT_TRUE(fs::exists(fs::path(s.study_dir) / "jobs" / ("probe." + g.material + ".json")))
        << g.material;
  }
}

const fs::path kOut = fs::path(SHADEFIT_TEST_OUTPUT) / "fit_failure";

TEST(FitFailure, NonConvergenceIsRecordedAndTheStudyGoesOn) {
  StudySpec spec = QuickSpec();
  spec.model_settings.at("ggx").max_iterations = 1;
  const RunSummary s = RunWithFault(spec, kOut / "not_converged");
  ExpectCarriedOn(s, spec);
  int ggx = 0;
  for (const Row& r : ReadResults(fs::path(s.study_dir) / "results.csv")) {
    if (r.label == "ggx") {
      ++ggx;
      EXPECT_EQ(r.converged, "0");
      EXPECT_EQ(r.status, "not-converged");
      EXPECT_FALSE(r.rmse.empty()) << "a fit that stopped early still has parameters and metrics";
    } else {
      EXPECT_EQ(r.status, "ok") << r.label;
    }
  }
  EXPECT_GT(ggx, 0);
  EXPECT_TRUE(s.fits_without_parameters.empty());
}

TEST(FitFailure, NanResidualsAreRecordedAndTheProbesGoOnWithoutThatFit) {
  const StudySpec spec = QuickSpec();
  const RunSummary s = RunWithFault(spec, kOut / "nan", "nan-residuals:1");
  ExpectCarriedOn(s, spec);
  ASSERT_EQ(s.fits_without_parameters.size(), 1u);
  const std::string id = s.fits_without_parameters[0].substr(0, s.fits_without_parameters[0].find(':'));
  const json job = ReadJson(fs::path(s.study_dir) / "jobs" / (id + ".json"));
  EXPECT_EQ(job["status"], "nan-residuals");
  EXPECT_TRUE(job["parameters"].empty());
  int rows = 0;
  for (const Row& r : ReadResults(fs::path(s.study_dir) / "results.csv")) {
    if (r.status != "nan-residuals") continue;
    ++rows;
    EXPECT_EQ(job["label"], r.label);
    EXPECT_TRUE(r.rmse.empty()) << "no parameters, no metrics";
  }
  EXPECT_GT(rows, 0) << "the failed fit has no rows in results.csv";
  const json probe = ReadJson(fs::path(s.study_dir) / "jobs" / ("probe." + job["material"].get<std::string>() + ".json"));
  EXPECT_EQ(probe["status"], "ok");
  EXPECT_EQ(probe["fits_without_parameters"], json::array({job["label"]}));
  EXPECT_FALSE(probe["probes"].empty());
}

// A finite solve whose parameters render an infinite pixel under one of the material's
// references: before, the metrics threw "pixels: infinite value" and the study exited 1.
TEST(FitFailure, NonFiniteRenderIsRecordedWithNoImageAndTheStudyGoesOn) {
  const StudySpec spec = QuickSpec();
  const RunSummary s = RunWithFault(spec, kOut / "inf_render", "inf-render:2");
  ExpectCarriedOn(s, spec);
  ASSERT_EQ(s.fits_without_parameters.size(), 1u);
  const std::string id =
      s.fits_without_parameters[0].substr(0, s.fits_without_parameters[0].find(':'));
  const json job = ReadJson(fs::path(s.study_dir) / "jobs" / (id + ".json"));
  EXPECT_EQ(job["status"], "non-finite-render");
  EXPECT_NE(job["error"].get<std::string>().find("the fit renders inf at"), std::string::npos)
      << job["error"];
  EXPECT_TRUE(job["parameters"].empty());
  int rows = 0;
  for (const Row& r : ReadResults(fs::path(s.study_dir) / "results.csv")) {
    if (r.status != "non-finite-render") continue;
    ++rows;
    EXPECT_EQ(job["label"], r.label);
    EXPECT_TRUE(r.rmse.empty()) << "no parameters, no metrics";
  }
  EXPECT_GT(rows, 0);
  // The fit's previews of the references evaluated before the failing one are gone.
  auto ends_with = [](const std::string& s, const std::string& end) {
    return s.size() > end.size() && s.compare(s.size() - end.size(), end.size(), end) == 0;
  };
  const std::string label = job["label"].get<std::string>();
  for (const auto& e : fs::directory_iterator(fs::path(s.study_dir) / "images")) {
    const std::string name = e.path().filename().string();
    const bool of_fit = name.rfind(job["material"].get<std::string>() + "-", 0) == 0 &&
                        (ends_with(name, "." + label + ".png") ||
                         ends_with(name, "." + label + ".error.png"));
    EXPECT_FALSE(of_fit) << name << " left by the failed fit";
  }
}

TEST(FitFailure, BlackReferenceIsRecordedForEveryModelAndTheStudyGoesOn) {
  StudySpec spec = QuickSpec();
  // A black copy of red plastic's key reference, with a sidecar naming the same scene.
  const ReferenceSpec& src = spec.groups.front().references.front();
  const fs::path dir = kOut / "black_input";
  fs::remove_all(dir);
  fs::create_directories(dir);
  Image image = ReadImage(src.image_path);
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      for (int c = 0; c < 3; ++c) image.at(x, y, c) = 0.0f;
    }
  }
  const fs::path exr = dir / "black-key.exr";
  WriteExr(exr.string(), image);
  json sidecar = ReadJson(src.sidecar_path);
  const fs::path scene = fs::path(src.sidecar_path).parent_path() / sidecar["scene_file"].get<std::string>();
  sidecar["scene_file"] = fs::absolute(scene).lexically_normal().string();
  sidecar.erase("material");  // No ground truth for the probes.
  std::ofstream(dir / "black-key.json") << sidecar.dump(1);
  ReferenceGroup black;
  black.material = "black";
  ReferenceSpec ref = src;
  ref.name = "black-key";
  ref.material = "black";
  ref.image_path = fs::absolute(exr).string();
  ref.sidecar_path = fs::absolute(dir / "black-key.json").string();
  black.references.push_back(ref);
  spec.groups.push_back(black);

  const RunSummary s = RunWithFault(spec, kOut / "black");
  ExpectCarriedOn(s, spec);
  EXPECT_EQ(s.fits_without_parameters.size(), spec.models.size());
  for (const Row& r : ReadResults(fs::path(s.study_dir) / "results.csv")) {
    EXPECT_EQ(r.status, r.material == "black" ? "degenerate-reference" : "ok")
        << r.material << " " << r.label;
  }
  const json probe = ReadJson(fs::path(s.study_dir) / "jobs" / "probe.black.json");
  EXPECT_EQ(probe["status"], "no-fit");
  const json fit = ReadJson(fs::path(s.study_dir) / "jobs" / "fit.black.ggx.key.json");
  EXPECT_NE(fit["error"].get<std::string>().find("all"), std::string::npos) << fit["error"];
  EXPECT_NE(fit["error"].get<std::string>().find("black"), std::string::npos) << fit["error"];
}

TEST(FitFailure, LostGlContextIsRetriedOnANewContext) {
  const StudySpec spec = QuickSpec();
  const RunSummary s = RunWithFault(spec, kOut / "gl_lost_once", "gl-lost:1");
  ExpectCarriedOn(s, spec);
  EXPECT_TRUE(s.fits_without_parameters.empty()) << "the retry on a new context succeeded";
  for (const Row& r : ReadResults(fs::path(s.study_dir) / "results.csv")) EXPECT_EQ(r.status, "ok");
  std::ifstream log(fs::path(s.study_dir) / "study.log");
  const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("new GL context"), std::string::npos);
}

TEST(FitFailure, ContextLostOnEveryAttemptIsRecordedAndRetriedByTheNextRun) {
  const StudySpec spec = QuickSpec();
  const RunSummary s = RunWithFault(spec, kOut / "gl_lost", "gl-lost:*");
  ExpectCarriedOn(s, spec);
  const int fits = static_cast<int>(spec.training_sets.size() * spec.models.size());
  EXPECT_EQ(static_cast<int>(s.fits_without_parameters.size()),
            fits * static_cast<int>(spec.groups.size()));
  for (const Row& r : ReadResults(fs::path(s.study_dir) / "results.csv")) {
    EXPECT_EQ(r.status, "gl-context-lost");
  }
  // The next run, with a healthy context, redoes exactly those fits.
  RunOptions options;
  options.out_dir = (kOut / "gl_lost").string();
  options.jobs = 2;
  options.quiet = true;
  const RunSummary again = RunStudy(spec, options);
  EXPECT_EQ(again.failed, 0);
  EXPECT_TRUE(again.fits_without_parameters.empty());
  for (const Row& r : ReadResults(fs::path(again.study_dir) / "results.csv")) {
    EXPECT_EQ(r.status, "ok");
  }
}

}  // namespace
}  // namespace shadefit::studies
