// FLIP's entry points (flip.h): the cache of reference halves, pooling of the map into
// statistics, and HDR-FLIP's exposures and tone mappers around the LDR-FLIP map of flip_map.cpp.
#include "shadefit/metrics/flip.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>

#include "flip_map.h"
#include "internal.h"
#include "reference_cache.h"
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

// The reference's half at one exposure (tone mapper 0: none, LDR-FLIP), from `cache` when it holds
// it; what it depends on: the reference's pixels, the pixels it is wanted at, the observer, and
// the exposure scale and tone mapper applied before it is computed.
std::shared_ptr<const FlipSide> ReferenceSide(ReferenceCache* cache, std::uint64_t pixels,
                                              const Image& reference, double ppd,
                                              const RowSpans& wanted, std::uint64_t wanted_hash,
                                              int tone_mapper, const Exposure& exposure) {
  const ReferenceCache::Impl::Key key{ReferenceCache::Impl::Kind::kFlip, pixels, wanted_hash,
                                      {ppd, static_cast<double>(tone_mapper), exposure.scale}};
  return FindOrMake<FlipSide>(
      cache, key, [&] { return ComputeSide(reference, ppd, wanted, exposure); },
      [](const FlipSide& side) { return side.Bytes(); });
}

// Copies the kept half of `from` with this tone mapper and scale into `side` (this call's
// coordinates: its image at `x0`, `y0` of the frame, `width` wide): false, and `side` untouched,
// when there is none with this observer or it lacks a pixel of `wanted`.
bool TakeKeptHalf(const internal::FlipTestHalves& from, int x0, int y0, int width, double ppd,
                  int tone_mapper, float scale, const RowSpans& wanted, FlipSide& side) {
  if (from.ppd != ppd) return false;
  const auto half = std::find_if(from.halves.begin(), from.halves.end(), [&](const auto& k) {
    return k.tone_mapper == tone_mapper && k.scale == scale;
  });
  if (half == from.halves.end()) return false;
  const RowSpans& kept = half->spans;
  const int dx = x0 - from.x0, dy = y0 - from.y0;
  const int kept_rows = static_cast<int>(kept.begin.size());
  const int kept_width = half->width;
  const int rows = static_cast<int>(wanted.begin.size());
  for (int y = 0; y < rows; ++y) {
    if (wanted.begin[y] >= wanted.end[y]) continue;
    const int ky = y + dy;
    if (ky < 0 || ky >= kept_rows || wanted.begin[y] + dx < kept.begin[ky] ||
        wanted.end[y] + dx > kept.end[ky]) {
      return false;
    }
  }
  const std::size_t n = static_cast<std::size_t>(width) * rows;
  side.lab.resize(n);
  side.features.edge.resize(n);
  side.features.point.resize(n);
  const FlipSide& k = half->side;
  for (int y = 0; y < rows; ++y) {
    if (wanted.begin[y] >= wanted.end[y]) continue;
    const std::size_t to = static_cast<std::size_t>(y) * width + wanted.begin[y];
    const std::size_t at = static_cast<std::size_t>(y + dy) * kept_width + wanted.begin[y] + dx;
    const std::size_t count = static_cast<std::size_t>(wanted.end[y] - wanted.begin[y]);
    std::copy_n(k.lab.begin() + at, count, side.lab.begin() + to);
    std::copy_n(k.features.edge.begin() + at, count, side.features.edge.begin() + to);
    std::copy_n(k.features.point.begin() + at, count, side.features.point.begin() + to);
  }
  return true;
}

// The test image's half at one exposure (tone mapper 0: LDR-FLIP), from reuse.from when it holds
// it, else computed; a copy kept in reuse.keep.
void TestSide(const Image& test, double ppd, const RowSpans& wanted, int tone_mapper,
              const Exposure& exposure, const internal::FlipReuse& reuse, SideScratch& scratch,
              FlipSide& side) {
  if (reuse.from == nullptr || !TakeKeptHalf(*reuse.from, reuse.x0, reuse.y0, test.width, ppd,
                                             tone_mapper, exposure.scale, wanted, side)) {
    ComputeSide(test, ppd, wanted, exposure, scratch, side);
  }
  if (reuse.keep != nullptr) {
    reuse.keep->x0 = reuse.x0;
    reuse.keep->y0 = reuse.y0;
    reuse.keep->ppd = ppd;
    reuse.keep->halves.push_back({tone_mapper, exposure.scale, test.width, wanted, side});
  }
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
  return internal::FlipLdr(reference, test, p, flip_map, {});
}

FlipResult FlipHdr(const Image& reference, const Image& test, const FlipParameters& p,
                   Image* flip_map, Image* exposure_map) {
  return internal::FlipHdr(reference, test, p, flip_map, exposure_map, {});
}

FlipResult internal::FlipLdr(const Image& reference, const Image& test, const FlipParameters& p,
                             Image* flip_map, const FlipReuse& reuse) {
  ValidateInputs(reference, test, p.mask, 3);
  const Image& ref = reference;  // The halves read the first three channels.
  const RowSpans wanted = WantedSpans(ref, p.mask, flip_map != nullptr);
  const auto ref_side =
      ReferenceSide(p.reference_cache, p.reference_cache ? HashPixels(ref) : 0, ref, p.ppd, wanted,
                    internal::HashSpans(wanted), 0, {});
  FlipSide test_side;
  TestSide(test, p.ppd, wanted, 0, {}, reuse, internal::ThreadScratch(), test_side);
  const Plane map = CombineSides(*ref_side, test_side, ref.width, ref.height, wanted);
  FlipResult result = Pool(map, p.mask);
  if (flip_map) *flip_map = ToImage(map, reference.width, reference.height);
  return result;
}

FlipResult internal::FlipHdr(const Image& reference, const Image& test, const FlipParameters& p,
                             Image* flip_map, Image* exposure_map, const FlipReuse& reuse) {
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
    const auto ref_side = ReferenceSide(p.reference_cache, ref_hash, ref, p.ppd, wanted, spans_hash,
                                        1 + static_cast<int>(p.tone_mapper), exposure);
    TestSide(test, p.ppd, wanted, 1 + static_cast<int>(p.tone_mapper), exposure, reuse, scratch,
             test_side);
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