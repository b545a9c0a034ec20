#include "progress_log.h"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>

namespace shadefit::studies::internal {
namespace {

std::string Timestamp() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  localtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S", &tm);
  return buf;
}

}  // namespace

void Log::Line(const std::string& text) {
  std::lock_guard lock(mutex_);
  out_ << Timestamp() << "  " << text << "\n";
  out_.flush();
}

void Log::Say(const std::string& text) {
  Line(text);
  if (quiet_) return;
  std::lock_guard lock(mutex_);
  if (bar_) std::fputs("\r\033[K", stderr);
  std::fprintf(stderr, "%s\n", text.c_str());
  if (bar_) DrawLocked();
}

void Log::Progress(double done_weight, double total_weight, int done, int total,
                   const std::string& current, double elapsed) {
  std::lock_guard lock(mutex_);
  done_weight_ = done_weight;
  total_weight_ = total_weight;
  done_ = done;
  total_ = total;
  current_ = current;
  elapsed_ = elapsed;
  if (bar_ && !quiet_) DrawLocked();
}

void Log::EndBar() {
  std::lock_guard lock(mutex_);
  if (bar_ && !quiet_) std::fputs("\r\033[K", stderr);
}

void Log::DrawLocked() {
  const int width = 28;
  const double f = total_weight_ > 0 ? std::clamp(done_weight_ / total_weight_, 0.0, 1.0) : 0;
  const int filled = static_cast<int>(std::round(f * width));
  std::string eta = "--:--";
  if (f > 0.02 && f < 1) {
    const int s = static_cast<int>(elapsed_ * (1 - f) / f);
    eta = fmt::format("{}:{:02d}", s / 60, s % 60);
  }
  std::string current = current_.size() > 48 ? current_.substr(0, 45) + "..." : current_;
  std::fprintf(stderr, "\r\033[K[%s%s] %d/%d  ETA %s  %s", std::string(filled, '#').c_str(),
               std::string(width - filled, '-').c_str(), done_, total_, eta.c_str(),
               current.c_str());
  std::fflush(stderr);
}

}  // namespace shadefit::studies::internal
