// The image metrics a fit job records per lighting, by their names in the job JSON and the
// columns of results.csv (docs/studies.md, "Outputs"), each with where its value lies in a
// metrics report: one list, read by the job writer, the writer of results.csv and the study
// loader's check of [verdicts] judging. report/results_csv.py's list is checked against it
// (tests/report/columns_test.py).
#pragma once

#include <string>
#include <vector>

#include "shadefit/metrics/report.h"

namespace shadefit::studies::internal {

struct MetricColumn {
  std::string name;
  double (*value)(const metrics::MetricsReport&);
};

using Report = metrics::MetricsReport;
inline const std::vector<MetricColumn> kMetrics = {
    {"rmse", [](const Report& m) { return m.rmse; }},
    {"relative_rmse", [](const Report& m) { return m.relative_rmse; }},
    {"log_rmse", [](const Report& m) { return m.log_rmse; }},
    {"mae", [](const Report& m) { return m.mae; }},
    {"psnr", [](const Report& m) { return m.psnr; }},
    {"ssim", [](const Report& m) { return m.ssim_rgb.mean; }},
    {"ms_ssim", [](const Report& m) { return m.ms_ssim.value; }},
    {"ciede2000_mean", [](const Report& m) { return m.ciede2000.mean; }},
    {"flip_ldr_mean", [](const Report& m) { return m.flip_ldr.mean; }},
    {"flip_hdr_mean", [](const Report& m) { return m.flip_hdr.mean; }},
    {"delta_e_itp_mean", [](const Report& m) { return m.delta_e_itp.mean; }},
};

// kMetrics' names, in its order.
inline const std::vector<std::string> kMetricColumns = [] {
  std::vector<std::string> names;
  for (const MetricColumn& c : kMetrics) names.push_back(c.name);
  return names;
}();

// The image regions a fit's error is split into per lighting (docs/studies.md, "Where the
// difference lies"): the reference's brightest 5% of covered measured pixels, the rim
// (n.v < 0.35) and the rest.
inline const std::vector<std::string> kRegionNames = {"highlight", "rim", "body"};
// Per region: mean signed and absolute luminance error, the reference's mean, the pixel count
// (region_errors.h); results.csv's columns region_<name>_<column>.
inline const std::vector<std::string> kRegionColumns = {"signed", "abs", "ref", "pixels"};

}  // namespace shadefit::studies::internal
