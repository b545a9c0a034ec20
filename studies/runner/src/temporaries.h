// Temporary files left by an interrupted (killed) run: never results, removed when the process
// that wrote them is gone (docs/studies.md, "Jobs, resuming and interruption").
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace shadefit::studies::internal {

// Hidden temporaries are named "<dir>/.<name>.<pid>.<n>.tmp" (TemporaryPathFor, base/files.h:
// every atomic writer's, the probes' plot scratch files included), ".<probe>.<pid>.tmp.<ext>"
// (the probes' plot files before they used the atomic writer; still recognised in folders
// such a version left) or ".<name>.<pid>.tmp" (the report's, report/*.py). True when `leaf` is
// one of them and no process with that pid is running.
bool IsTemporaryOfDeadProcess(const std::string& leaf);

// Removes every such file under `dir` (recursively) and returns them.
std::vector<std::filesystem::path> SweepDeadTemporaries(const std::filesystem::path& dir);

}  // namespace shadefit::studies::internal
