// The study's job graph (docs/studies.md, "Jobs"): one fit job per material x model x training
// set, then one probe job per material after all of that material's fits. A job's hash covers
// everything its results depend on (shadefit's version, the settings, the input files' bytes),
// so a job is up to date exactly when its JSON holds its current hash.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "shadefit/studies/study.h"

namespace shadefit::studies::internal {

// SHA-256 of a reference's input files, for the job hashes and provenance.json.
struct InputHashes {
  std::string image, sidecar, scene, scene_path;
};

// By reference image path, every reference of the study. Throws shadefit::Error naming a file
// that cannot be read.
std::map<std::string, InputHashes> HashInputs(const StudySpec& spec);

struct Job {
  enum class Kind { kFit, kProbe };
  Kind kind = Kind::kFit;
  std::string id;           // File-name safe: "fit.red-plastic.ggx.key", "probe.red-plastic".
  int group = 0;            // Index into spec.groups.
  ModelRef model;           // Fit jobs: resolved when the study was loaded.
  std::string label;
  std::vector<std::string> train;
  fit::Loss loss = fit::Loss::kL2;  // Fit jobs: the loss it is fitted under.
  std::vector<int> deps;    // Job indices.
  std::string hash;
  double weight = 1;        // Relative cost estimate for the ETA.
  enum class State { kPending, kRunning, kDone, kSkipped, kFailed, kNotRun } state = State::kPending;

  bool Finished() const { return state == State::kDone || state == State::kFailed; }
};

// Every job of the study, dependencies before the jobs that need them.
std::vector<Job> BuildJobs(const StudySpec& spec, const std::map<std::string, InputHashes>& hashes);

// A fit job's id and file name: "fit.<material>.<model>.<lighting>+<lighting>", ".<loss>" added
// when the study lists several losses, made file-name safe (FileSafe).
std::string FitJobId(const StudySpec& spec, const std::string& material, const FitSpec& f);

// Throws shadefit::Error naming the study file when two fits of the study would share a job id
// (two materials, say "a b" and "a_b", that FileSafe maps to one name): LoadStudy's last check,
// before anything is written.
void CheckJobIds(const StudySpec& spec);

// "key+rim".
std::string JoinTrain(const std::vector<std::string>& train);

// `s` with '/', ' ' and '\' replaced by '_'.
std::string FileSafe(std::string s);

// Whether `lighting` was trained on ("train"), tested ("test") or neither ("other").
std::string SplitOf(const StudySpec& spec, const std::string& lighting,
                    const std::vector<std::string>& train);

// Where a job's files go, under the study's output folder.
struct StudyPaths {
  std::filesystem::path dir;  // <out>/<study name>
  std::string JobJson(const Job& job) const;     // jobs/<id>.json
  std::string TimingJson(const Job& job) const;  // jobs/<id>.timing.json
};

}  // namespace shadefit::studies::internal
