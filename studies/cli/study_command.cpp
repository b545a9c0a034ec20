// `shadefit study run S.toml [-j N] [-o OUT] [--quick] [--force] [--no-report] [--shard i/N]`:
// runs a study (docs/studies.md), or one shard of it, and, when every job succeeded, makes its
// report. `shadefit study merge OUT/STUDY` merges the shards' outputs; `shadefit study slurm`
// writes the sbatch scripts that run the shards and the merge on a cluster (docs/cluster.md).
//
// Links: shadefit::studies, CLI11::CLI11, fmt::fmt.
#include <fmt/core.h>
#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <set>
#include <string>

#include "commands.h"
#include "report_command.h"
#include "shadefit/base/error.h"
#include "shadefit/base/files.h"
#include "shadefit/studies/parameter_charts.h"
#include "shadefit/studies/runner.h"
#include "shadefit/studies/study.h"

namespace shadefit::cli {
namespace {

std::atomic<bool> g_interrupt{false};

// First Ctrl-C: stop scheduling and let running jobs finish. Second: die at once (every output is
// written to a temporary file and renamed, so nothing partial is left).
extern "C" void OnSigint(int) {
  if (g_interrupt.exchange(true)) {
    signal(SIGINT, SIG_DFL);
    raise(SIGINT);
    return;
  }
  static const char kMsg[] =
      "\nshadefit: interrupted: finishing running jobs (Ctrl-C again to abandon them)\n";
  [[maybe_unused]] ssize_t n = write(STDERR_FILENO, kMsg, sizeof kMsg - 1);
}

struct StudyRunOptions {
  std::string study;
  std::string out = "out";
  int jobs = 0;
  bool quick = false;
  bool force = false;
  bool no_report = false;
  bool quiet = false;
  bool verbose = false;
  std::string shard;  // "i/N"; empty: the whole study.
};

// Sphere grids over each model's parameters, then the report (both read the finished results).
void FinishStudy(const studies::StudySpec& spec, const std::string& study_dir, bool report,
                 bool quiet) {
  studies::WriteParameterCharts(spec, study_dir);  // Sphere grids the report lays out.
  if (spec.report && report) MakeReport(study_dir, quiet);
}

void RunStudyCommand(const StudyRunOptions& o) {
  studies::StudySpec spec = studies::LoadStudy(o.study, o.quick);
  const studies::Shard shard =
      o.shard.empty() ? studies::Shard{} : studies::ParseShard(o.shard, "--shard");
  if (const std::string skip = studies::MeasuredSkipReason(spec); !skip.empty()) {
    std::fprintf(stderr, "shadefit: study %s: %s\n", spec.name.c_str(), skip.c_str());
  }
  std::set<std::string> shard_materials;
  studies::MeasuredOptions mo;
  mo.quiet = o.quiet;
  mo.verbose = o.verbose;
  mo.progress_bar = isatty(STDERR_FILENO) != 0;
  if (!shard.whole()) {
    shard_materials = studies::RestrictToShard(&spec, shard);
    mo.materials = &shard_materials;
  }
  const studies::MeasuredSummary measured =
      studies::MaterialiseMeasuredReferences(&spec, o.out, mo);
  if (measured.rendered + measured.unchanged > 0 && !o.quiet) {
    std::fprintf(stderr, "study %s: %d measured reference(s) rendered (%.1f s), %d unchanged\n",
                 spec.name.c_str(), measured.rendered, measured.seconds, measured.unchanged);
  }
  if (spec.groups.empty() && shard.whole()) {
    std::fprintf(stderr, "shadefit: study %s: no material to study; nothing run\n",
                 spec.name.c_str());
    return;
  }
  studies::RunOptions ro;
  ro.shard = shard;
  ro.jobs = o.jobs;
  ro.out_dir = o.out;
  ro.force = o.force;
  ro.interrupt = &g_interrupt;
  ro.progress_bar = isatty(STDERR_FILENO) != 0;
  ro.quiet = o.quiet;
  ro.verbose = o.verbose;
  struct sigaction sa {};
  sa.sa_handler = OnSigint;
  sigemptyset(&sa.sa_mask);
  struct sigaction old {};
  sigaction(SIGINT, &sa, &old);
  studies::RunSummary s;
  try {
    s = studies::RunStudy(spec, ro);
  } catch (...) {
    sigaction(SIGINT, &old, nullptr);
    throw;
  }
  sigaction(SIGINT, &old, nullptr);
  if (s.interrupted) {
    std::fprintf(stderr, "shadefit: study interrupted: %d of %d jobs done; rerun to resume\n",
                 s.ran + s.skipped, s.total);
    std::exit(130);
  }
  if (s.failed > 0) {
    throw Error(s.study_dir + "/study.log", "study",
                fmt::format("{} job(s) failed ({}...), {} not run", s.failed, s.failed_ids.front(),
                            s.not_run));
  }
  if (!s.fits_without_parameters.empty()) {  // A result, not progress: said even with -q.
    std::fprintf(stderr,
                 "shadefit: study %s: %zu fit(s) left no parameters (first: %s); see "
                 "the status column of results.csv\n",
                 spec.name.c_str(), s.fits_without_parameters.size(),
                 s.fits_without_parameters.front().c_str());
  }
  if (shard.whole()) FinishStudy(spec, s.study_dir, !o.no_report, o.quiet);
  fmt::print("{}\n", s.study_dir);
}

struct StudyMergeOptions {
  std::string study_dir;
  std::string study;  // Overrides the study path the shards recorded (a moved checkout).
  bool no_report = false;
  bool quiet = false;
};

// Every shard has finished: check that the whole job graph is done, then write the study-wide
// outputs exactly as a single-machine run would, and the report.
void MergeStudyCommand(const StudyMergeOptions& o) {
  const studies::ShardedRun sharded = studies::ReadShardManifests(o.study_dir);
  const std::string path = o.study.empty() ? sharded.study_path : o.study;
  studies::StudySpec spec = studies::LoadStudy(path, sharded.quick);
  if (Sha256String(spec.text) != sharded.study_sha256) {
    throw Error(path, "",
                "differs from the study file the shards ran (its SHA-256 changed); "
                "rerun the shards, or pass the original with --study");
  }
  const std::filesystem::path dir = std::filesystem::absolute(o.study_dir).lexically_normal();
  if (dir.filename() != spec.name) {
    throw Error(o.study_dir, "", "is not the output folder of study '" + spec.name + "'");
  }
  studies::MeasuredOptions mo;
  mo.quiet = o.quiet;
  mo.render = false;
  studies::MaterialiseMeasuredReferences(&spec, dir.parent_path().string(), mo);
  studies::RunOptions ro;
  ro.out_dir = dir.parent_path().string();
  ro.merge_only = true;
  ro.shard_manifests = sharded.manifests;
  ro.quiet = o.quiet;
  const studies::RunSummary s = studies::RunStudy(spec, ro);
  FinishStudy(spec, s.study_dir, !o.no_report, o.quiet);
  fmt::print("{}\n", s.study_dir);
}

struct StudySlurmOptions {
  std::string study;
  studies::SlurmOptions slurm;
};

void SlurmStudyCommand(const StudySlurmOptions& o) {
  const studies::StudySpec spec = studies::LoadStudy(o.study, o.slurm.quick);
  studies::SlurmOptions so = o.slurm;
  std::error_code ec;
  so.executable = std::filesystem::read_symlink("/proc/self/exe", ec).string();
  const studies::SlurmScripts s = studies::WriteSlurmScripts(spec, so);
  std::fprintf(stderr, "wrote %s\n      %s\nsubmit both (on the login node):\n",
               s.shards_script.c_str(), s.merge_script.c_str());
  fmt::print("{}\n", s.submit_command);
}

}  // namespace

void RegisterStudyCommand(CLI::App& app) {
  CLI::App* study = app.add_subcommand("study", "Run a study: fits, metrics, probes, report");
  study->require_subcommand(1);
  auto o = std::make_shared<StudyRunOptions>();
  CLI::App* run = study->add_subcommand("run", "Run (or resume) a study file");
  run->add_option("study", o->study, "Study file (TOML, docs/studies.md)")->required();
  run->add_option("-j,--jobs", o->jobs, "Worker threads, each with its own GL context (0 = CPUs)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  run->add_option("-o,--out", o->out, "Output folder; results go to <out>/<study name>/")
      ->capture_default_str();
  run->add_flag("--quick", o->quick, "Apply the study's [quick] table (CI-sized run)");
  run->add_flag("--force", o->force, "Rerun every job, even unchanged ones");
  run->add_flag("--no-report", o->no_report, "Do not make the report at the end");
  run->add_flag("-q,--quiet", o->quiet, "No progress output (study.log is still written)");
  run->add_flag("-v,--verbose", o->verbose,
                "A line per finished job and per rendered measured reference");
  run->add_option("--shard", o->shard,
                  "Run share i of N (i/N, 1-based) of the job graph; `study merge` joins them");
  run->callback([o] { RunStudyCommand(*o); });

  auto m = std::make_shared<StudyMergeOptions>();
  CLI::App* merge = study->add_subcommand(
      "merge", "Merge the outputs of a sharded run (every shard done) into the study's tables");
  merge->add_option("study_dir", m->study_dir, "The study's output folder, OUT/<study name>")
      ->required();
  merge->add_option("--study", m->study, "Study file, if it moved since the shards ran");
  merge->add_flag("--no-report", m->no_report, "Do not make the report");
  merge->add_flag("-q,--quiet", m->quiet, "No progress output");
  merge->callback([m] { MergeStudyCommand(*m); });

  auto sl = std::make_shared<StudySlurmOptions>();
  CLI::App* slurm = study->add_subcommand(
      "slurm", "Write sbatch scripts: a job array of shards and a dependent merge job");
  slurm->add_option("study", sl->study, "Study file (TOML)")->required();
  slurm->add_option("--array", sl->slurm.array, "Shards, one per array task")
      ->capture_default_str();
  slurm->add_option("--partition", sl->slurm.partition, "Slurm partition (default: the cluster's)");
  slurm->add_option("--time", sl->slurm.time, "Time limit per task (sbatch --time)")
      ->capture_default_str();
  slurm->add_option("--cpus", sl->slurm.cpus, "CPUs per task (= the shard's workers)")
      ->capture_default_str();
  slurm->add_option("--merge-cpus", sl->slurm.merge_cpus,
                    "CPUs of the merge job, whose report draws on them (default: --cpus)");
  slurm->add_option("--gpus", sl->slurm.gpus, "GPUs per task (EGL then uses the NVIDIA device)")
      ->capture_default_str();
  slurm->add_option("-o,--out", sl->slurm.out_dir, "Output folder, shared by every node")
      ->capture_default_str();
  slurm->add_flag("--quick", sl->slurm.quick, "Apply the study's [quick] table");
  slurm->callback([sl] { SlurmStudyCommand(*sl); });
}

}  // namespace shadefit::cli
