// Values made once per key and shared by every thread that asks for them (the study's BRDF-space
// fits and samples, studies/runner/src/brdf_space_fits.h).
#pragma once

#include <cstddef>
#include <deque>
#include <exception>
#include <future>
#include <map>
#include <mutex>
#include <string>

namespace shadefit {

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

}  // namespace shadefit
