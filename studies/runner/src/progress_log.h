// The run's log (study.log, or the shard's log) and its progress output on stderr: a bar on a
// TTY, else one line per finished job. Thread-safe: every worker reports through one Log.
#pragma once

#include <fstream>
#include <mutex>
#include <string>

namespace shadefit::studies::internal {

class Log {
 public:
  Log(const std::string& path, bool bar, bool quiet)
      : out_(path, std::ios::app), bar_(bar), quiet_(quiet) {}

  // A timestamped line in the log file only.
  void Line(const std::string& text);
  // Also to stderr (cleared bar first) unless quiet.
  void Say(const std::string& text);
  // Redraws the bar (when drawn): done and total weights give the fraction and the ETA.
  void Progress(double done_weight, double total_weight, int done, int total,
                const std::string& current, double elapsed);
  void EndBar();

 private:
  void DrawLocked();

  std::mutex mutex_;
  std::ofstream out_;
  bool bar_, quiet_;
  double done_weight_ = 0, total_weight_ = 0, elapsed_ = 0;
  int done_ = 0, total_ = 0;
  std::string current_;
};

}  // namespace shadefit::studies::internal
