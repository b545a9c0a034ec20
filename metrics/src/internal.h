// Helpers shared by the metric sources (not installed).
#pragma once

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cmath>
#include <cstddef>
#include <limits>
#include <thread>
#include <vector>

#include "shadefit/metrics/common.h"
#include "shadefit/metrics/ssim.h"
#include "shadefit/render/image.h"

namespace shadefit::metrics::internal {

// Runs body(begin_row, end_row) over [0, rows) split into contiguous blocks, one per thread
// of MetricsThreads() (the rows of a filter pass are independent). Small jobs run inline.
template <typename Body>
void ParallelRows(int rows, Body body) {
  const int threads = MetricsThreads();
  if (threads == 1 || rows < 64) {
    body(0, rows);
    return;
  }
  std::vector<std::thread> pool;
  const int block = (rows + threads - 1) / threads;
  for (int t = 1; t < threads; ++t) {
    const int begin = t * block;
    const int end = std::min(rows, begin + block);
    if (begin < end) pool.emplace_back([=] { body(begin, end); });
  }
  body(0, std::min(rows, block));
  for (auto& thread : pool) thread.join();
}

// While one is alive on a thread, ValidateInputs on that thread skips the scans that
// ComputeMetrics made of the images it derives every metric's inputs from (a window of them, or
// their display encodings, clipped to [0, 1]): finite values, and a mask with a valid pixel. A
// metric's own checks of sizes and channels still run. Ends with its scope, thrown or not.
class CheckedInputs {
 public:
  CheckedInputs();
  ~CheckedInputs();
  CheckedInputs(const CheckedInputs&) = delete;
  CheckedInputs& operator=(const CheckedInputs&) = delete;

 private:
  bool was_;  // Nested in another one.
};

inline bool IsValid(const Image* mask, std::size_t pixel) {
  return mask == nullptr || mask->data[pixel] > 0.5f;
}

// Values at the valid pixels of a frame, in row-major order: row y's are values[row_start[y]]
// onwards. What the reference cache keeps of a reference for a point-wise metric.
template <typename T>
struct ValidPixelValues {
  std::vector<std::size_t> row_start;  // height + 1 entries
  std::vector<T> values;
  std::size_t Bytes() const {
    return row_start.size() * sizeof(std::size_t) + values.size() * sizeof(T);
  }
};

// f(pixel index) at every valid pixel of a w x h frame, rows split over the threads.
template <typename T, typename F>
ValidPixelValues<T> AtValidPixels(int w, int h, const Image* mask, F f) {
  ValidPixelValues<T> out;
  out.row_start.resize(static_cast<std::size_t>(h) + 1);
  std::size_t k = 0;
  for (int y = 0; y < h; ++y) {
    out.row_start[y] = k;
    for (std::size_t i = static_cast<std::size_t>(y) * w; i < static_cast<std::size_t>(y + 1) * w;
         ++i) {
      k += IsValid(mask, i) ? 1 : 0;
    }
  }
  out.row_start[h] = k;
  out.values.resize(k);
  ParallelRows(h, [&](int row_begin, int row_end) {
    for (int y = row_begin; y < row_end; ++y) {
      std::size_t j = out.row_start[y];
      for (std::size_t i = static_cast<std::size_t>(y) * w;
           i < static_cast<std::size_t>(y + 1) * w; ++i) {
        if (IsValid(mask, i)) out.values[j++] = f(i);
      }
    }
  });
  return out;
}

// A point-wise map of a w x h frame: f(the reference's kept value, pixel index) at each valid
// pixel, NaN elsewhere (CIEDE2000's and Delta E_ITP's maps, from the reference's CIELAB or
// ICtCp).
template <typename T, typename F>
Image PointWiseMap(const ValidPixelValues<T>& reference, int w, int h, const Image* mask, F f) {
  Image map(w, h, 1, std::numeric_limits<float>::quiet_NaN());
  ParallelRows(h, [&](int row_begin, int row_end) {
    for (int y = row_begin; y < row_end; ++y) {
      const T* r = reference.values.data() + reference.row_start[y];
      for (std::size_t i = static_cast<std::size_t>(y) * w;
           i < static_cast<std::size_t>(y + 1) * w; ++i) {
        if (IsValid(mask, i)) map.data[i] = static_cast<float>(f(*r++, i));
      }
    }
  });
  return map;
}

// Sorts non-negative floats ascending (LSD radix sort on the bit patterns, which order like the
// values when the sign bit is clear): O(n), several times faster than std::sort on FLIP maps.
// Values with the sign bit set (negative, -0) fall back to std::sort.
inline void SortNonNegative(std::vector<float>& values) {
  std::vector<std::uint32_t> keys(values.size()), tmp(values.size());
  for (std::size_t i = 0; i < values.size(); ++i) {
    keys[i] = std::bit_cast<std::uint32_t>(values[i]);
    if (keys[i] >> 31) {
      std::sort(values.begin(), values.end());
      return;
    }
  }
  for (int shift = 0; shift < 32; shift += 11) {  // Three passes of 11 bits.
    std::vector<std::size_t> count(2049, 0);
    for (std::uint32_t k : keys) ++count[((k >> shift) & 2047u) + 1];
    for (int b = 0; b < 2048; ++b) count[b + 1] += count[b];
    for (std::uint32_t k : keys) tmp[count[(k >> shift) & 2047u]++] = k;
    keys.swap(tmp);
  }
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = std::bit_cast<float>(keys[i]);
}

// Nearest-rank percentile (rank ceil(q n), 1-based) of values sorted ascending. q in [0, 1].
inline double NearestRankSorted(const std::vector<float>& sorted, double q) {
  if (sorted.empty()) return 0.0;
  const double rank = std::ceil(q * static_cast<double>(sorted.size()));
  const std::size_t index =
      std::min(sorted.size() - 1, static_cast<std::size_t>(std::max(1.0, rank)) - 1);
  return sorted[index];
}

// Mean, 95th percentile (nearest rank) and maximum of a one-channel map over the valid pixels
// of the mask (every pixel without one); the map's values must be non-negative. The summary of
// the point-wise colour differences (CIEDE2000, Delta E_ITP).
struct MapStatistics {
  double mean = 0.0;
  double p95 = 0.0;
  double max = 0.0;
};
inline MapStatistics SummarizeMap(const Image& map, const Image* mask) {
  std::vector<float> values;
  values.reserve(map.PixelCount());
  double sum = 0.0;
  for (std::size_t i = 0; i < map.PixelCount(); ++i) {
    if (!IsValid(mask, i)) continue;
    values.push_back(map.data[i]);
    sum += map.data[i];
  }
  MapStatistics s;
  if (values.empty()) return s;
  s.mean = sum / static_cast<double>(values.size());
  SortNonNegative(values);
  s.p95 = NearestRankSorted(values, 0.95);
  s.max = values.back();
  return s;
}

// Where an SSIM call's images lie in the frame (its window's corner), and the terms it keeps or
// pools: planes indexed scale x channels + channel (SsimTerms).
struct SsimReuse {
  int x0 = 0, y0 = 0;
  std::vector<SsimPlaneTerms>* keep = nullptr;
  const std::vector<SsimPlaneTerms>* from = nullptr;  // Not read when keep is set.
};

// Ssim without a map, keeping or pooling terms (`reuse`).
SsimResult SsimReusing(const Image& reference, const Image& test, const SsimParameters& p,
                       const SsimReuse& reuse);

// MsSsim; with `ssim`, also Ssim of the same images and parameters (no map), which is MS-SSIM's
// first scale: the same planes, pool and sums, so the same bits, at no cost of its own.
MsSsimResult MsSsimAndSsim(const Image& reference, const Image& test, const MsSsimParameters& p,
                           SsimResult* ssim, const SsimReuse& reuse = {});

// PSNR of images already display-encoded (Psnr encodes, then calls it).
double PsnrOfEncoded(const Image& reference, const Image& test, const Image* mask);

}  // namespace shadefit::metrics::internal
