// Benchmarks of the image metrics on 512 x 512 images (docs/metrics.md, "Performance").
//
// Build (the lead's bench/CMakeLists.txt):
//   add_executable(metrics_bench metrics_bench.cpp)
//   target_link_libraries(metrics_bench PRIVATE shadefit::metrics benchmark::benchmark_main)
// Run: ./bench/metrics_bench --benchmark_min_time=1 (Release build).
// Target: SSIM + LDR-FLIP together <= 100 ms on the 2-core development machine.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "shadefit/metrics/ciede2000.h"
#include "shadefit/metrics/common.h"
#include "shadefit/metrics/flip.h"
#include "shadefit/metrics/ssim.h"

namespace {

using shadefit::Image;
namespace m = shadefit::metrics;

// One metrics thread for a benchmark's scope, as a study job's worker has; the count before it
// restored after.
class OneMetricsThread {
 public:
  OneMetricsThread() : before_(m::MetricsThreads()) { m::SetMetricsThreads(1); }
  ~OneMetricsThread() { m::SetMetricsThreads(before_); }
  OneMetricsThread(const OneMetricsThread&) = delete;
  OneMetricsThread& operator=(const OneMetricsThread&) = delete;

 private:
  int before_;
};

constexpr int kSize = 512;

float Noise(std::uint32_t i, std::uint32_t seed) {
  std::uint32_t h = i * 2654435761u + seed * 97531u;
  h = (h ^ (h >> 15)) * 2246822519u;
  h ^= h >> 13;
  return static_cast<float>(h & 0xFFFF) / 65535.0f - 0.5f;
}

// Linear HDR test scene (gradients, a bright band, edges) and a noisy, brighter copy.
const Image& Reference() {
  static const Image image = [] {
    Image img(kSize, kSize, 3);
    for (int y = 0; y < kSize; ++y) {
      for (int x = 0; x < kSize; ++x) {
        const float u = x / float(kSize), v = y / float(kSize);
        const float band = (y / 64) % 2 ? 4.0f : 0.3f;
        img.at(x, y, 0) = band * (0.2f + 0.8f * u);
        img.at(x, y, 1) = band * (0.3f + 0.5f * v);
        img.at(x, y, 2) = ((x / 16 + y / 16) % 2) ? 0.8f : 0.05f;
      }
    }
    return img;
  }();
  return image;
}

const Image& Test() {
  static const Image image = [] {
    Image img = Reference();
    for (std::size_t i = 0; i < img.data.size(); ++i) {
      img.data[i] = std::max(0.0f, img.data[i] * (1.05f + 0.2f * Noise(i, 1)));
    }
    return img;
  }();
  return image;
}

void BM_SsimLuminance512(benchmark::State& state) {
  const Image r = m::DisplayEncode(m::Luminance(Reference()), 0.0f);
  const Image t = m::DisplayEncode(m::Luminance(Test()), 0.0f);
  for (auto _ : state) benchmark::DoNotOptimize(m::Ssim(r, t).mean);
}
BENCHMARK(BM_SsimLuminance512)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_SsimRgb512(benchmark::State& state) {
  const Image r = m::DisplayEncode(Reference(), 0.0f);
  const Image t = m::DisplayEncode(Test(), 0.0f);
  for (auto _ : state) benchmark::DoNotOptimize(m::Ssim(r, t).mean);
}
BENCHMARK(BM_SsimRgb512)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_FlipLdr512(benchmark::State& state) {
  const Image r = m::ExposeAndClip(Reference(), 0.0f);
  const Image t = m::ExposeAndClip(Test(), 0.0f);
  for (auto _ : state) benchmark::DoNotOptimize(m::FlipLdr(r, t).mean);
}
BENCHMARK(BM_FlipLdr512)->Unit(benchmark::kMillisecond)->UseRealTime();

// The budgeted pair: luminance SSIM plus LDR-FLIP on the same 512^2 inputs.
void BM_SsimPlusFlipLdr512(benchmark::State& state) {
  const Image ry = m::DisplayEncode(m::Luminance(Reference()), 0.0f);
  const Image ty = m::DisplayEncode(m::Luminance(Test()), 0.0f);
  const Image r = m::ExposeAndClip(Reference(), 0.0f);
  const Image t = m::ExposeAndClip(Test(), 0.0f);
  for (auto _ : state) {
    benchmark::DoNotOptimize(m::Ssim(ry, ty).mean);
    benchmark::DoNotOptimize(m::FlipLdr(r, t).mean);
  }
}
BENCHMARK(BM_SsimPlusFlipLdr512)->Unit(benchmark::kMillisecond)->UseRealTime();

// HDR-FLIP runs LDR-FLIP once per exposure (here num_exposures is reported as a counter).
void BM_FlipHdr512(benchmark::State& state) {
  int exposures = 0;
  for (auto _ : state) {
    const m::FlipResult f = m::FlipHdr(Reference(), Test());
    exposures = f.num_exposures;
    benchmark::DoNotOptimize(f.mean);
  }
  state.counters["exposures"] = exposures;
}
BENCHMARK(BM_FlipHdr512)->Unit(benchmark::kMillisecond)->UseRealTime();

// CIEDE2000 as a study job runs it: one metrics thread, the reference's CIELAB from the cache,
// so each call converts the test image and takes the colour difference per pixel.
void BM_Ciede2000_512CachedReferenceOneThread(benchmark::State& state) {
  const OneMetricsThread one_thread;
  m::ReferenceCache cache(std::size_t{1} << 30);
  m::DeltaE2000Parameters p;
  p.reference_cache = &cache;
  for (auto _ : state) benchmark::DoNotOptimize(m::DeltaE2000(Reference(), Test(), p).mean);
}
BENCHMARK(BM_Ciede2000_512CachedReferenceOneThread)->Unit(benchmark::kMillisecond)->UseRealTime();

// HDR-FLIP as a study job runs it: one metrics thread per worker, the reference's half from
// the cache (every fit of a material is compared with the same references), so each call
// computes the test image's half at every exposure and combines.
void BM_FlipHdr512CachedReferenceOneThread(benchmark::State& state) {
  const OneMetricsThread one_thread;
  m::ReferenceCache cache(std::size_t{1} << 30);
  m::FlipParameters p;
  p.reference_cache = &cache;
  int exposures = 0;
  for (auto _ : state) {
    const m::FlipResult f = m::FlipHdr(Reference(), Test(), p);
    exposures = f.num_exposures;
    benchmark::DoNotOptimize(f.mean);
  }
  state.counters["exposures"] = exposures;
}
BENCHMARK(BM_FlipHdr512CachedReferenceOneThread)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
