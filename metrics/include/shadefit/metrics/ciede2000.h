// CIEDE2000 colour difference (CIE 142-2001), implemented after Sharma, Wu, Dalal 2005, "The
// CIEDE2000 Color-Difference Formula: Implementation Notes, Supplementary Test Data, and
// Mathematical Observations", Color Research & Application 30(1), Eqs. 1-22.
#pragma once

#include "shadefit/metrics/reference_cache.h"
#include "shadefit/render/image.h"

namespace shadefit::metrics {

// CIE 1976 L*a*b* coordinates (L* in [0, 100] for surface colours).
struct Lab {
  double l = 0.0;
  double a = 0.0;
  double b = 0.0;
};

struct Ciede2000Parameters {
  // Parametric weighting factors kL, kC, kH (Sharma et al. Eq. 22); 1 for reference conditions.
  double k_l = 1.0;
  double k_c = 1.0;
  double k_h = 1.0;
};

// Delta E_00 between two L*a*b* colours. Symmetric; 0 for equal colours.
double Ciede2000(const Lab& reference, const Lab& test, const Ciede2000Parameters& p = {});

// Linear sRGB (Rec. 709 primaries, D65) -> CIE XYZ (IEC 61966-2-1 matrix) -> CIELAB with the D65
// white of the same matrix (RGB 1, 1, 1 -> L* 100, a* = b* = 0).
Lab LinearSrgbToLab(double r, double g, double b);

struct DeltaE2000Parameters {
  // Exposure in stops applied before conversion; values are then clipped to [0, 1] so that 1.0
  // is the diffuse white L* = 100 (CIELAB is defined for display-referred colours).
  float exposure_stops = 0.0f;
  // kL, kC, kH.
  Ciede2000Parameters weights;
  // Optional single-channel mask, same size; valid where > 0.5.
  const Image* mask = nullptr;
  // Optional: where the reference's CIELAB is kept for the next call with the same reference
  // (reference_cache.h). The result is the same with and without it.
  ReferenceCache* reference_cache = nullptr;
};

struct DeltaE2000Result {
  double mean = 0.0;  // Mean Delta E_00 over valid pixels.
  double p95 = 0.0;   // 95th percentile (nearest rank) over valid pixels.
  double max = 0.0;   // Maximum over valid pixels.
};

// Per-pixel Delta E_00 between two linear sRGB images (first three channels). error_map, if
// given, receives the one-channel Delta E_00 map (masked-out pixels are NaN).
DeltaE2000Result DeltaE2000(const Image& reference, const Image& test,
                            const DeltaE2000Parameters& p = {}, Image* error_map = nullptr);

}  // namespace shadefit::metrics
