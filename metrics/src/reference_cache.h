// The inside of ReferenceCache (shadefit/metrics/reference_cache.h), shared by the metrics that
// keep their reference's half in it (not installed).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <mutex>

#include "shadefit/metrics/reference_cache.h"
#include "shadefit/render/image.h"

namespace shadefit::metrics {

// 64-bit hash of an image's size, channel count and pixel bits.
std::uint64_t HashPixels(const Image& image);

struct ReferenceCache::Impl {
  // Which half an entry holds: each kind's values have their own type (below).
  enum class Kind { kFlip, kLab, kIctcp, kDisplay };
  struct Key {
    Kind kind;
    std::uint64_t pixels;  // HashPixels of the reference as the metric reads it.
    std::uint64_t where;   // Hash of the pixels the values are wanted at.
    std::array<double, 3> parameters;  // The metric's, in a fixed order per kind.
    auto operator<=>(const Key&) const = default;
  };

  // The entry's values, or nullptr (counted as a miss). T: the kind's type.
  template <typename T>
  std::shared_ptr<const T> Find(const Key& key) {
    return std::static_pointer_cast<const T>(FindAny(key));
  }
  // Keeps `values` (`bytes` long) under `key`, then drops the least recently used entries past
  // the budget (never the newest).
  template <typename T>
  void Insert(const Key& key, std::shared_ptr<const T> values, std::size_t bytes) {
    InsertAny(key, std::move(values), bytes);
  }

  std::size_t budget = 0;
  mutable std::mutex mutex;
  ReferenceCache::Stats stats;

 private:
  struct Entry {
    std::shared_ptr<const void> values;
    std::size_t bytes;
    std::list<Key>::iterator lru;  // Position in `order`, most recent first.
  };
  std::shared_ptr<const void> FindAny(const Key& key);
  void InsertAny(const Key& key, std::shared_ptr<const void> values, std::size_t bytes);

  std::map<Key, Entry> entries_;
  std::list<Key> order_;
};

// The values under `key` in `cache`, else make() (kept there when there is a cache, with
// bytes(values) as their size).
template <typename T, typename Make, typename Bytes>
std::shared_ptr<const T> FindOrMake(ReferenceCache* cache, const ReferenceCache::Impl::Key& key,
                                    Make make, Bytes bytes) {
  std::shared_ptr<const T> values = cache ? cache->impl().Find<T>(key) : nullptr;
  if (!values) {
    values = std::make_shared<const T>(make());
    if (cache) cache->impl().Insert(key, values, bytes(*values));
  }
  return values;
}

}  // namespace shadefit::metrics
