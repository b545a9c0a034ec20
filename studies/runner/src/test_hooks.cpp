#include "test_hooks.h"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <fstream>
#include <mutex>

#include "shadefit/base/files.h"

namespace shadefit::studies::internal {
namespace {

bool KillPointArmed(const char* site) {
  static const std::string spec = [] {
    const char* v = std::getenv("SHADEFIT_KILL_AT");
    return std::string(v != nullptr ? v : "");
  }();
  if (spec.empty()) return false;
  const auto colon = spec.find(':');
  if (spec.substr(0, colon) != site) return false;
  static std::atomic<int> reached{0};
  const int n = colon == std::string::npos ? 1 : std::atoi(spec.c_str() + colon + 1);
  return ++reached == n;
}

}  // namespace

void KillPoint(const char* site) {
  if (KillPointArmed(site)) ::kill(::getpid(), SIGKILL);
}

bool FaultArmed(const char* mode) {
  static std::mutex mutex;
  static std::string last;
  static int reached = 0;
  const char* v = std::getenv("SHADEFIT_TEST_FAULT");
  const std::string spec = v != nullptr ? v : "";
  std::lock_guard lock(mutex);
  if (spec != last) {  // A new fault (tests set one per run): count from zero.
    last = spec;
    reached = 0;
  }
  const auto colon = spec.find(':');
  if (spec.empty() || spec.substr(0, colon) != mode) return false;
  const std::string n = colon == std::string::npos ? "1" : spec.substr(colon + 1);
  ++reached;
  return n == "*" || reached == std::atoi(n.c_str());  // "*": every time.
}

void WriteJobJson(const std::string& path, const std::string& text) {
  if (!KillPointArmed("result")) return WriteTextAtomic(path, text);
  WriteAtomic(path, [&](const std::string& temporary) {
    std::ofstream(temporary, std::ios::binary) << text.substr(0, text.size() / 2);
    ::kill(::getpid(), SIGKILL);
  });
}

}  // namespace shadefit::studies::internal
