#include "temporaries.h"

#include <signal.h>
#include <sys/types.h>

#include <algorithm>
#include <cerrno>
#include <fstream>

namespace shadefit::studies::internal {
namespace fs = std::filesystem;

namespace {

// The pid in a temporary's name (see IsTemporaryOfDeadProcess), or -1 when `leaf` is not one.
long PidOfTemporary(const std::string& leaf) {
  if (leaf.size() < 6 || leaf[0] != '.') return -1;
  std::vector<std::string> parts;
  std::size_t start = 1;
  while (true) {
    const std::size_t dot = leaf.find('.', start);
    parts.push_back(leaf.substr(start, dot == std::string::npos ? std::string::npos : dot - start));
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  auto numeric = [](const std::string& x) {
    return !x.empty() && x.size() < 10 &&
           std::all_of(x.begin(), x.end(), [](char c) { return c >= '0' && c <= '9'; });
  };
  const std::size_t n = parts.size();
  if (n >= 4 && parts[n - 1] == "tmp" && numeric(parts[n - 2]) && numeric(parts[n - 3])) {
    return std::stol(parts[n - 3]);
  }
  if (n >= 4 && parts[n - 2] == "tmp" && numeric(parts[n - 3])) return std::stol(parts[n - 3]);
  if (n >= 3 && parts[n - 1] == "tmp" && numeric(parts[n - 2])) {
    return std::stol(parts[n - 2]);  // ".<name>.<pid>.tmp": the report's (report/*.py).
  }
  return -1;
}

}  // namespace

bool IsTemporaryOfDeadProcess(const std::string& leaf) {
  const long pid = PidOfTemporary(leaf);
  if (pid <= 0) return false;
  if (::kill(static_cast<pid_t>(pid), 0) != 0) return errno == ESRCH;
  // A killed process stays a zombie until its parent (or init, for an orphan) reaps it: dead,
  // though kill(pid, 0) still finds it. /proc/<pid>/stat's third field is then Z (or X).
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return false;
  const auto paren = line.rfind(')');  // The command name may hold spaces and parentheses.
  return paren != std::string::npos && paren + 2 < line.size() &&
         (line[paren + 2] == 'Z' || line[paren + 2] == 'X');
}

std::vector<fs::path> SweepDeadTemporaries(const fs::path& dir) {
  std::vector<fs::path> stale;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file() && IsTemporaryOfDeadProcess(entry.path().filename().string())) {
      stale.push_back(entry.path());
    }
  }
  std::error_code ec;
  for (const fs::path& p : stale) fs::remove(p, ec);
  return stale;
}

}  // namespace shadefit::studies::internal
