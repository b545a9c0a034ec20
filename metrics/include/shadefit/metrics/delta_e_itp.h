// Delta E_ITP colour difference, ITU-R BT.2124-0 (2019), "Objective metric for the assessment of
// the potential visibility of colour differences in television", on the ICtCp space of ITU-R
// BT.2100-2 (Table 6 and 7) with the PQ transfer function of SMPTE ST 2084:2014.
//
// Unlike CIELAB it is defined on absolute luminance (cd/m^2) up to 10000 cd/m^2, so it compares
// HDR renders without clipping them to a display; the price is that a render's values must be
// given a luminance (DeltaEItpParameters::white_luminance).
#pragma once

#include "shadefit/metrics/reference_cache.h"
#include "shadefit/render/image.h"

namespace shadefit::metrics {

// BT.2100 ICtCp coordinates (PQ): I in [0, 1], Ct and Cp roughly in [-0.5, 0.5].
struct Ictcp {
  double i = 0.0;
  double ct = 0.0;
  double cp = 0.0;
};

// SMPTE ST 2084 inverse EOTF: absolute luminance in cd/m^2 (clamped to [0, 10000]) -> PQ
// signal in [0, 1].
double PqInverseEotf(double luminance_cd_m2);

// Linear Rec. 709 RGB in cd/m^2 -> Rec. 2020 RGB (ITU-R BT.2087-0, eq. 4) -> LMS -> PQ ->
// ICtCp (BT.2100-2, Tables 6 and 7). Negative components are clamped to 0 before PQ.
Ictcp Rec709LuminanceToIctcp(double r, double g, double b);

// BT.2124 eq. 1: 720 sqrt(dI^2 + dT^2 + dP^2) with T = 0.5 Ct, P = Cp. 1 ~ a just noticeable
// difference in the standard's viewing conditions. Symmetric; 0 for equal colours.
double DeltaItp(const Ictcp& reference, const Ictcp& test);

struct DeltaEItpParameters {
  // Luminance in cd/m^2 of the value 1.0 of the linear renders. The display transform of the
  // other metrics (exposure 0) shows 1.0 as the display's white, and an SDR display's reference
  // white is 100 cd/m^2 (ITU-R BT.2035, EBU Tech 3320): 1.0 -> 100 cd/m^2 keeps a diffuse white
  // where a viewer of the LDR renders saw it, while values above 1.0 (highlights) keep their HDR
  // luminance up to PQ's end at 10000 cd/m^2 (100.0). BT.2408's HDR graphics white would be 203.
  double white_luminance = 100.0;
  // Optional single-channel mask, same size; valid where > 0.5.
  const Image* mask = nullptr;
  // Optional: where the reference's ICtCp is kept for the next call with the same reference
  // (reference_cache.h). The result is the same with and without it.
  ReferenceCache* reference_cache = nullptr;
};

struct DeltaEItpResult {
  double mean = 0.0;  // Mean Delta E_ITP over valid pixels.
  double p95 = 0.0;   // 95th percentile (nearest rank) over valid pixels.
  double max = 0.0;   // Maximum over valid pixels.
};

// Per-pixel Delta E_ITP between two linear HDR Rec. 709 images (first three channels, relative
// units scaled by p.white_luminance). error_map, if given, receives the one-channel map
// (masked-out pixels are NaN).
DeltaEItpResult DeltaEItp(const Image& reference, const Image& test,
                          const DeltaEItpParameters& p = {}, Image* error_map = nullptr);

}  // namespace shadefit::metrics
