// Point-wise error statistics between a reference and a test image.
//
// Inputs: linear HDR RGB (any channel count, equal in both images; every channel is used), same
// size, finite. Statistics average over every channel of every valid pixel (see common.h for
// masks). All return values are >= 0 except PSNR, which is +infinity for identical images.
#pragma once

#include "shadefit/render/image.h"

namespace shadefit::metrics {

struct PixelMetricParameters {
  // Optional single-channel mask, same size; a pixel is used where mask > 0.5. Null: all pixels.
  const Image* mask = nullptr;
  // eps of the relative error |t - r| / (|r| + eps), in the images' linear units. 0.01 keeps
  // near-black reference pixels from dominating (1 % of a diffuse white of 1.0).
  float relative_epsilon = 0.01f;
};

// Root-mean-square error: sqrt(mean((t - r)^2)). Units of the input.
double Rmse(const Image& reference, const Image& test, const PixelMetricParameters& p = {});

// Relative RMSE: sqrt(mean(((t - r) / (|r| + eps))^2)), eps = p.relative_epsilon. Unitless;
// 0.1 means a typical 10 % error per channel. Chosen over RMSE / mean(r) because it weights dark
// and bright regions alike, which is what a fit across an HDR range needs.
double RelativeRmse(const Image& reference, const Image& test,
                    const PixelMetricParameters& p = {});

// Log RMSE: sqrt(mean((log(1 + max(t, 0)) - log(1 + max(r, 0)))^2)), natural log. Compresses
// highlights; negative values (noise) are clamped to 0 first.
double LogRmse(const Image& reference, const Image& test, const PixelMetricParameters& p = {});

// Mean absolute error: mean(|t - r|). Units of the input.
double MeanAbsoluteError(const Image& reference, const Image& test,
                         const PixelMetricParameters& p = {});

struct PsnrParameters {
  // Exposure of the display transform, in stops: values are scaled by 2^exposure_stops.
  float exposure_stops = 0.0f;
  // Optional single-channel mask (see PixelMetricParameters::mask).
  const Image* mask = nullptr;
};

// Peak signal-to-noise ratio in dB on the display transform of common.h (exposure, sRGB OETF,
// clip to [0, 1]) with peak 1: 10 log10(1 / MSE). +infinity when MSE is 0.
double Psnr(const Image& reference, const Image& test, const PsnrParameters& p = {});

// Per-pixel error maps (one channel, same size; masked-out pixels are NaN so false-colour maps
// can show them apart). Absolute: mean over channels of |t - r|. Relative: mean over channels of
// |t - r| / (|r| + eps).
Image AbsoluteErrorMap(const Image& reference, const Image& test, const Image* mask = nullptr);
Image RelativeErrorMap(const Image& reference, const Image& test, float relative_epsilon = 0.01f,
                       const Image* mask = nullptr);

}  // namespace shadefit::metrics
