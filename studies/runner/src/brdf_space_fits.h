// The BRDF-space fits of a run (fit/brdf_space.h), made once per material, model and settings and
// shared by every job that needs one: each image fit that starts from it ([fit] start = "brdf":
// one per training set and loss) and the BRDF-space training set itself. The fit is a
// deterministic function of its inputs, so a job's results are the same bytes whether it made
// the fit or found it here; the study just stops making the same fit up to seven times.
#pragma once

#include <cstddef>
#include <deque>
#include <exception>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "shadefit/fit/brdf_space.h"
#include "shadefit/fit/fitter.h"

namespace shadefit::studies::internal {

// Values made once per key by the first thread that asks; the others wait for it. A value whose
// making threw is forgotten (the next asker tries again and reports its own error). With `keep`
// > 0 only the last `keep` keys are held (an evicted value lives on in those holding it).
template <typename T>
class MadeOnce {
 public:
  explicit MadeOnce(std::size_t keep = 0) : keep_(keep) {}

  template <typename Make>
  T Get(const std::string& key, Make make) {
    std::promise<T> made;
    std::shared_future<T> found;
    {
      std::lock_guard lock(mutex_);
      if (const auto it = values_.find(key); it != values_.end()) {
        found = it->second;
      } else {
        values_[key] = made.get_future().share();
        order_.push_back(key);
        if (keep_ > 0 && order_.size() > keep_) {
          values_.erase(order_.front());
          order_.pop_front();
        }
      }
    }
    if (found.valid()) return found.get();
    try {
      T value = make();
      made.set_value(value);
      return value;
    } catch (...) {
      made.set_exception(std::current_exception());
      std::lock_guard lock(mutex_);
      values_.erase(key);
      throw;
    }
  }

 private:
  std::size_t keep_;
  std::mutex mutex_;
  std::map<std::string, std::shared_future<T>> values_;
  std::deque<std::string> order_;
};

class BrdfSpaceFits {
 public:
  // The BRDF-space fit of `model` (held values `fixed`) to the measured BRDF at `brdf_path`,
  // with `options` (l2, fixed exposure, no start points; the caller's). `key` names everything
  // the options depend on besides the material and the model (the study's settings).
  fit::FitResult Get(const std::string& brdf_path, const ModelInfo& model,
                     const std::vector<FixedValue>& fixed, const fit::FitOptions& options,
                     const std::string& key);

 private:
  MadeOnce<fit::FitResult> fits_;
  // The BRDF sampled on MERL's cells (fit::SampleBrdfSpace): read and sampled once per material
  // while its jobs run; the last three materials' are kept.
  MadeOnce<std::shared_ptr<const fit::BrdfSpaceData>> samples_{3};
};

}  // namespace shadefit::studies::internal
