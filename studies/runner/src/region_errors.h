// Where a fit's error lies under one lighting (docs/studies.md, "Where the difference lies"):
// the measured covered pixels split into the reference's highlight, the rim seen at grazing and
// the body, and per region the fit's mean signed and absolute luminance error.
#pragma once

#include <nlohmann/json.hpp>
#include <vector>

#include "shadefit/render/gbuffer.h"
#include "shadefit/render/image.h"

namespace shadefit::studies::internal {

// The highlight is the reference's brightest kHighlightShare of the measured covered pixels (by
// luminance, lit pixels only; ceil(share n) pixels); the rim the rest of them with n.v below kRimCosine (about 70
// degrees from the view); the body what is left.
inline constexpr double kHighlightShare = 0.05;
inline constexpr double kRimCosine = 0.35;

// Each pixel's region, in kRegionNames' order (0 highlight, 1 rim, 2 body; -1: not in `measured`,
// channel 0 > 0.5), row by row. It depends on the reference alone (its luminance, its measured
// pixels and its scene's n and v per pixel, `gbuffer`), so one map serves every fit compared with
// that reference.
std::vector<signed char> PixelRegions(const Image& ref_rgb, const Image& measured,
                                      const GBuffer& gbuffer);

// {"highlight": {"signed", "abs", "ref", "pixels"}, "rim": ..., "body": ...}: over the pixels of
// each region of `regions` (PixelRegions of the same reference), the mean of fit - reference and
// of |fit - reference| in luminance (Rec. 709 Y of linear radiance), the reference's mean
// luminance, and the pixel count; a region without pixels has nulls and 0. `ref_rgb` and
// `fit_rgb` are 3-channel linear radiance of one size.
nlohmann::json RegionErrors(const Image& ref_rgb, const Image& fit_rgb,
                            const std::vector<signed char>& regions);

// The same with the regions found here: RegionErrors(ref_rgb, fit_rgb, PixelRegions(ref_rgb,
// measured, gbuffer)).
nlohmann::json RegionErrors(const Image& ref_rgb, const Image& fit_rgb, const Image& measured,
                            const GBuffer& gbuffer);

}  // namespace shadefit::studies::internal
