// The LDR-FLIP map's two halves and their combination (Andersson et al. 2020, Sec. 4), computed
// in flip_map.cpp; flip.cpp caches the reference's half, pools the map and runs HDR-FLIP on it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "shadefit/render/image.h"

namespace shadefit::metrics::internal {

using Plane = std::vector<float>;

struct Float3 {
  float v[3];
};

// Edge and point magnitudes of the achromatic channel normalised to [0, 1], (Y + 16) / 116.
struct Features {
  Plane edge, point;
};

// One image's half of the LDR-FLIP map: its CSF-filtered Hunt-adjusted colours (Sec. 4.1) and
// its edge and point features (Sec. 4.2).
struct FlipSide {
  std::vector<Float3> lab;
  Features features;
  std::size_t Bytes() const {
    return lab.size() * sizeof(Float3) +
           (features.edge.size() + features.point.size()) * sizeof(float);
  }
};

// The pixels a FLIP map is wanted at: one [begin, end) column range per row (begin == end: none).
// Every stage of a side computes only what those pixels read (the filters' supports), with the
// same arithmetic per pixel as over the whole frame, so the wanted pixels get the same bits.
struct RowSpans {
  std::vector<int> begin, end;
};

// Every pixel of a w x h frame.
RowSpans FullSpans(int w, int h);
// Per row, the columns from the first to the last pixel `mask` keeps (internal::IsValid); every
// pixel without a mask.
RowSpans MaskSpans(const Image* mask, int w, int h);
// A hash of the spans, for cache keys.
std::uint64_t HashSpans(const RowSpans& spans);

// The reference's or the test image's half (linear RGB in the first three channels, clamped to
// [0, 1]) for an observer at `ppd` pixels per degree, valid at the pixels of `wanted` (0
// elsewhere).
FlipSide ComputeSide(const Image& rgb, double ppd, const RowSpans& wanted);

// The LDR-FLIP map from the two halves (Andersson et al. 2020, Sec. 4) at the pixels of `wanted`
// (0 elsewhere).
Plane CombineSides(const FlipSide& ref, const FlipSide& tst, int w, int h, const RowSpans& wanted);

}  // namespace shadefit::metrics::internal
