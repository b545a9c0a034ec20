// `shadefit study run S.toml [-j N] [-o OUT] [--quick] [--force] [--no-report]`: runs a study
// (docs/studies.md) and, when every job succeeded, makes its report.
//
// Links: shadefit::studies, CLI11::CLI11, fmt::fmt.
#include <fmt/core.h>
#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cstdlib>
#include <memory>
#include <string>

#include "commands.h"
#include "report_command.h"
#include "shadefit/render/error.h"
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
};

void RunStudyCommand(const StudyRunOptions& o) {
  studies::StudySpec spec = studies::LoadStudy(o.study, o.quick);
  if (const std::string skip = studies::MeasuredSkipReason(spec); !skip.empty()) {
    std::fprintf(stderr, "shadefit: study %s: %s\n", spec.name.c_str(), skip.c_str());
  }
  const studies::MeasuredSummary measured =
      studies::MaterialiseMeasuredReferences(&spec, o.out, o.quiet);
  if (measured.rendered + measured.unchanged > 0 && !o.quiet) {
    std::fprintf(stderr, "study %s: %d measured reference(s) rendered (%.1f s), %d unchanged\n",
                 spec.name.c_str(), measured.rendered, measured.seconds, measured.unchanged);
  }
  if (spec.groups.empty()) {
    std::fprintf(stderr, "shadefit: study %s: no material to study; nothing run\n",
                 spec.name.c_str());
    return;
  }
  studies::RunOptions ro;
  ro.jobs = o.jobs;
  ro.out_dir = o.out;
  ro.force = o.force;
  ro.interrupt = &g_interrupt;
  ro.progress_bar = isatty(STDERR_FILENO) != 0;
  ro.quiet = o.quiet;
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
  if (spec.report && !o.no_report) MakeReport(s.study_dir);
  fmt::print("{}\n", s.study_dir);
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
  run->callback([o] { RunStudyCommand(*o); });
}

}  // namespace shadefit::cli
