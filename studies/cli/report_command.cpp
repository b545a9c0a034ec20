// `shadefit report OUT/STUDY`: tables, figures, index.html and summary.md from a study's result
// files (docs/studies.md, "Report"). The report is Python (matplotlib) and reads files only; this
// command finds the interpreter and the script and runs it.
//
// Links: CLI11::CLI11, fmt::fmt (shadefit::Error from shadefit::render's headers).
#include "report_command.h"

#include <fmt/core.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "shadefit/base/error.h"

#ifndef SHADEFIT_SOURCE_DIR
#define SHADEFIT_SOURCE_DIR "."
#endif

namespace shadefit::cli {
namespace fs = std::filesystem;

void MakeReport(const std::string& study_dir, bool quiet) {
  if (!fs::is_directory(study_dir)) throw Error(study_dir, "", "study output folder not found");
  if (!fs::exists(fs::path(study_dir) / "results.csv")) {
    throw Error(study_dir, "results.csv", "missing (run `shadefit study run` to completion first)");
  }
  const char* env_python = std::getenv("SHADEFIT_PYTHON");
  const std::string python = env_python != nullptr && *env_python ? env_python : "/usr/bin/python3";
  const char* env_script = std::getenv("SHADEFIT_REPORT_SCRIPT");
  const std::string script = env_script != nullptr && *env_script
                                 ? env_script
                                 : std::string(SHADEFIT_SOURCE_DIR) + "/report/make_report.py";
  if (!fs::exists(script)) throw Error(script, "", "report script not found");
  // Checked here, before the fork: a child that cannot exec would add a second error line.
  if (access(python.c_str(), X_OK) != 0) {
    throw Error(python, env_python != nullptr && *env_python ? "SHADEFIT_PYTHON" : "python",
                "not found or not executable (set SHADEFIT_PYTHON to a Python 3 interpreter)");
  }
  std::vector<std::string> args = {python, script};
  if (quiet) args.push_back("-q");  // No progress line under `study run -q`.
  args.push_back(study_dir);
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::fflush(stdout);
  std::fflush(stderr);
  const pid_t pid = fork();
  if (pid < 0) throw Error("", "report", "fork failed");
  if (pid == 0) {
    execv(python.c_str(), argv.data());
    std::fprintf(stderr, "shadefit: error: %s: cannot execute\n", python.c_str());
    _exit(127);
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) throw Error("", "report", "waitpid failed");
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw Error(script, "",
                fmt::format("report failed (exit status {})",
                            WIFEXITED(status) ? WEXITSTATUS(status) : -1));
  }
}

void RegisterReportCommand(CLI::App& app) {
  auto dir = std::make_shared<std::string>();
  CLI::App* cmd = app.add_subcommand(
      "report",
      "Tables (LaTeX, Markdown, CSV), figures, verdicts, index.html from a study's results");
  cmd->add_option("study_dir", *dir, "A study's output folder, e.g. out/pbs_vs_blinn_phong")
      ->required();
  cmd->callback([dir] { MakeReport(*dir); });
}

}  // namespace shadefit::cli
