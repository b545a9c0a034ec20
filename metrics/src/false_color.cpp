#include "shadefit/metrics/false_color.h"

#include <cmath>
#include <cstdio>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "colormap_tables.h"
#include "internal.h"

namespace shadefit::metrics {
namespace {

const std::array<std::array<float, 3>, 256>& Table(ColorMap map) {
  return map == ColorMap::kMagma ? internal::kMagmaTable : internal::kViridisTable;
}

std::string Label(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.3g", v);
  return buffer;
}

}  // namespace

Image FalseColor(const Image& scalar_map, const FalseColorParameters& p) {
  const int w = scalar_map.width, h = scalar_map.height;
  // Range: given, or the finite min / max of the map (min 0 for non-negative maps).
  double lo = p.min, hi = p.max;
  if (std::isnan(lo) || std::isnan(hi)) {
    double found_lo = 0.0, found_hi = 0.0;
    bool any = false;
    for (float v : scalar_map.data) {
      if (!std::isfinite(v)) continue;
      found_lo = any ? std::min<double>(found_lo, v) : v;
      found_hi = any ? std::max<double>(found_hi, v) : v;
      any = true;
    }
    if (std::isnan(lo)) lo = std::min(0.0, found_lo);
    if (std::isnan(hi)) hi = found_hi;
  }
  if (!(hi > lo)) hi = lo + 1.0;  // Constant map: everything at the low end.
  const auto& table = Table(p.color_map);
  const auto lookup = [&](double v) -> const std::array<float, 3>& {
    const double t = std::clamp((v - lo) / (hi - lo), 0.0, 1.0);
    return table[static_cast<int>(std::lround(255.0 * t))];
  };

  // Colour-bar strip: gap, bar, gap, labels.
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  const double font_scale = 0.35;
  const std::string hi_label = Label(hi), lo_label = Label(lo);
  int baseline = 0;
  const cv::Size hi_size = cv::getTextSize(hi_label, font, font_scale, 1, &baseline);
  const cv::Size lo_size = cv::getTextSize(lo_label, font, font_scale, 1, &baseline);
  const int gap = 4, bar = 12;
  const int strip =
      p.color_bar ? gap + bar + gap + std::max(hi_size.width, lo_size.width) + gap : 0;

  cv::Mat canvas(h, w + strip, CV_32FC3, cv::Scalar(0, 0, 0));  // RGB order.
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const float v = scalar_map.at(x, y, 0);
      cv::Vec3f& out = canvas.at<cv::Vec3f>(y, x);
      if (!std::isfinite(v)) {
        out = cv::Vec3f(p.nan_gray, p.nan_gray, p.nan_gray);
        continue;
      }
      const auto& c = lookup(v);
      out = cv::Vec3f(c[0], c[1], c[2]);
    }
  }
  if (p.color_bar) {
    // Gradient: max at the top row, min at the bottom row.
    for (int y = 0; y < h; ++y) {
      const double t = h > 1 ? 1.0 - static_cast<double>(y) / (h - 1) : 1.0;
      const auto& c = table[static_cast<int>(std::lround(255.0 * t))];
      for (int x = w + gap; x < w + gap + bar; ++x) {
        canvas.at<cv::Vec3f>(y, x) = cv::Vec3f(c[0], c[1], c[2]);
      }
    }
    const int text_x = w + gap + bar + gap;
    cv::putText(canvas, hi_label, cv::Point(text_x, std::min(h - 1, hi_size.height + 1)), font,
                font_scale, cv::Scalar(1, 1, 1), 1, cv::LINE_AA);
    cv::putText(canvas, lo_label, cv::Point(text_x, h - 2), font, font_scale,
                cv::Scalar(1, 1, 1), 1, cv::LINE_AA);
  }
  Image out(w + strip, h, 3);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w + strip; ++x) {
      const cv::Vec3f& c = canvas.at<cv::Vec3f>(y, x);
      for (int k = 0; k < 3; ++k) out.at(x, y, k) = c[k];
    }
  }
  return out;
}

void WriteFalseColorPng(const std::string& path, const Image& scalar_map,
                        const FalseColorParameters& p) {
  WritePng8(path, FalseColor(scalar_map, p));
}

}  // namespace shadefit::metrics
