// The run's log (study.log, or the shard's log) and its progress output on stderr: one live line
// on a TTY (bar, done / total, failed, rate, time left, the job started last), else a line at
// each quarter of the jobs. Thread-safe: every worker reports through one Log.
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
  // Redraws the live line (on a TTY), or prints a line when `done` enters a new quarter of
  // `total` (elsewhere): done and total weights give the fraction and the time left.
  void Progress(double done_weight, double total_weight, int done, int total, int failed,
                const std::string& current, double elapsed);
  void EndBar();

 private:
  void DrawLocked();
  std::string Rate() const;      // "31.2 jobs/min"
  std::string TimeLeft() const;  // "12:05", from the weights; "--:--" too early to tell

  std::mutex mutex_;
  std::ofstream out_;
  bool bar_, quiet_;
  double done_weight_ = 0, total_weight_ = 0, elapsed_ = 0;
  int done_ = 0, total_ = 0, failed_ = 0, quarter_ = 0;
  std::string current_;
};

}  // namespace shadefit::studies::internal
