// A study rerun after a killed run (issue 14): the dead run's hidden temporaries, in both naming
// schemes (".<name>.<pid>.<n>.tmp" from TemporaryPathFor and ".<probe>.<pid>.tmp.<ext>" from the
// probes' plot step), are removed; a live process's temporaries are left alone.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "shadefit/studies/runner.h"
#include "shadefit/studies/study.h"

namespace shadefit::studies {
namespace {
namespace fs = std::filesystem;

// The pid of a process that has exited (and been reaped): no process has it now, short of the
// kernel recycling it within the test.
pid_t DeadPid() {
  const pid_t pid = fork();
  if (pid == 0) _exit(0);
  int status = 0;
  waitpid(pid, &status, 0);
  return pid;
}

TEST(InterruptedRun, RerunRemovesDeadRunsTemporariesAndKeepsLiveOnes) {
  const fs::path out = fs::path(SHADEFIT_TEST_OUTPUT) / "interrupted_run";
  fs::remove_all(out);
  const StudySpec spec =
      LoadStudy(std::string(SHADEFIT_SOURCE_DIR) + "/studies/pbs_vs_blinn_phong.toml", true);
  const fs::path study = out / spec.name;
  fs::create_directories(study / "probes" / "gold");
  const std::string dead = std::to_string(DeadPid());
  const std::string live = std::to_string(getpid());
  const fs::path dead_plot = study / "probes" / "gold" / (".energy." + dead + ".tmp.json");
  const fs::path dead_png = study / "probes" / "gold" / (".energy." + dead + ".tmp.png");
  const fs::path dead_csv = study / (".results.csv." + dead + ".3.tmp");
  const fs::path live_csv = study / (".results.csv." + live + ".1.tmp");
  const fs::path not_ours = study / "notes.tmp";  // not hidden: a user's file
  for (const fs::path& p : {dead_plot, dead_png, dead_csv, live_csv, not_ours}) {
    std::ofstream(p) << "partial";
  }
  RunOptions options;
  options.out_dir = out.string();
  options.jobs = 2;
  options.quiet = true;
  const RunSummary s = RunStudy(spec, options);
  EXPECT_EQ(s.failed, 0);
  EXPECT_FALSE(fs::exists(dead_plot));
  EXPECT_FALSE(fs::exists(dead_png));
  EXPECT_FALSE(fs::exists(dead_csv));
  EXPECT_TRUE(fs::exists(live_csv)) << "a live process's temporary was removed";
  EXPECT_TRUE(fs::exists(not_ours));
  // And the run itself leaves no hidden temporary behind.
  for (const auto& e : fs::recursive_directory_iterator(study)) {
    const std::string leaf = e.path().filename().string();
    if (e.path() == live_csv) continue;
    EXPECT_FALSE(leaf[0] == '.' && leaf.find(".tmp") != std::string::npos) << e.path();
  }
}

}  // namespace
}  // namespace shadefit::studies
