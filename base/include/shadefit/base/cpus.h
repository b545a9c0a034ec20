// How many CPUs this process may use, for its thread counts.
#pragma once

#include <sched.h>

#include <algorithm>
#include <cstdlib>
#include <string>
#include <thread>

namespace shadefit {

// The CPUs of this process's affinity mask (taskset, a cgroup's cpuset, a batch system's CPU
// binding), and inside a Slurm job no more than its allocation ($SLURM_CPUS_PER_TASK): a cluster
// that does not bind tasks to CPUs leaves the mask at the whole node, where a thread per CPU
// would share the task's CPUs with other tasks' threads. std::thread::hardware_concurrency()
// counts the machine's CPUs whatever the mask. At least 1.
inline int UsableCpus() {
  int cpus = 0;
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) == 0) cpus = CPU_COUNT(&set);
  if (cpus < 1) cpus = static_cast<int>(std::thread::hardware_concurrency());
  const char* job = std::getenv("SLURM_JOB_ID");
  const char* per_task = std::getenv("SLURM_CPUS_PER_TASK");
  if (job != nullptr && *job != '\0' && per_task != nullptr) {
    char* end = nullptr;
    const long allocated = std::strtol(per_task, &end, 10);
    if (end != per_task && *end == '\0' && allocated > 0) {
      cpus = std::min<long>(cpus, allocated);
    }
  }
  return std::max(1, cpus);
}

}  // namespace shadefit
