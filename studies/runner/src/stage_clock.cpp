#include "stage_clock.h"

#include <algorithm>

#include "shadefit/base/error.h"

namespace shadefit::studies::internal {
namespace {

std::size_t IndexOf(const std::string& stage) {
  const auto it = std::find(kStageNames.begin(), kStageNames.end(), stage);
  if (it == kStageNames.end()) throw Error("", "stage", "unknown stage '" + stage + "'");
  return static_cast<std::size_t>(it - kStageNames.begin());
}

}  // namespace

void StageClock::Lap(const std::string& stage) {
  const Clock::time_point now = Clock::now();
  seconds_[IndexOf(stage)] += std::chrono::duration<double>(now - last_).count();
  last_ = now;
}

void StageClock::Move(const std::string& from, const std::string& to, double seconds) {
  seconds_[IndexOf(from)] -= seconds;
  seconds_[IndexOf(to)] += seconds;
}

double StageClock::Seconds(const std::string& stage) const { return seconds_[IndexOf(stage)]; }

}  // namespace shadefit::studies::internal
