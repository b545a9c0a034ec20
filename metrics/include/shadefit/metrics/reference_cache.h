// What the metrics compute from the reference alone, kept for the next comparison with the same
// reference: FLIP's half of the map at each exposure (flip.h), CIELAB for CIEDE2000
// (ciede2000.h), ICtCp for Delta E_ITP (delta_e_itp.h) and the display encodings (sRGB, of RGB
// and of luminance) that ComputeMetrics' PSNR and SSIM read (report.h). A study compares every
// fit of a material with the same references (10 fits x 15 HDR-FLIP exposures each); the
// reference's half of each metric is half of that work. The values found are those a call without the cache
// computes: the results are the same bits with and without one.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

namespace shadefit::metrics {

// Entries are found by what the kept values depend on: a 64-bit hash of the reference's pixels
// and size, of the pixels they are wanted at (the mask's), and the metric's parameters.
// Thread-safe; the least recently used entries go when the held bytes pass the budget.
class ReferenceCache {
 public:
  explicit ReferenceCache(std::size_t byte_budget);
  ~ReferenceCache();
  ReferenceCache(const ReferenceCache&) = delete;
  ReferenceCache& operator=(const ReferenceCache&) = delete;

  struct Stats {
    std::uint64_t hits = 0;
    std::uint64_t misses = 0;
    std::size_t bytes = 0;  // Held now.
  };
  Stats stats() const;

  struct Impl;  // metrics/src/reference_cache.h.
  Impl& impl() { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace shadefit::metrics
