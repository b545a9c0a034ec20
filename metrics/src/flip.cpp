// FLIP's entry points (flip.h): the cache of reference halves, pooling of the map into
// statistics, and HDR-FLIP's exposures and tone mappers around the LDR-FLIP map of flip_map.cpp.
#include "shadefit/metrics/flip.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <mutex>

#include "flip_map.h"
#include "internal.h"
#include "shadefit/base/statistics.h"
#include "shadefit/metrics/common.h"

namespace shadefit::metrics {
namespace {

using internal::CombineSides;
using internal::ComputeSide;
using internal::Exposure;
using internal::FlipSide;
using internal::Plane;
using internal::RowSpans;
using internal::SideScratch;

// 64-bit hash of an image's size and pixel bits: splitmix64's finaliser over 64-bit words (two
// floats), in four independent lanes so that the mixes of neighbouring words overlap instead of
// waiting on each other (it runs on every FLIP call, over the whole frame), lanes mixed at the end.
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

}  // namespace

// What identifies a reference's half: its pixels (hash), the pixels it is wanted at (hash of the
// spans), the observer, and the exposure scale and tone mapper applied before its half is
// computed (tone mapper 0: none, LDR-FLIP).
struct FlipReferenceCache::Impl {
  struct Key {
    std::uint64_t pixels;
    std::uint64_t spans;
    double ppd;
    int tone_mapper;
    float scale;
    auto operator<=>(const Key&) const = default;
  };
  struct Entry {
    std::shared_ptr<const FlipSide> side;
    std::list<Key>::iterator lru;  // Position in `order`, most recent first.
  };

  std::shared_ptr<const FlipSide> Find(const Key& key) {
    std::lock_guard lock(mutex);
    const auto it = entries.find(key);
    if (it == entries.end()) {
      ++stats.misses;
      return nullptr;
    }
    ++stats.hits;
    order.splice(order.begin(), order, it->second.lru);
    return it->second.side;
  }

  void Insert(const Key& key, std::shared_ptr<const FlipSide> side) {
    std::lock_guard lock(mutex);
    if (entries.contains(key)) return;  // Another thread computed it too: the same values.
    stats.bytes += side->Bytes();
    order.push_front(key);
    entries.emplace(key, Entry{std::move(side), order.begin()});
    while (stats.bytes > budget && order.size() > 1) {
      const auto last = entries.find(order.back());
      stats.bytes -= last->second.side->Bytes();
      entries.erase(last);
      order.pop_back();
    }
  }

  std::size_t budget;
  std::mutex mutex;
  std::map<Key, Entry> entries;
  std::list<Key> order;
  FlipReferenceCache::Stats stats;
};

FlipReferenceCache::FlipReferenceCache(std::size_t byte_budget) : impl_(std::make_unique<Impl>()) {
  impl_->budget = byte_budget;
}

FlipReferenceCache::~FlipReferenceCache() = default;

FlipReferenceCache::Stats FlipReferenceCache::stats() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->stats;
}

namespace {

// The reference's half: from `cache` when it holds `key`, else computed (and kept there when
// there is a cache).
std::shared_ptr<const FlipSide> ReferenceSide(FlipReferenceCache* cache,
                                              const FlipReferenceCache::Impl::Key& key,
                                              const Image& reference, double ppd,
                                              const RowSpans& wanted, const Exposure& exposure) {
  std::shared_ptr<const FlipSide> side = cache ? cache->impl().Find(key) : nullptr;
  if (!side) {
    side = std::make_shared<const FlipSide>(ComputeSide(reference, ppd, wanted, exposure));
    if (cache) cache->impl().Insert(key, side);
  }
  return side;
}

FlipResult Pool(const Plane& map, const Image* mask) {
  std::vector<float> values;
  values.reserve(map.size());
  double sum = 0.0;
  FlipResult result;
  result.histogram.assign(20, 0.0);
  for (std::size_t i = 0; i < map.size(); ++i) {
    if (!internal::IsValid(mask, i)) continue;
    values.push_back(map[i]);
    sum += map[i];
    result.histogram[std::min(19, static_cast<int>(map[i] * 20.0f))] += 1.0;
  }
  for (double& b : result.histogram) b /= static_cast<double>(values.size());
  result.mean = sum / static_cast<double>(values.size());
  internal::SortNonNegative(values);
  result.median = internal::NearestRankSorted(values, 0.5);
  result.p95 = internal::NearestRankSorted(values, 0.95);
  result.p99 = internal::NearestRankSorted(values, 0.99);
  result.max = values.back();
  // Error-weighted percentiles: walk the sorted values until the running error sum exceeds the
  // fraction q of the total (Andersson et al. 2020, Sec. 6, weighted histogram).
  const auto weighted = [&](double q) {
    double running = 0.0;
    for (float v : values) {
      running += v;
      if (running > q * sum) return static_cast<double>(v);
    }
    return static_cast<double>(values.back());
  };
  result.weighted_median = weighted(0.5);
  result.weighted_q1 = weighted(0.25);
  result.weighted_q3 = weighted(0.75);
  return result;
}

Image ToImage(const Plane& plane, int w, int h) {
  Image image(w, h, 1);
  image.data = plane;
  return image;
}

// Input x with tonemap(x) = t: the larger root of (c0 - t c3) x^2 + (c1 - t c4) x + (c2 - t c5).
double ToneMapInverse(FlipToneMapper tm, double t) {
  using internal::kAces;
  if (tm == FlipToneMapper::kReinhard) return t / (1.0 - t);  // x / (1 + x) = t.
  const double a = kAces[0] - t * kAces[3];
  const double b = kAces[1] - t * kAces[4];
  const double c = kAces[2] - t * kAces[5];
  if (a == 0.0) return -c / b;
  const double mid = -0.5 * b / a;
  return mid + std::sqrt(mid * mid - c / a);
}

// The pixels a map is computed at: the mask's (what Pool reads) unless a whole map is returned.
RowSpans WantedSpans(const Image& ref, const Image* mask, bool whole_map) {
  return whole_map ? internal::FullSpans(ref.width, ref.height)
                   : internal::MaskSpans(mask, ref.width, ref.height);
}

}  // namespace

FlipResult FlipLdr(const Image& reference, const Image& test, const FlipParameters& p,
                   Image* flip_map) {
  ValidateInputs(reference, test, p.mask, 3);
  const Image& ref = reference;  // The halves read the first three channels.
  const RowSpans wanted = WantedSpans(ref, p.mask, flip_map != nullptr);
  const FlipReferenceCache::Impl::Key key{p.reference_cache ? HashPixels(ref) : 0,
                                          internal::HashSpans(wanted), p.ppd, 0, 1.0f};
  const auto ref_side = ReferenceSide(p.reference_cache, key, ref, p.ppd, wanted, {});
  const Plane map =
      CombineSides(*ref_side, ComputeSide(test, p.ppd, wanted), ref.width, ref.height, wanted);
  FlipResult result = Pool(map, p.mask);
  if (flip_map) *flip_map = ToImage(map, reference.width, reference.height);
  return result;
}

FlipResult FlipHdr(const Image& reference, const Image& test, const FlipParameters& p,
                   Image* flip_map, Image* exposure_map) {
  ValidateInputs(reference, test, p.mask, 3);
  const Image& ref = reference;  // The halves read the first three channels.
  const std::size_t n = ref.PixelCount();
  // Exposure range from the reference (Andersson et al. 2021, Sec. 3): the start exposure maps
  // the brightest reference pixel, the stop exposure the median one, to 0.85 after tone mapping.
  double start = p.start_exposure, stop = p.stop_exposure;
  if (std::isnan(start) || std::isnan(stop)) {
    // The luminance of the evaluated pixels: the mask's when one is given (a sphere on black
    // has more black background than lit surface, and the background's zeros would pull the
    // median, and so the stop exposure, many stops below anything evaluated).
    std::vector<float> luminance;
    luminance.reserve(n);
    float y_max = 0.0f;
    for (std::size_t i = 0; i < n; ++i) {
      if (!internal::IsValid(p.mask, i)) continue;
      const float* c = &ref.data[ref.channels * i];
      luminance.push_back(0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2]);
      y_max = std::max(y_max, luminance.back());
    }
    // The upper median (base/statistics.h); 0 for no pixel.
    const auto median = [](std::vector<float>& v) { return v.empty() ? 0.0f : Percentile(v, 0.5); };
    float y_median = median(luminance);
    // Degenerate references: more than half of the evaluated pixels black -> the median of the
    // lit ones stands in (the darkest lit pixel would stretch the range by many stops of
    // exposures that show nothing but black); all black -> exposure 0.
    if (!(y_median > 0.0f)) {
      std::erase_if(luminance, [](float y) { return !(y > 0.0f); });
      y_median = luminance.empty() ? 1.0f : median(luminance);
    }
    if (!(y_max > 0.0f)) y_max = 1.0f;
    const double x85 = ToneMapInverse(p.tone_mapper, 0.85);
    if (std::isnan(start)) start = std::log2(x85 / y_max);
    if (std::isnan(stop)) stop = std::log2(x85 / y_median);
  }
  if (stop < start) stop = start;
  const int count = p.num_exposures > 0 ? std::max(2, p.num_exposures)
                                        : static_cast<int>(std::max(2.0, std::ceil(stop - start)));
  const double step = (stop - start) / (count - 1);

  Plane worst(n, 0.0f), worst_index(n, 0.0f);
  const std::uint64_t ref_hash = p.reference_cache ? HashPixels(ref) : 0;
  const RowSpans wanted = WantedSpans(ref, p.mask, flip_map != nullptr || exposure_map != nullptr);
  const std::uint64_t spans_hash = internal::HashSpans(wanted);
  // The test image's half and the map at one exposure, kept across the exposures and, with
  // the scratch planes, across calls on this thread (a new plane is memory cleared first).
  thread_local FlipSide test_side;
  thread_local Plane map;
  SideScratch& scratch = internal::ThreadScratch();
  for (int e = 0; e < count; ++e) {
    const Exposure exposure{true, static_cast<float>(std::exp2(start + e * step)), p.tone_mapper};
    const FlipReferenceCache::Impl::Key key{ref_hash, spans_hash, p.ppd,
                                            1 + static_cast<int>(p.tone_mapper), exposure.scale};
    const auto ref_side = ReferenceSide(p.reference_cache, key, ref, p.ppd, wanted, exposure);
    ComputeSide(test, p.ppd, wanted, exposure, scratch, test_side);
    CombineSides(*ref_side, test_side, ref.width, wanted, map);
    // Outside `wanted` the map is not written and `worst` stays 0, as a map of 0 there leaves it.
    for (std::size_t y = 0; y < wanted.begin.size(); ++y) {
      for (int x = wanted.begin[y]; x < wanted.end[y]; ++x) {
        const std::size_t i = y * ref.width + x;
        if (map[i] > worst[i]) {
          worst[i] = map[i];
          worst_index[i] = static_cast<float>(e) / (count - 1);
        }
      }
    }
  }
  FlipResult result = Pool(worst, p.mask);
  result.start_exposure = start;
  result.stop_exposure = stop;
  result.num_exposures = count;
  if (flip_map) *flip_map = ToImage(worst, ref.width, ref.height);
  if (exposure_map) *exposure_map = ToImage(worst_index, ref.width, ref.height);
  return result;
}

}  // namespace shadefit::metrics