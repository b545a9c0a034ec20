// The study runner: builds the job graph of a study (one fit per material x model x training
// set, then the probes of each material), runs it on worker threads that each own a GL context,
// and writes every result atomically so an interrupted run resumes where it stopped
// (docs/studies.md, "Outputs").
#pragma once

#include <atomic>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "shadefit/studies/study.h"

namespace shadefit::studies {

struct RunOptions {
  int jobs = 0;               // Worker threads (each with its own GL context); 0 = CPU count.
  std::string out_dir = "out";
  bool force = false;         // Rerun every job even when its hash is unchanged.
  // Set (from a signal handler) to stop scheduling; running jobs finish, nothing partial is left.
  const std::atomic<bool>* interrupt = nullptr;
  // Progress: true draws a bar on stderr (a TTY), false prints one line per finished job.
  bool progress_bar = false;
  bool quiet = false;         // No progress output at all (the log is still written).
};

struct RunSummary {
  std::string study_dir;      // <out>/<study name>
  int total = 0, ran = 0, skipped = 0, failed = 0, not_run = 0;
  bool interrupted = false;
  double seconds = 0;
  std::vector<std::string> ran_ids, skipped_ids, failed_ids;
};

// Runs the study. Throws shadefit::Error when the output folder cannot be made or no GL context
// can be created; a job that fails is logged, counted and leaves no output (its dependents are
// not run). results.csv and provenance.json are written only when every job succeeded.
RunSummary RunStudy(const StudySpec& spec, const RunOptions& options);

struct MeasuredSummary {
  int rendered = 0, unchanged = 0;
  double seconds = 0;  // Render time of the rendered ones.
};

// Renders the references of the study's [[measured]] sources that are missing or out of date
// into OUT/<study>/references/ and appends one group per material to spec->groups. Call before
// RunStudy. Throws shadefit::Error naming the file on an unreadable BRDF or scene.
MeasuredSummary MaterialiseMeasuredReferences(StudySpec* spec, const std::string& out_dir,
                                              bool quiet);

// Version string recorded in outputs and job hashes ("0.1.0+<git revision>").
std::string ShadefitVersion();

// Writes `text` to `path` through a temporary file in the same directory and a rename.
void WriteFileAtomic(const std::string& path, const std::string& text);

}  // namespace shadefit::studies
