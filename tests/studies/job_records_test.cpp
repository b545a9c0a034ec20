// The job records (studies/runner/src/job_records.h): what one stage writes the next reads back
// field for field, and a record with a field missing or of another type is a one-line error
// naming the file and the field, never a default.
#include "job_records.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "shadefit/base/error.h"

namespace shadefit::studies::internal {
namespace {
using json = nlohmann::json;
namespace fs = std::filesystem;

// A fit job's JSON as the runner writes it, by hand (not through ToJson).
json HandWrittenFit() {
  return json::parse(R"({
    "schema": "shadefit.study.job/1", "id": "fit.gold.ggx.key", "kind": "fit", "hash": "ab12",
    "shadefit_version": "1.2.3", "material": "gold", "model": "ggx", "label": "ggx@key",
    "train": ["key"], "status": "not-converged", "converged": false,
    "settings": {"loss": "l2"}, "termination": "NO_CONVERGENCE",
    "values": [0.5, 0.25, 0.125, 0.04, 0.04, 0.04, 0.3], "exposure": 1.5,
    "parameters": [{"name": "kd.r"}], "fit": {"solver": {}},
    "evaluations": [{"reference": "gold-key", "lighting": "key", "split": "train",
                     "measured_fraction": 0.75, "metrics": {"rmse": 0.1},
                     "metrics_all": {"rmse": 0.2}, "rmse_fitter": 0.09}],
    "outputs": ["previews/gold-key.ggx.png"]})");
}

std::string Write(const std::string& name, const json& j) {
  const fs::path dir = fs::path(SHADEFIT_TEST_OUTPUT) / "job_records";
  fs::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path) << j.dump(1);
  return path;
}

std::string ErrorOf(const std::string& path) {
  try {
    ReadFitJobRecord(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(JobRecords, FitRecordReadsEveryFieldAndWritesTheSameJson) {
  const json written = HandWrittenFit();
  const FitJobRecord r = ReadFitJobRecord(Write("fit.json", written));
  EXPECT_EQ(r.id, "fit.gold.ggx.key");
  EXPECT_EQ(r.model, "ggx");
  EXPECT_EQ(r.label, "ggx@key");
  EXPECT_EQ(r.train, std::vector<std::string>{"key"});
  EXPECT_EQ(r.status, FitStatus::kNotConverged);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.values[2], 0.125);
  EXPECT_EQ(r.exposure, 1.5);
  ASSERT_EQ(r.evaluations.size(), 1u);
  EXPECT_EQ(r.evaluations[0].lighting, "key");
  EXPECT_EQ(r.evaluations[0].measured_fraction, 0.75);
  EXPECT_EQ(r.evaluations[0].metrics_all["rmse"], 0.2);
  EXPECT_EQ(r.evaluations[0].details["rmse_fitter"], 0.09);  // Kept for the report.
  EXPECT_TRUE(r.encoding.is_null());
  EXPECT_EQ(ToJson(r), written);  // Nothing lost or added on the way through.
}

TEST(JobRecords, FailedFitHasAnErrorAndNoParameters) {
  json j = HandWrittenFit();
  for (const char* field : {"settings", "termination", "values", "exposure", "fit"}) j.erase(field);
  j["status"] = "degenerate-reference";
  j["evaluations"] = json::array();
  j["error"] = "every valid pixel is black";
  const FitJobRecord r = ReadFitJobRecord(Write("failed.json", j));
  EXPECT_EQ(r.error, "every valid pixel is black");
  EXPECT_TRUE(r.values.empty());
  EXPECT_EQ(ToJson(r), j);
  j.erase("error");
  EXPECT_EQ(ErrorOf(Write("failed-no-error.json", j)),
            Write("failed-no-error.json", j) + ": error: missing");
}

TEST(JobRecords, MissingOrMistypedFieldNamesFileAndField) {
  for (const char* field :
       {"schema", "id", "hash", "material", "model", "label", "train", "status", "converged",
        "values", "exposure", "evaluations", "outputs", "settings", "fit"}) {
    json j = HandWrittenFit();
    j.erase(field);
    const std::string path = Write("missing.json", j);
    EXPECT_EQ(ErrorOf(path), path + ": " + field + ": missing");
  }
  json j = HandWrittenFit();
  j["values"] = "0.5";
  std::string path = Write("mistyped.json", j);
  EXPECT_EQ(ErrorOf(path), path + ": values: expected an array of numbers");
  j = HandWrittenFit();
  j["evaluations"][0].erase("lighting");
  path = Write("evaluation.json", j);
  EXPECT_EQ(ErrorOf(path), path + ": evaluations[0].lighting: missing");
  j = HandWrittenFit();
  j["evaluations"][0] = "gold-key";
  path = Write("evaluation-type.json", j);
  EXPECT_EQ(ErrorOf(path), path + ": evaluations[0]: expected an object");
  j = HandWrittenFit();
  j["status"] = "fine";
  path = Write("status.json", j);
  EXPECT_EQ(ErrorOf(path), path + ": status: unknown fit status 'fine'");
  j = HandWrittenFit();
  j["kind"] = "probe";
  path = Write("kind.json", j);
  EXPECT_EQ(ErrorOf(path), path + ": kind: expected \"fit\"");
  path = Write("truncated.json", json());
  std::ofstream(path) << "{\"schema\": \"shadefit.study.job/1\", \"id\": ";
  EXPECT_EQ(ErrorOf(path).rfind(path + ": malformed JSON: ", 0), 0u) << ErrorOf(path);
}

TEST(JobRecords, HeadOfEitherKind) {
  const JobRecordHead fit = ReadJobRecordHead(Write("head-fit.json", HandWrittenFit()));
  EXPECT_EQ(fit.hash, "ab12");
  EXPECT_EQ(fit.status, FitStatus::kNotConverged);
  EXPECT_EQ(fit.outputs, std::vector<std::string>{"previews/gold-key.ggx.png"});
  ProbeJobRecord probe;
  probe.id = "probe.gold";
  probe.hash = "cd34";
  probe.material = "gold";
  probe.status = "ok";
  probe.outputs = {"probes/gold/fresnel.json"};
  const JobRecordHead head = ReadJobRecordHead(Write("head-probe.json", ToJson(probe)));
  EXPECT_EQ(head.hash, "cd34");
  EXPECT_FALSE(head.status.has_value());
  EXPECT_EQ(head.outputs, probe.outputs);
  json bad = ToJson(probe);
  bad["status"] = "done";
  const std::string path = Write("probe-status.json", bad);
  try {
    ReadProbeJobRecord(path);
    FAIL() << "no error for a probe status the runner never writes";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), path + ": status: expected ok or no-fit");
  }
}

}  // namespace
}  // namespace shadefit::studies::internal
