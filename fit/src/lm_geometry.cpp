#include "lm_geometry.h"

#include <algorithm>
#include <mutex>

namespace shadefit::fit::internal {
namespace {

constexpr long kMaxLitSamples = 1L << 20;  // 88 MiB of LitSample.

// The lit samples of `problem`, in the order of its points and their lights: each point's count
// (two dot products per sample) and then its samples are computed per chunk on the problem's
// threads, with the offsets summed in between: the same values whatever the thread count.
Geometry PrepareGeometry(const BoundedLmProblem& problem, const std::vector<Chunk>& chunks) {
  Geometry geo;
  long total = 0;
  for (const PixelSpan& s : problem.spans) {
    for (int k = 0; k < s.count; ++k) {
      total += static_cast<long>(s.points[k].lights.size() + s.points[k].environment.size());
    }
  }
  if (total > kMaxLitSamples) return geo;
  geo.precomputed = true;
  for (const PixelSpan& s : problem.spans) geo.spans.emplace_back().begin.assign(s.count + 1, 0);
  ForEachChunk(static_cast<int>(chunks.size()), problem.threads, [&](int c) {
    const Chunk& chunk = chunks[c];
    const ShadingPoint* points = problem.spans[chunk.span].points;
    std::vector<int>& begin = geo.spans[chunk.span].begin;
    for (int k = chunk.begin; k < chunk.begin + chunk.count; ++k) {
      int lit = 0;
      for (const std::vector<PixelLight>* set : {&points[k].lights, &points[k].environment}) {
        for (const PixelLight& light : *set) lit += SampleAboveSurface(points[k], light) ? 1 : 0;
      }
      begin[k + 1] = lit;
    }
  });
  for (SpanGeometry& sg : geo.spans) {
    for (std::size_t k = 1; k < sg.begin.size(); ++k) sg.begin[k] += sg.begin[k - 1];
    sg.samples = std::make_unique_for_overwrite<LitSample[]>(static_cast<std::size_t>(sg.begin.back()));
  }
  ForEachChunk(static_cast<int>(chunks.size()), problem.threads, [&](int c) {
    const Chunk& chunk = chunks[c];
    const ShadingPoint* points = problem.spans[chunk.span].points;
    SpanGeometry& sg = geo.spans[chunk.span];
    for (int k = chunk.begin; k < chunk.begin + chunk.count; ++k) {
      const ShadingPoint& point = points[k];
      LitSample* out = sg.samples.get() + sg.begin[k];
      for (const std::vector<PixelLight>* set : {&point.lights, &point.environment}) {
        for (const PixelLight& light : *set) {
          if (!SampleAboveSurface(point, light)) continue;
          out->dots = ComputeShadingDots(point.n, light.l, point.v);
          for (int ch = 0; ch < 3; ++ch) out->irradiance[ch] = light.irradiance[ch];
          ++out;
        }
      }
    }
  });
  return geo;
}

bool SameSpans(const std::vector<PixelSpan>& a, const std::vector<PixelSpan>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].points != b[i].points || a[i].count != b[i].count) return false;
  }
  return true;
}

}  // namespace

std::vector<Chunk> Chunks(const BoundedLmProblem& problem) {
  std::vector<Chunk> out;
  for (int s = 0; s < static_cast<int>(problem.spans.size()); ++s) {
    for (int k = 0; k < problem.spans[s].count; k += kChunkPixels) {
      out.push_back({s, k, std::min(kChunkPixels, problem.spans[s].count - k)});
    }
  }
  return out;
}

struct GeometryCache {
  std::mutex mutex;
  std::vector<PixelSpan> spans;  // What `geometry` was computed for.
  std::shared_ptr<const Geometry> geometry;
};

std::shared_ptr<GeometryCache> NewGeometryCache() { return std::make_shared<GeometryCache>(); }

void ForgetGeometry(const BoundedLmProblem& problem) {
  if (!problem.geometry) return;
  std::lock_guard<std::mutex> lock(problem.geometry->mutex);
  problem.geometry->geometry.reset();
}

std::shared_ptr<const Geometry> GeometryOf(const BoundedLmProblem& problem,
                                           const std::vector<Chunk>& chunks) {
  if (!problem.geometry) {
    return std::make_shared<const Geometry>(PrepareGeometry(problem, chunks));
  }
  GeometryCache& cache = *problem.geometry;
  std::lock_guard<std::mutex> lock(cache.mutex);
  if (!cache.geometry || !SameSpans(cache.spans, problem.spans)) {
    cache.geometry = std::make_shared<const Geometry>(PrepareGeometry(problem, chunks));
    cache.spans = problem.spans;
  }
  return cache.geometry;
}

}  // namespace shadefit::fit::internal
