// base/: the one atomic writer (files.h: a complete file or nothing, never a temporary left),
// the percentile (statistics.h) and the CPUs a process may use (cpus.h).
#include "shadefit/base/files.h"

#include <sched.h>
#include <stdlib.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <algorithm>
#include <cmath>
#include <iterator>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "shadefit/base/cpus.h"
#include "shadefit/base/error.h"
#include "shadefit/base/statistics.h"

namespace shadefit {
namespace {
namespace fs = std::filesystem;

fs::path CleanDir(const std::string& name) {
  const fs::path dir = fs::path(SHADEFIT_TEST_OUTPUT) / "files_test" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string Read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

int Entries(const fs::path& dir) {
  return static_cast<int>(std::distance(fs::directory_iterator(dir), fs::directory_iterator()));
}

TEST(WriteAtomicTest, FillWritesTheTemporaryThenItIsRenamed) {
  const fs::path dir = CleanDir("fill");
  const std::string path = (dir / "out.bin").string();
  std::string seen;
  WriteAtomic(path, [&](const std::string& tmp) {
    seen = tmp;
    EXPECT_EQ(fs::path(tmp).parent_path(), dir);
    EXPECT_EQ(fs::path(tmp).filename().string().rfind(".out.bin.", 0), 0u) << tmp;
    std::ofstream(tmp, std::ios::binary) << std::string("a\0b", 3);
  });
  EXPECT_FALSE(fs::exists(seen));
  EXPECT_EQ(Read(path), std::string("a\0b", 3));
  EXPECT_EQ(Entries(dir), 1);
}

TEST(WriteAtomicTest, AFailingFillLeavesNothingAndKeepsTheOldFile) {
  const fs::path dir = CleanDir("fail");
  const std::string path = (dir / "out.txt").string();
  WriteTextAtomic(path, "old\n");
  EXPECT_THROW(WriteAtomic(path,
                           [](const std::string& tmp) {
                             std::ofstream(tmp) << "half";
                             throw std::runtime_error("fill failed");
                           }),
               std::runtime_error);
  EXPECT_EQ(Read(path), "old\n");
  EXPECT_EQ(Entries(dir), 1);  // No temporary left.
}

TEST(WriteAtomicTest, BadPathFailsBeforeFilling) {
  bool filled = false;
  EXPECT_THROW(WriteAtomic("/nonexistent-dir/x.txt", [&](const std::string&) { filled = true; }),
               Error);
  EXPECT_FALSE(filled);
}

// base/statistics.h: the one percentile rule, the element of 0-based rank floor(q n) of the
// sorted values. Its index against integer arithmetic (n * 995 / 1000, the exact floor) for every
// n up to 20000 and the fractions the code uses, and its values on a shuffled 1..10.
TEST(Percentile, OrderStatisticOfRankFloorQN) {
  const std::pair<double, std::size_t> fractions[] = {{0.5, 2}, {0.9, 10}, {0.99, 100},
                                                      {0.995, 1000}};
  for (const auto& [q, den] : fractions) {
    const std::size_t num = static_cast<std::size_t>(std::lround(q * den));
    for (std::size_t n = 1; n <= 20000; ++n) {
      ASSERT_EQ(PercentileIndex(n, q), std::min(n - 1, n * num / den)) << q << " " << n;
    }
  }
  std::vector<double> v = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10};
  std::shuffle(v.begin(), v.end(), std::mt19937(7));
  EXPECT_EQ(Percentile(v, 0.5), 6.0);  // The upper median of an even count.
  EXPECT_EQ(Percentile(v, 0.0), 1.0);
  EXPECT_EQ(Percentile(v, 0.25), 3.0);
  EXPECT_EQ(Percentile(v, 0.9), 10.0);
  EXPECT_EQ(Percentile(v, 1.0), 10.0);
  std::vector<int> odd = {5, 1, 3};
  EXPECT_EQ(Percentile(odd, 0.5), 3);
  std::vector<float> none;
  EXPECT_TRUE(std::isnan(Percentile(none, 0.5)));
}

// UsableCpus: the affinity mask's CPUs, and inside a Slurm job no more than its allocation. The
// mask is set on this thread (sched_setaffinity(0) is the calling thread's) and restored.
TEST(UsableCpusTest, AffinityMaskAndSlurmAllocation) {
  cpu_set_t all;
  ASSERT_EQ(sched_getaffinity(0, sizeof(all), &all), 0);
  std::vector<int> allowed;
  for (int c = 0; c < CPU_SETSIZE; ++c) {
    if (CPU_ISSET(c, &all)) allowed.push_back(c);
  }
  ASSERT_FALSE(allowed.empty());
  const auto pin = [](std::vector<int> cpus) {
    cpu_set_t set;
    CPU_ZERO(&set);
    for (int c : cpus) CPU_SET(c, &set);
    return sched_setaffinity(0, sizeof(set), &set) == 0;
  };
  const auto with_slurm = [](const char* job, const char* per_task) {
    const auto set = [](const char* name, const char* value) {
      if (value != nullptr) {
        setenv(name, value, 1);
      } else {
        unsetenv(name);
      }
    };
    set("SLURM_JOB_ID", job);
    set("SLURM_CPUS_PER_TASK", per_task);
    return UsableCpus();
  };
  const char* job_before = std::getenv("SLURM_JOB_ID");
  const char* per_task_before = std::getenv("SLURM_CPUS_PER_TASK");
  const std::string job_saved = job_before ? job_before : "";
  const std::string per_task_saved = per_task_before ? per_task_before : "";

  ASSERT_TRUE(pin({allowed.front()}));
  EXPECT_EQ(with_slurm(nullptr, nullptr), 1);
  EXPECT_EQ(with_slurm("7", "4"), 1);  // The mask's one CPU.
  if (allowed.size() >= 2) {
    ASSERT_TRUE(pin({allowed[0], allowed[1]}));
    EXPECT_EQ(with_slurm(nullptr, nullptr), 2);
    EXPECT_EQ(with_slurm(nullptr, "1"), 2);  // Not in a Slurm job: the variable is not ours.
    EXPECT_EQ(with_slurm("7", "1"), 1);
    EXPECT_EQ(with_slurm("7", "2"), 2);
    EXPECT_EQ(with_slurm("7", "16"), 2);
    for (const char* bad : {"", "0", "-1", "two", "1x"}) {
      EXPECT_EQ(with_slurm("7", bad), 2) << "SLURM_CPUS_PER_TASK=" << bad;
    }
  }
  ASSERT_EQ(sched_setaffinity(0, sizeof(all), &all), 0);
  EXPECT_EQ(with_slurm(nullptr, nullptr), static_cast<int>(allowed.size()));
  with_slurm(job_before ? job_saved.c_str() : nullptr,
             per_task_before ? per_task_saved.c_str() : nullptr);
}

}  // namespace
}  // namespace shadefit
