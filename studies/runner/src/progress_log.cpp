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

void Log::Progress(double done_weight, double total_weight, int done, int total, int failed,
                   const std::string& current, double elapsed) {
  std::lock_guard lock(mutex_);
  done_weight_ = done_weight;
  total_weight_ = total_weight;
  done_ = done;
  total_ = total;
  failed_ = failed;
  if (!current.empty()) current_ = current;
  elapsed_ = elapsed;
  if (quiet_) return;
  if (bar_) {
    DrawLocked();
    return;
  }
  const int quarter = total > 0 ? 4 * done / total : 0;
  if (quarter > quarter_ && done < total) {
    quarter_ = quarter;
    std::fprintf(stderr, "%d/%d %s (%d%%), %d failed, %s, %s left\n", done, total,
                 unit_.c_str(), 100 * done / total, failed, Rate().c_str(), TimeLeft().c_str());
  }
}

std::string Log::Rate() const {
  if (elapsed_ <= 0 || done_ == 0) return "-- " + unit_ + "/min";
  return fmt::format("{:.1f} {}/min", 60.0 * done_ / elapsed_, unit_);
}

std::string Log::TimeLeft() const {
  const double f = total_weight_ > 0 ? std::clamp(done_weight_ / total_weight_, 0.0, 1.0) : 0;
  if (!(f > 0.02 && f < 1)) return "--:--";
  const int s = static_cast<int>(elapsed_ * (1 - f) / f);
  return fmt::format("{}:{:02d}", s / 60, s % 60);
}

void Log::EndBar() {
  std::lock_guard lock(mutex_);
  if (bar_ && !quiet_) std::fputs("\r\033[K", stderr);
}

void Log::DrawLocked() {
  const int width = 28;
  const double f = total_weight_ > 0 ? std::clamp(done_weight_ / total_weight_, 0.0, 1.0) : 0;
  const int filled = static_cast<int>(std::round(f * width));
  std::string current = current_.size() > 40 ? current_.substr(0, 37) + "..." : current_;
  const std::string failed = failed_ > 0 ? fmt::format(", {} failed", failed_) : "";
  std::fprintf(stderr, "\r\033[K[%s%s] %d/%d%s  %s  %s left  %s", std::string(filled, '#').c_str(),
               std::string(width - filled, '-').c_str(), done_, total_, failed.c_str(),
               Rate().c_str(), TimeLeft().c_str(), current.c_str());
  std::fflush(stderr);
}

}  // namespace shadefit::studies::internal
