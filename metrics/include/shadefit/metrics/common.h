// Shared conventions of the image metrics: input checks, masks, colour conversions.
//
// Every metric compares a `reference` with a `test` image of the same size (shadefit::Image:
// interleaved float, row 0 on top). Unless a function says otherwise, inputs are linear-light
// sRGB/Rec. 709 primaries, HDR (unclamped, >= 0 expected), and only the first three channels are
// used (an alpha channel is ignored).
//
// Masks: an optional single-channel image of the same size; a pixel is valid where mask > 0.5.
// Point-wise statistics average over valid pixels; windowed metrics (SSIM, FLIP) filter the
// whole image and then pool over valid pixels (SSIM: over the mask eroded by its window).
#pragma once

#include <string>

#include "shadefit/render/image.h"

namespace shadefit::metrics {

// Names used in error messages (shadefit::Error's "file" part). The CLI passes the file paths.
struct InputNames {
  std::string reference = "reference";  // Reference image.
  std::string test = "test";            // Test image.
  std::string mask = "mask";            // Optional mask.
};

// Throws shadefit::Error naming the file and field when: an image is empty; channel counts
// differ or are below `min_channels` (0: no requirement); sizes differ; a pixel is NaN or
// infinite; the mask is not single-channel, has another size, has non-finite values, or has no
// valid pixel ("empty mask"). Inside ComputeMetrics, which checks its own inputs so, the metrics
// it calls on windows and clipped encodings of them skip the value scans (metrics/src/internal.h,
// CheckedInputs); called on their own, they make them.
void ValidateInputs(const Image& reference, const Image& test, const Image* mask,
                    int min_channels, const InputNames& names = {});

// Threads each metric call may use for its row loops (0, the default: one per CPU, at most 16).
// A caller that already runs one metric call per core, like the study runner's workers, sets 1:
// threads started per filter pass then only wait for the cores. Process-wide; results do not
// depend on it (rows are split, never reductions).
void SetMetricsThreads(int threads);
int MetricsThreads();  // The number in effect, >= 1.

// Number of valid pixels (mask > 0.5); the pixel count when mask is null.
std::size_t CountValidPixels(const Image* mask, int width, int height);

// Linear luminance Y of linear Rec. 709 RGB (first three channels): 0.2126 R + 0.7152 G +
// 0.0722 B (ITU-R BT.709-6, the Y row of the sRGB to XYZ matrix). One-channel result.
Image Luminance(const Image& linear_rgb);

// The display transform used by PSNR, SSIM, MS-SSIM and LDR-FLIP inputs: scale by
// 2^exposure_stops, sRGB OETF (IEC 61966-2-1), clip to [0, 1]. Works on every channel of the
// input (pass Luminance(image) for an encoded luminance image). Output is display-encoded.
Image DisplayEncode(const Image& linear, float exposure_stops);

// Linear display-referred copy: scale by 2^exposure_stops, clip to [0, 1], keep first three
// channels. Input of CIEDE2000 and LDR-FLIP (which apply their own colour transforms).
Image ExposeAndClip(const Image& linear_rgb, float exposure_stops);

}  // namespace shadefit::metrics
