// The image metrics a fit job records per lighting, by their names in the job JSON and the
// columns of results.csv (docs/studies.md, "Outputs"): one list, read by the writer of
// results.csv and by the study loader's check of [verdicts] judging.
#pragma once

#include <string>
#include <vector>

namespace shadefit::studies::internal {

inline const std::vector<std::string> kMetricColumns = {
    "rmse", "relative_rmse", "log_rmse", "mae", "psnr", "ssim", "ms_ssim", "ciede2000_mean",
    "flip_ldr_mean", "flip_hdr_mean", "delta_e_itp_mean"};

// The image regions a fit's error is split into per lighting (docs/studies.md, "Where the
// difference lies"): the reference's brightest 5% of covered measured pixels, the rim
// (n.v < 0.35) and the rest.
inline const std::vector<std::string> kRegionNames = {"highlight", "rim", "body"};
// Per region: mean signed and absolute luminance error, the reference's mean, the pixel count
// (region_errors.h); results.csv's columns region_<name>_<column>.
inline const std::vector<std::string> kRegionColumns = {"signed", "abs", "ref", "pixels"};

}  // namespace shadefit::studies::internal
