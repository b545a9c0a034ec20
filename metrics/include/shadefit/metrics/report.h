// All metrics between two images in one call, their JSON form and their map files.
// Every field is documented in docs/metrics.md.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "shadefit/metrics/ciede2000.h"
#include "shadefit/metrics/common.h"
#include "shadefit/metrics/delta_e_itp.h"
#include "shadefit/metrics/flip.h"
#include "shadefit/metrics/ssim.h"
#include "shadefit/render/image.h"

namespace shadefit::metrics {

// Seconds ComputeMetrics spent on each family of metrics, added to (one struct sums many calls):
// for a caller's stage table (the study's timings.csv).
struct MetricsSeconds {
  double pixel = 0.0;        // RMSE, relative RMSE, log RMSE, MAE, PSNR
  double ssim = 0.0;         // SSIM (luminance and RGB) and MS-SSIM, with their display encoding
  double ciede2000 = 0.0;    // CIEDE2000
  double delta_e_itp = 0.0;  // Delta E_ITP
  double flip_ldr = 0.0;     // LDR-FLIP, with its exposure and clip
  double flip_hdr = 0.0;     // HDR-FLIP
  double maps = 0.0;         // the absolute and relative error maps
  double Total() const { return pixel + ssim + ciede2000 + delta_e_itp + flip_ldr + flip_hdr + maps; }
};

// The maps ComputeMetrics fills when given a MetricsMaps: a set of these bits.
enum MetricMap : unsigned {
  kAbsoluteErrorMap = 1u << 0,
  kRelativeErrorMap = 1u << 1,
  kSsimMap = 1u << 2,
  kCiede2000Map = 1u << 3,
  kDeltaEItpMap = 1u << 4,
  kFlipLdrMap = 1u << 5,
  kFlipHdrMap = 1u << 6,
  kAllMaps = (1u << 7) - 1,
};

namespace internal {
struct KeptInputs;  // metrics/src/kept_inputs.h
}  // namespace internal

// Per-pixel terms one ComputeMetrics call keeps (MetricsParameters::keep) for a later call
// (MetricsParameters::kept) on a part of its mask, with the same test and parameters and a
// reference equal to this call's on that part: a study's measured pass (the covered pixels less a
// shadow's edge, the reference patched outside them) after its covered pass. That call pools the
// kept terms instead of computing them where its own terms are the same numbers: CIEDE2000's and
// Delta E_ITP's at every pixel of its mask; SSIM's and MS-SSIM's at the pixels whose windows lie
// inside its mask (the only ones they pool), at every scale. The same bits, for a pass over the
// mask. A pixel the kept terms lack is an Error for the point-wise metrics; SSIM then computes.
// The keeping call's inputs also give the later call what it would derive from its own where the
// pixels are the same bits (checked): the display encodings of its test and, pixel by pixel, of
// its reference (where that is the keeping call's reference or the test), and the test's
// LDR-FLIP half and its HDR-FLIP half at an exposure both calls use.
struct KeptTerms {
  Image ciede2000, delta_e_itp;  // Frame maps, NaN outside the keeping call's mask.
  SsimTerms ssim;
  std::shared_ptr<const internal::KeptInputs> inputs;
};

struct MetricsParameters {
  // Exposure (stops) of the display transform used by PSNR, SSIM, MS-SSIM, CIEDE2000, LDR-FLIP.
  float exposure_stops = 0.0f;
  // FLIP observer pixels per degree.
  double ppd = 67.0;
  // eps of the relative error (linear units).
  float relative_epsilon = 0.01f;
  // Luminance (cd/m^2) of the linear value 1.0 for Delta E_ITP, which works on absolute
  // luminance (DeltaEItpParameters::white_luminance: an SDR display's reference white).
  double itp_white_luminance = 100.0;
  // Names used in error messages (the CLI passes file paths).
  InputNames names;
  // Optional: keeps the reference's half of CIEDE2000, Delta E_ITP, LDR- and HDR-FLIP for the
  // next call with the same reference (reference_cache.h); the results are the same without it.
  ReferenceCache* reference_cache = nullptr;
  // Which maps a MetricsMaps receives (MetricMap bits); the others stay empty and cost nothing.
  unsigned maps_wanted = kAllMaps;
  // Optional: receives this call's per-pixel terms, for a later call's `kept` (KeptTerms).
  KeptTerms* keep = nullptr;
  // Optional: an earlier call's kept terms (not read when `keep` is set); this call's CIEDE2000
  // and Delta E_ITP maps then stay empty (it computes none), and Delta E_ITP's white luminance
  // is the keeping call's.
  const KeptTerms* kept = nullptr;
  // Optional: receives the seconds spent per metric (added to).
  MetricsSeconds* seconds = nullptr;
};

struct MetricsReport {
  int width = 0;
  int height = 0;
  std::size_t valid_pixels = 0;  // Pixels inside the mask (all pixels without one).
  bool masked = false;
  float exposure_stops = 0.0f;
  double ppd = 67.0;
  float relative_epsilon = 0.01f;
  double itp_white_luminance = 100.0;
  // Linear HDR RGB.
  double rmse = 0.0;
  double relative_rmse = 0.0;
  double log_rmse = 0.0;
  double mae = 0.0;
  // Display transform.
  double psnr = 0.0;
  SsimResult ssim_luminance;
  SsimResult ssim_rgb;
  MsSsimResult ms_ssim;  // On display-encoded luminance.
  DeltaE2000Result ciede2000;
  DeltaEItpResult delta_e_itp;  // On the linear HDR images, 1.0 = itp_white_luminance cd/m^2.
  FlipResult flip_ldr;  // On the display-referred (exposed, clipped) linear images.
  FlipResult flip_hdr;  // On the linear HDR images.
};

// One-channel maps, same size as the inputs (NaN where masked out for the point-wise ones); those
// not in MetricsParameters::maps_wanted are left empty.
struct MetricsMaps {
  Image absolute_error;  // Mean over RGB of |t - r|, linear units.
  Image relative_error;  // Mean over RGB of |t - r| / (|r| + eps).
  Image ssim;            // Luminance SSIM map.
  Image ciede2000;       // Delta E_00.
  Image delta_e_itp;     // Delta E_ITP.
  Image flip_ldr;        // LDR-FLIP.
  Image flip_hdr;        // HDR-FLIP.
};

// Checks the inputs (ValidateInputs with 3 channels and p.names) and computes every metric.
// reference, test: linear HDR RGB (alpha ignored); mask: optional, single channel.
MetricsReport ComputeMetrics(const Image& reference, const Image& test, const Image* mask,
                             const MetricsParameters& p = {}, MetricsMaps* maps = nullptr);

// The report as JSON (schema "shadefit.metrics/1", fields in docs/metrics.md). Non-finite
// numbers (PSNR of identical images) are written as null.
nlohmann::json MetricsToJson(const MetricsReport& report);

// Writes abs_error.png, rel_error.png (viridis), flip_ldr.png, flip_hdr.png (magma, fixed range
// [0, 1]), ssim.png (viridis, [0, 1]), ciede2000.png and delta_e_itp.png (viridis) into an
// existing directory.
void WriteMetricMaps(const MetricsMaps& maps, const std::string& directory);

}  // namespace shadefit::metrics
