// FLIP image difference evaluator, implemented from the papers:
//   LDR-FLIP: Andersson, Nilsson, Akenine-Moller, Oskarsson, Astrom, Fairchild 2020, "FLIP: A
//     Difference Evaluator for Alternating Images", Proc. ACM Comput. Graph. Interact. Tech. 3(2).
//   HDR-FLIP: Andersson, Nilsson, Shirley, Akenine-Moller 2021, "Visualizing Errors in Rendered
//     High Dynamic Range Images", Eurographics short papers.
// Validated against NVIDIA's reference tool (github.com/NVlabs/flip); see docs/metrics.md.
//
// The FLIP map is per pixel in [0, 1] (0: no perceived difference). It is always computed on the
// whole image (the filters see every pixel, borders are clamped to the edge); a mask selects
// the pixels the statistics pool and, for HDR-FLIP, those that set the exposure range.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "shadefit/metrics/reference_cache.h"
#include "shadefit/render/image.h"

namespace shadefit::metrics {

enum class FlipToneMapper {
  kAces,      // Narkowicz's fit of ACES, with 0.6 pre-exposure cancelled (the HDR-FLIP default).
  kReinhard,  // Reinhard's global operator on luminance, L / (1 + L).
};

struct FlipParameters {
  // Observer's pixels per degree of visual angle. 67 ~ a 0.7 m wide 4K display seen from 0.7 m
  // (the papers' default; the authors' tool uses the unrounded 67.02).
  double ppd = 67.0;
  // HDR-FLIP only: tone mapper of each exposure.
  FlipToneMapper tone_mapper = FlipToneMapper::kAces;
  // HDR-FLIP only: exposure range in stops. NaN: computed from the reference as in Andersson et
  // al. 2021, Sec. 3: start = log2(x_0.85 / Y_max), stop = log2(x_0.85 / Y_median), where x_0.85
  // is the input the tone mapper maps to 0.85 and Y is the reference's luminance.
  double start_exposure = std::numeric_limits<double>::quiet_NaN();
  double stop_exposure = std::numeric_limits<double>::quiet_NaN();
  // HDR-FLIP only: number of exposures; 0: max(2, ceil(stop - start)) as in the paper.
  int num_exposures = 0;
  // Optional single-channel mask, same size; statistics pool pixels where mask > 0.5. HDR-FLIP
  // also takes its exposure range from the masked pixels of the reference.
  const Image* mask = nullptr;
  // Optional: where the reference's half of the map (its CSF-filtered colours and its edge and
  // point features at each exposure) is kept for the next call with the same reference
  // (reference_cache.h). The result is the same with and without it.
  ReferenceCache* reference_cache = nullptr;
};

struct FlipResult {
  double mean = 0.0;             // Mean FLIP over pooled pixels (the papers' summary value).
  double median = 0.0;           // Percentiles of the per-pixel values (nearest rank).
  double p95 = 0.0;
  double p99 = 0.0;
  double max = 0.0;
  // Error-weighted percentiles of the FLIP histogram (Andersson et al. 2020, Sec. 6: each pixel
  // weighted by its own error): the value below which half (a quarter, ...) of the total error
  // mass lies.
  double weighted_median = 0.0;
  double weighted_q1 = 0.0;
  double weighted_q3 = 0.0;
  // Fraction of pooled pixels in each of 20 equal bins over [0, 1].
  std::vector<double> histogram;
  // HDR-FLIP: the exposure range used (NaN / 0 for LDR-FLIP).
  double start_exposure = std::numeric_limits<double>::quiet_NaN();
  double stop_exposure = std::numeric_limits<double>::quiet_NaN();
  int num_exposures = 0;
};

// LDR-FLIP. Inputs: linear sRGB in [0, 1] (display-referred; values outside are clamped),
// first three channels. To compare 8-bit sRGB files, decode them with SrgbToLinear first.
FlipResult FlipLdr(const Image& reference, const Image& test, const FlipParameters& p = {},
                   Image* flip_map = nullptr);

// HDR-FLIP. Inputs: linear HDR sRGB, first three channels. For each exposure c the images are
// scaled by 2^c, tone mapped, clamped to [0, 1] and compared with LDR-FLIP; the map is the
// per-pixel maximum over exposures. exposure_map, if given, receives for each pixel the index of
// its worst exposure divided by (num_exposures - 1), in [0, 1].
FlipResult FlipHdr(const Image& reference, const Image& test, const FlipParameters& p = {},
                   Image* flip_map = nullptr, Image* exposure_map = nullptr);

}  // namespace shadefit::metrics
