#include "region_errors.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>
#include <vector>

#include "metric_columns.h"

namespace shadefit::studies::internal {
namespace {

double Luminance(const Image& im, int x, int y) {
  return 0.2126 * im.at(x, y, 0) + 0.7152 * im.at(x, y, 1) + 0.0722 * im.at(x, y, 2);
}

struct Sums {
  double signed_sum = 0, abs_sum = 0, ref_sum = 0;
  long pixels = 0;
};

}  // namespace

std::vector<signed char> PixelRegions(const Image& ref_rgb, const Image& measured,
                                      const GBuffer& gbuffer) {
  // The highlight: the ceil(share n) brightest of the n lit measured pixels (ties broken by
  // scan order, so that a flat reference still gets exactly that many).
  std::vector<std::pair<double, int>> lit;  // (-luminance, pixel index): brightest first.
  for (int y = 0; y < measured.height; ++y) {
    for (int x = 0; x < measured.width; ++x) {
      const double l = Luminance(ref_rgb, x, y);
      if (measured.at(x, y, 0) > 0.5f && l > 0) lit.emplace_back(-l, y * measured.width + x);
    }
  }
  const auto count = static_cast<std::size_t>(std::ceil(kHighlightShare * lit.size()));
  std::partial_sort(lit.begin(), lit.begin() + count, lit.end());
  std::vector<signed char> regions(static_cast<std::size_t>(measured.width) * measured.height, -1);
  for (int y = 0; y < measured.height; ++y) {
    for (int x = 0; x < measured.width; ++x) {
      if (!(measured.at(x, y, 0) > 0.5f)) continue;
      double cos_nv = 1;
      if (gbuffer.Hit(x, y)) {
        cos_nv = 0;
        for (int c = 0; c < 3; ++c) cos_nv += gbuffer.normal.at(x, y, c) * gbuffer.view.at(x, y, c);
      }
      regions[y * measured.width + x] = cos_nv < kRimCosine ? 1 : 2;
    }
  }
  for (std::size_t i = 0; i < count; ++i) regions[lit[i].second] = 0;
  return regions;
}

nlohmann::json RegionErrors(const Image& ref_rgb, const Image& fit_rgb,
                            const std::vector<signed char>& regions) {
  std::array<Sums, 3> sums;  // In kRegionNames' order: highlight, rim, body.
  for (int y = 0; y < ref_rgb.height; ++y) {
    for (int x = 0; x < ref_rgb.width; ++x) {
      const int region = regions[static_cast<std::size_t>(y) * ref_rgb.width + x];
      if (region < 0) continue;
      const double ref = Luminance(ref_rgb, x, y);
      const double d = Luminance(fit_rgb, x, y) - ref;
      Sums& s = sums[region];
      s.signed_sum += d;
      s.abs_sum += std::abs(d);
      s.ref_sum += ref;
      ++s.pixels;
    }
  }
  nlohmann::json out = nlohmann::json::object();
  for (std::size_t i = 0; i < sums.size(); ++i) {
    const Sums& s = sums[i];
    const auto mean = [&](double v) {
      return s.pixels > 0 ? nlohmann::json(v / s.pixels) : nlohmann::json(nullptr);
    };
    out[kRegionNames[i]] = {{"signed", mean(s.signed_sum)},
                            {"abs", mean(s.abs_sum)},
                            {"ref", mean(s.ref_sum)},
                            {"pixels", s.pixels}};
  }
  return out;
}

nlohmann::json RegionErrors(const Image& ref_rgb, const Image& fit_rgb, const Image& measured,
                            const GBuffer& gbuffer) {
  return RegionErrors(ref_rgb, fit_rgb, PixelRegions(ref_rgb, measured, gbuffer));
}

}  // namespace shadefit::studies::internal
