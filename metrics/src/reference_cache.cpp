// ReferenceCache (shadefit/metrics/reference_cache.h): its least-recently-used store and the
// pixel hash of its keys.
#include "reference_cache.h"

#include <bit>

namespace shadefit::metrics {

// splitmix64's finaliser over 64-bit words (two floats), in four independent lanes so that the
// mixes of neighbouring words overlap instead of waiting on each other (it runs on every call
// with a cache, over the whole image), lanes mixed at the end.
std::uint64_t HashPixels(const Image& image) {
  const auto mix = [](std::uint64_t z) {
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  };
  constexpr std::uint64_t kStep = 0x9E3779B97F4A7C15ull;
  std::uint64_t lane[4];
  lane[0] = mix((static_cast<std::uint64_t>(image.width) << 32) ^
                (static_cast<std::uint64_t>(image.height) << 8) ^
                static_cast<std::uint64_t>(image.channels));
  for (int l = 1; l < 4; ++l) lane[l] = mix(lane[l - 1] + kStep);
  const std::size_t n = image.data.size();
  const auto word = [&](std::size_t i) {  // Floats i and i + 1 (0 past the end).
    const std::uint64_t lo = std::bit_cast<std::uint32_t>(image.data[i]);
    const std::uint64_t hi = i + 1 < n ? std::bit_cast<std::uint32_t>(image.data[i + 1]) : 0u;
    return lo | hi << 32;
  };
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    for (int l = 0; l < 4; ++l) lane[l] = mix(lane[l] ^ word(i + 2 * l)) + kStep;
  }
  for (int l = 0; i < n; i += 2, ++l) lane[l] = mix(lane[l] ^ word(i)) + kStep;
  return mix(lane[0] ^ mix(lane[1] ^ mix(lane[2] ^ mix(lane[3] ^ n))));
}

ReferenceCache::ReferenceCache(std::size_t byte_budget) : impl_(std::make_unique<Impl>()) {
  impl_->budget = byte_budget;
}

ReferenceCache::~ReferenceCache() = default;

ReferenceCache::Stats ReferenceCache::stats() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->stats;
}

std::shared_ptr<const void> ReferenceCache::Impl::FindAny(const Key& key) {
  std::lock_guard lock(mutex);
  const auto it = entries_.find(key);
  if (it == entries_.end()) {
    ++stats.misses;
    return nullptr;
  }
  ++stats.hits;
  order_.splice(order_.begin(), order_, it->second.lru);
  return it->second.values;
}

void ReferenceCache::Impl::InsertAny(const Key& key, std::shared_ptr<const void> values,
                                     std::size_t bytes) {
  std::lock_guard lock(mutex);
  if (entries_.contains(key)) return;  // Another thread computed it too: the same values.
  stats.bytes += bytes;
  order_.push_front(key);
  entries_.emplace(key, Entry{std::move(values), bytes, order_.begin()});
  while (stats.bytes > budget && order_.size() > 1) {
    const auto last = entries_.find(order_.back());
    stats.bytes -= last->second.bytes;
    entries_.erase(last);
    order_.pop_back();
  }
}

}  // namespace shadefit::metrics
