// The LDR-FLIP map's two halves and their combination (Andersson et al. 2020, Sec. 4), computed
// in flip_map.cpp; flip.cpp caches the reference's half, pools the map and runs HDR-FLIP on it.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "shadefit/metrics/flip.h"
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
// The widest filter's radius in pixels (the CSF's or the feature detectors'): a side reads its
// input within this distance of the pixels it is wanted at, clamped at the frame's edges.
double SideRadius(double ppd);
// A hash of the spans, for cache keys.
std::uint64_t HashSpans(const RowSpans& spans);

// Tone mappers as y = (c0 x^2 + c1 x + c2) / (c3 x^2 + c4 x + c5), per channel.
// ACES: Narkowicz 2015, "ACES Filmic Tone Mapping Curve", x(2.51x + 0.03) / (x(2.43x + 0.59) +
// 0.14), applied to 0.6 x (the fit includes a 0.6 pre-exposure that HDR-FLIP cancels).
constexpr std::array<float, 6> kAces = {0.6f * 0.6f * 2.51f, 0.6f * 0.03f, 0.0f,
                                        0.6f * 0.6f * 2.43f, 0.6f * 0.59f, 0.14f};

// What is done to each pixel's linear colour before its half is computed. LDR-FLIP: nothing
// (clamped to [0, 1]). HDR-FLIP (Andersson et al. 2021, Sec. 3): scaled by 2^exposure, tone
// mapped, clamped to [0, 1]; applied where the half reads, so no exposed copy of the image is made.
struct Exposure {
  bool tone_map = false;
  float scale = 1.0f;
  FlipToneMapper tone_mapper = FlipToneMapper::kAces;
};

// The planes ComputeSide works in, allocated once per thread and frame size (ThreadScratch):
// HDR-FLIP computes a half at each of up to 22 exposures, a study thousands, and a new plane is
// memory the allocator and the kernel clear first. Only the pixels a stage writes are ever read,
// so the planes are not cleared between uses.
struct SideScratch {
  std::array<Plane, 3> ycxcz;
  Plane tmp, y, cx, cz1, cz2, gray, hg, hdg, hddg, ex, ey, px, py;
  std::array<Plane, 3> lab;  // HuntLab's rows, as planes before they are interleaved.
};

// This thread's scratch planes (they grow to the largest frame the thread has seen and stay).
SideScratch& ThreadScratch();

// The reference's or the test image's half (linear RGB in the first three channels, after
// `exposure`) for an observer at `ppd` pixels per degree, valid at the pixels of `wanted`. `side`
// is resized to the frame; its pixels outside `wanted` keep what they held (0 when it was empty).
void ComputeSide(const Image& rgb, double ppd, const RowSpans& wanted, const Exposure& exposure,
                 SideScratch& scratch, FlipSide& side);
// The same into a new half (0 outside `wanted`).
FlipSide ComputeSide(const Image& rgb, double ppd, const RowSpans& wanted,
                     const Exposure& exposure = {});

// A test image's half one FLIP call keeps for a later call on the same test pixels (a study's
// measured pass after its covered pass, metrics/src/report.cpp): valid at `spans`, in the
// coordinates of its call's image.
struct KeptHalf {
  int tone_mapper = 0;  // 0: LDR-FLIP's; 1 + FlipToneMapper: an HDR-FLIP exposure's.
  float scale = 1.0f;   // The exposure's scale (1 for LDR-FLIP).
  int width = 0;        // The image's (its height: the spans' rows).
  RowSpans spans;
  FlipSide side;
};

// The halves a call keeps, and where its image lies in the frame: (x0, y0) is its (0, 0) (a
// window around a mask has its corner there).
struct FlipTestHalves {
  int x0 = 0, y0 = 0;
  double ppd = 0.0;
  std::vector<KeptHalf> halves;
};

// Where a FLIP call's images lie in the frame, and the test halves it keeps (`keep`) or takes
// (`from`: an earlier call's on test pixels that are this call's, bit for bit, over this call's
// image; the caller checks that). A half is taken when it has this call's observer, exposure and
// tone mapper and holds every pixel this call wants: the pixels of a mask are as far from a
// window's edge as the filters reach (or on the frame's edge), so a side's value there is the
// frame's (ComputeSide), whichever window it was computed in.
struct FlipReuse {
  int x0 = 0, y0 = 0;
  FlipTestHalves* keep = nullptr;
  const FlipTestHalves* from = nullptr;
};

// FlipLdr and FlipHdr (flip.h) with the test halves of `reuse`; the same numbers and maps.
FlipResult FlipLdr(const Image& reference, const Image& test, const FlipParameters& p,
                   Image* flip_map, const FlipReuse& reuse);
FlipResult FlipHdr(const Image& reference, const Image& test, const FlipParameters& p,
                   Image* flip_map, Image* exposure_map, const FlipReuse& reuse);

// The LDR-FLIP map from the two halves (Andersson et al. 2020, Sec. 4) at the pixels of `wanted`
// (0 elsewhere).
Plane CombineSides(const FlipSide& ref, const FlipSide& tst, int w, int h, const RowSpans& wanted);
// The same into `flip`, resized to the frame, written at the pixels of `wanted` only.
void CombineSides(const FlipSide& ref, const FlipSide& tst, int w, const RowSpans& wanted,
                  Plane& flip);

}  // namespace shadefit::metrics::internal
