// The job records (studies/runner/src/job_records.h): what one stage writes the next reads back
// field for field, and a record with a field missing or of another type is a one-line error
// naming the file and the field, never a default. Also the references the jobs share
// (studies/runner/src/loaded_references.h): each read once, side by side by the workers.
#include "job_records.h"

#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "loaded_references.h"

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

// A stand-in for a read reference: its path and a one-pixel image.
reference_images::Reference FakeReference(const std::string& path) {
  reference_images::Reference r;
  r.image_path = path;
  r.image = Image(1, 1, 3);
  return r;
}

TEST(LoadedReferencesTest, WorkersAskingForOneSetReadItSideBySide) {
  std::mutex mutex;
  std::condition_variable changed;
  int started = 0;
  std::map<std::string, int> reads;
  std::set<std::thread::id> readers;
  LoadedReferences loaded(std::size_t{1} << 30, [&](const std::string& path) {
    std::unique_lock lock(mutex);
    ++reads[path];
    readers.insert(std::this_thread::get_id());
    ++started;
    changed.notify_all();
    // The first read waits for the other worker to start a read of its own (10 s at most): a
    // worker that queues behind the first read never does.
    if (started == 1) changed.wait_for(lock, std::chrono::seconds(10), [&] { return started > 1; });
    return FakeReference(path);
  });
  const std::vector<std::string> paths = {"a.exr", "b.exr", "c.exr", "d.exr", "e.exr", "f.exr"};
  std::vector<LoadedReferences::Shared> got[2];
  std::thread other([&] { got[1] = loaded.GetAll(paths); });
  got[0] = loaded.GetAll(paths);
  other.join();
  EXPECT_EQ(readers.size(), 2u) << "one worker read every reference while the other waited";
  for (const std::string& p : paths) EXPECT_EQ(reads[p], 1) << p;
  for (int t = 0; t < 2; ++t) {
    ASSERT_EQ(got[t].size(), paths.size());
    for (std::size_t i = 0; i < paths.size(); ++i) {
      ASSERT_TRUE(got[t][i]);
      EXPECT_EQ(got[t][i]->image_path, paths[i]);
      EXPECT_EQ(got[t][i], got[1 - t][i]) << "the workers hold one copy of " << paths[i];
    }
  }
  // Asked again, the set is read already.
  EXPECT_EQ(loaded.GetAll(paths)[2], got[0][2]);
  EXPECT_EQ(reads["c.exr"], 1);
}

TEST(LoadedReferencesTest, AFailedReadGivesTheFirstFailingPathsErrorAndIsForgotten) {
  std::mutex mutex;
  std::map<std::string, int> reads;
  bool broken = true;
  LoadedReferences loaded(std::size_t{1} << 30, [&](const std::string& path) {
    {
      std::lock_guard lock(mutex);
      ++reads[path];
    }
    if (broken && (path == "b.exr" || path == "d.exr")) throw Error(path, "", "cannot read");
    return FakeReference(path);
  });
  const std::vector<std::string> paths = {"d.exr", "a.exr", "b.exr", "c.exr"};
  std::string errors[2];
  auto ask = [&](std::string* error) {
    try {
      loaded.GetAll(paths);
    } catch (const Error& e) {
      *error = e.what();
    }
  };
  std::thread other(ask, &errors[1]);
  ask(&errors[0]);
  other.join();
  for (const std::string& e : errors) EXPECT_NE(e.find("d.exr"), std::string::npos) << e;
  // The other failing path was left to the second pass: asked for alone it reports itself.
  EXPECT_THROW(loaded.Get("b.exr"), Error);
  broken = false;
  EXPECT_EQ(loaded.GetAll(paths)[0]->image_path, "d.exr");  // Forgotten: read again, now fine.
  EXPECT_EQ(reads["a.exr"], 1);
}

}  // namespace
}  // namespace shadefit::studies::internal
