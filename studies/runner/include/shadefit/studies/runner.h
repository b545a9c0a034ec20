// The study runner: builds the job graph of a study (one fit per material x model x training
// set, then the probes of each material), runs it on worker threads that each own a GL context,
// and writes every result atomically so an interrupted run resumes where it stopped
// (docs/studies.md, "Outputs").
#pragma once

#include <atomic>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "shadefit/studies/study.h"

namespace shadefit::studies {

// One share of a study's job graph (`study run --shard i/N`, docs/cluster.md). A material and all
// of its jobs (its measured references, its fits, then its probes) belong to one shard, so no
// job of a shard waits on another shard.
struct Shard {
  int index = 1;         // 1..count.
  int count = 1;
  bool sharded = false;  // false: the whole study (no --shard; 1/1 is a shard like any other).
  bool whole() const { return !sharded; }
  std::string Name() const;  // "2-of-4".
};

// Parses "i/N" (1 <= i <= N <= 10000); throws shadefit::Error naming `field` otherwise.
Shard ParseShard(const std::string& text, const std::string& field = "--shard");

// Which shard each material of the study belongs to (1-based), for `count` shards: longest job
// first onto the least-loaded shard, by the same cost estimate the progress bar uses; ties go to
// the lower shard and the earlier material name. A pure function of the study file and the
// measured folders' file lists, so every shard, and the merge, computes the same assignment.
std::map<std::string, int> AssignShards(const StudySpec& spec, int count);

// Keeps in `spec` only the Cycles groups of `shard`; returns every material of the shard
// (measured ones included, for MaterialiseMeasuredReferences).
std::set<std::string> RestrictToShard(StudySpec* spec, const Shard& shard);

struct RunOptions {
  int jobs = 0;               // Worker threads (each with its own GL context); 0 = CPU count.
  std::string out_dir = "out";
  bool force = false;         // Rerun every job even when its hash is unchanged.
  // Set (from a signal handler) to stop scheduling; running jobs finish, nothing partial is left.
  const std::atomic<bool>* interrupt = nullptr;
  // Progress: true draws one live line on stderr (a TTY: done / total, failed, rate, time left,
  // the job), false prints a line at each quarter of the jobs (a pipe or a log); failures are
  // printed in full either way.
  bool progress_bar = false;
  bool verbose = false;       // Also a line per finished job (`-v`).
  bool quiet = false;         // No progress output at all (the log is still written).
  // A shard runs its jobs and writes shards/<i>-of-<N>.json instead of the study-wide outputs
  // (results.csv, timings.csv, provenance.json), which `merge` writes once every shard is done.
  Shard shard;
  // No job is run: every job must already be done (by the shards); writes the study-wide
  // outputs. Needs no GL context. Throws shadefit::Error naming the first unfinished job.
  bool merge_only = false;
  std::vector<nlohmann::json> shard_manifests;  // merge_only: recorded in provenance.json.
};

struct RunSummary {
  std::string study_dir;      // <out>/<study name>
  int total = 0, ran = 0, skipped = 0, failed = 0, not_run = 0;
  bool interrupted = false;
  double seconds = 0;
  std::vector<std::string> ran_ids, skipped_ids, failed_ids;
  // Fits recorded without parameters ("<job id>: <status>"): a degenerate reference, NaN
  // residuals, a lost GL context. They are results, not failures: the study goes on.
  std::vector<std::string> fits_without_parameters;
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
struct MeasuredOptions {
  bool quiet = false;
  bool verbose = false;  // A line per rendered reference (else only the summary line).
  // Progress of the references to render, as the jobs' (RunOptions::progress_bar): true, one
  // live line on stderr; false, a line at each quarter.
  bool progress_bar = false;
  // When set, only these materials are rendered and added as groups (a shard's).
  const std::set<std::string>* materials = nullptr;
  // false (merge): a missing or out-of-date reference is an error, not a render.
  bool render = true;
};
MeasuredSummary MaterialiseMeasuredReferences(StudySpec* spec, const std::string& out_dir,
                                              const MeasuredOptions& options);
inline MeasuredSummary MaterialiseMeasuredReferences(StudySpec* spec, const std::string& out_dir,
                                                     bool quiet) {
  MeasuredOptions o;
  o.quiet = quiet;
  return MaterialiseMeasuredReferences(spec, out_dir, o);
}

// What `shadefit study merge` needs to reload the study the shards ran, from their manifests
// (OUT/<study>/shards/<i>-of-<N>.json). Throws shadefit::Error when a shard of the newest
// sharding is missing or the manifests disagree.
struct ShardedRun {
  std::string study_path;   // As the shards loaded it.
  std::string study_sha256;
  bool quick = false;
  int count = 0;
  std::vector<nlohmann::json> manifests;  // Sorted by shard index.
};
ShardedRun ReadShardManifests(const std::string& study_dir);

// `shadefit study slurm`: an sbatch script for a job array (one shard per task) and one for the
// merge, which runs after every task succeeded (--dependency=afterok). Paths are absolute.
struct SlurmOptions {
  int array = 2;                  // Shards = array tasks.
  std::string partition;          // Empty: the cluster's default.
  std::string time = "02:00:00";  // Per task, sbatch --time.
  int cpus = 2;                   // Per task: --cpus-per-task, and the shard's worker count.
  int merge_cpus = 0;             // The merge's --cpus-per-task (its report draws on them); 0: cpus.
  int gpus = 0;                   // Per task: --gpus-per-task (EGL then picks the NVIDIA device).
  std::string out_dir = "out";
  bool quick = false;
  std::string executable;         // Absolute path of the shadefit binary.
};
struct SlurmScripts {
  std::string shards_script, merge_script;  // Written files.
  std::string submit_command;               // The one command that submits both.
};
SlurmScripts WriteSlurmScripts(const StudySpec& spec, const SlurmOptions& options);

// Version string recorded in outputs and job hashes ("0.1.0+<git revision>").
std::string ShadefitVersion();

}  // namespace shadefit::studies
