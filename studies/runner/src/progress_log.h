// The run's log (study.log, or the shard's log) and its progress output on stderr: one live line
// on a TTY (bar, done / total, failed, rate, time left, the job started last), else a line at
// each quarter of the jobs. Thread-safe: every worker reports through one Log.
#pragma once

#include <fstream>
#include <mutex>
#include <string>
#include <utility>

namespace shadefit::studies::internal {

class Log {
 public:
  // `path` "": no log file (the progress line only). `unit`: what is counted ("jobs").
  Log(const std::string& path, bool bar, bool quiet, std::string unit = "jobs")
      : bar_(bar), quiet_(quiet), unit_(std::move(unit)) {
    if (!path.empty()) out_.open(path, std::ios::app);
  }

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
  std::string Rate() const;      // "31.2 jobs/min" (the unit's)
  std::string TimeLeft() const;  // "12:05", from the weights; "--:--" too early to tell

  std::mutex mutex_;
  std::ofstream out_;
  bool bar_, quiet_;
  std::string unit_;
  double done_weight_ = 0, total_weight_ = 0, elapsed_ = 0;
  int done_ = 0, total_ = 0, failed_ = 0, quarter_ = 0;
  std::string current_;
};

}  // namespace shadefit::studies::internal
