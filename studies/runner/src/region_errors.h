// Where a fit's error lies under one lighting (docs/studies.md, "Where the difference lies"):
// the measured covered pixels split into the reference's highlight, the rim seen at grazing and
// the body, and per region the fit's mean signed and absolute luminance error.
#pragma once

#include <nlohmann/json.hpp>

#include "shadefit/render/gbuffer.h"
#include "shadefit/render/image.h"

namespace shadefit::studies::internal {

// The highlight is the reference's brightest kHighlightShare of the measured covered pixels (by
// luminance, lit pixels only; ceil(share n) pixels); the rim the rest of them with n.v below kRimCosine (about 70
// degrees from the view); the body what is left.
inline constexpr double kHighlightShare = 0.05;
inline constexpr double kRimCosine = 0.35;

// {"highlight": {"signed", "abs", "ref", "pixels"}, "rim": ..., "body": ...}: over the pixels of
// `measured` (channel 0 > 0.5) in each region, the mean of fit - reference and of |fit -
// reference| in luminance (Rec. 709 Y of linear radiance), the reference's mean luminance, and
// the pixel count; a region without pixels has nulls and 0. `gbuffer` is the reference scene's
// (n and v per pixel); `ref_rgb` and `fit_rgb` are 3-channel linear radiance of one size.
nlohmann::json RegionErrors(const Image& ref_rgb, const Image& fit_rgb, const Image& measured,
                            const GBuffer& gbuffer);

}  // namespace shadefit::studies::internal
