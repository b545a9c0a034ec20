// The pixels of a bounded-LM problem as its passes walk them (internal to fit/): fixed chunks of
// pixels, run on the problem's threads, and the geometry of every lit sample, computed once per
// problem and shared by its passes (GeometryOf). lm_evaluator.cpp's passes read it.
#pragma once

#include <algorithm>
#include <memory>
#include <thread>
#include <vector>

#include "lm_problem.h"

namespace shadefit::fit::internal {

// Pixels per partial sum. The sums of a pass are taken per chunk and then added in chunk order,
// so the result does not depend on how many threads ran the chunks.
constexpr int kChunkPixels = 1024;

struct Chunk {
  int span = 0, begin = 0, count = 0;
};

std::vector<Chunk> Chunks(const BoundedLmProblem& problem);

// Runs fn(chunk index) for every chunk on `threads` threads (chunk c on thread c % threads).
template <typename Fn>
void ForEachChunk(int chunks, int threads, const Fn& fn) {
  threads = std::max(1, std::min(threads, chunks));
  auto work = [&](int t) {
    for (int c = t; c < chunks; c += threads) fn(c);
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(work, t);
  work(0);
  for (std::thread& th : pool) th.join();
}

// One light sample of a shading point (point.lights, then point.environment, in that order)
// with l and v above the surface, reduced to the dot products the models read. Trivially
// default-constructible (no Vec3d, whose members are zeroed), so that an array of them is
// allocated without being written: the pages are first touched by the threads that fill them
// (a zeroing resize of 39k samples took 1.3 ms of a 2 ms PrepareGeometry, on one thread).
struct LitSample {
  ShadingDots<double> dots;
  double irradiance[3];
};

// The lit samples of every point of every span, computed once per solve instead of once per
// pass: [begin[k], begin[k + 1]) are point k's. Left empty (the passes then compute the dots
// of each sample as they go, as ShadePoint does) when there are more than kMaxLitSamples, as
// with an environment quadrature of hundreds of samples per pixel, where they would double
// the memory the points already hold.
struct SpanGeometry {
  std::vector<int> begin;
  std::unique_ptr<LitSample[]> samples;
};
struct Geometry {
  bool precomputed = false;
  std::vector<SpanGeometry> spans;
};

inline bool SampleAboveSurface(const ShadingPoint& point, const PixelLight& light) {
  return Dot(point.n, light.l) > 0.0 && Dot(point.n, point.v) > 0.0;
}

// The problem's geometry: from its cache when that was computed for the same spans.
std::shared_ptr<const Geometry> GeometryOf(const BoundedLmProblem& problem,
                                           const std::vector<Chunk>& chunks);

// add(dots, irradiance) for every lit sample of point k of span `span`: the precomputed ones,
// or those computed as ShadePoint does when the geometry was not precomputed.
template <typename Add>
void ForEachLitSample(const Geometry& geo, int span, const ShadingPoint& point, int k,
                      const Add& add) {
  if (geo.precomputed) {
    const SpanGeometry& sg = geo.spans[span];
    for (int i = sg.begin[k]; i < sg.begin[k + 1]; ++i) {
      const LitSample& sample = sg.samples[i];
      add(sample.dots, Vec3d{sample.irradiance[0], sample.irradiance[1], sample.irradiance[2]});
    }
    return;
  }
  for (const std::vector<PixelLight>* set : {&point.lights, &point.environment}) {
    for (const PixelLight& light : *set) {
      if (SampleAboveSurface(point, light)) {
        add(ComputeShadingDots(point.n, light.l, point.v), light.irradiance);
      }
    }
  }
}

}  // namespace shadefit::fit::internal
