// Sphere and light estimation for imported pictures of a single sphere (see import.h for the
// assumptions; docs/measured_and_imported.md for their consequences).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "shadefit/reference_images/import.h"
#include "shadefit/base/error.h"
#include "shadefit/base/statistics.h"

namespace shadefit::reference_images {
namespace {

double Luminance(const Image& img, int x, int y) {
  // Rec. 709 luminance weights (linear RGB).
  return 0.2126 * img.at(x, y, 0) + 0.7152 * img.at(x, y, 1) + 0.0722 * img.at(x, y, 2);
}

// Algebraic circle fit (Kasa 1976, "A circle fitting procedure and its error analysis"): least
// squares on x^2 + y^2 + D x + E y + F = 0. Returns false for a degenerate point set.
bool FitCircle(const std::vector<cv::Point2d>& pts, double* cx, double* cy, double* r) {
  if (pts.size() < 8) return false;
  cv::Mat a(static_cast<int>(pts.size()), 3, CV_64F), b(static_cast<int>(pts.size()), 1, CV_64F);
  for (int i = 0; i < static_cast<int>(pts.size()); ++i) {
    a.at<double>(i, 0) = pts[i].x;
    a.at<double>(i, 1) = pts[i].y;
    a.at<double>(i, 2) = 1.0;
    b.at<double>(i, 0) = -(pts[i].x * pts[i].x + pts[i].y * pts[i].y);
  }
  cv::Mat s;
  if (!cv::solve(a, b, s, cv::DECOMP_SVD)) return false;
  *cx = -0.5 * s.at<double>(0);
  *cy = -0.5 * s.at<double>(1);
  const double r2 = *cx * *cx + *cy * *cy - s.at<double>(2);
  if (!(r2 > 0)) return false;
  *r = std::sqrt(r2);
  return true;
}


// 8-bit display-referred luminance for thresholding: sRGB OETF of luminance / white.
cv::Mat DisplayGray(const Image& linear, double white) {
  cv::Mat gray(linear.height, linear.width, CV_8U);
  for (int y = 0; y < linear.height; ++y) {
    for (int x = 0; x < linear.width; ++x) {
      const double v = std::clamp(Luminance(linear, x, y) / white, 0.0, 1.0);
      gray.at<unsigned char>(y, x) =
          static_cast<unsigned char>(std::lround(SrgbOetf(static_cast<float>(v)) * 255.0));
    }
  }
  return gray;
}

std::vector<cv::Point> LargestContour(const cv::Mat& binary) {
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(binary, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  if (contours.empty()) return {};
  return *std::max_element(
      contours.begin(), contours.end(),
      [](const auto& a, const auto& b) { return cv::contourArea(a) < cv::contourArea(b); });
}

double EnclosingRadius(const std::vector<cv::Point>& contour) {
  if (contour.empty()) return 0;
  cv::Point2f c;
  float r;
  cv::minEnclosingCircle(contour, c, r);
  return r;
}

// A circle through a region's outline: minimum enclosing circle, then Kasa fits to the outline
// points near the current circle that pass `keep`. Anything that is not the silhouette (a
// terminator, a masked-out stand, a reflection as dark as the background) lies inside the
// circle, never outside: after two symmetric passes, points more than 0.75 px inside the fit
// are trimmed, so the fit settles on the outer envelope of the outline, which is the silhouette.
template <typename Keep>
void FitOuterCircle(const std::vector<cv::Point>& contour, Keep keep, SphereEstimate* s) {
  std::vector<cv::Point2d> pts;  // Contour points are pixel indices; our centres are at +0.5.
  for (const cv::Point& p : contour) pts.emplace_back(p.x + 0.5, p.y + 0.5);
  cv::Point2f c0;
  float r0;
  cv::minEnclosingCircle(contour, c0, r0);
  double cx = c0.x + 0.5, cy = c0.y + 0.5, r = r0;
  for (int iter = 0; iter < 8; ++iter) {
    const double band_out = std::max(1.5, 0.03 * r);
    const double band_in = iter < 2 ? band_out : 0.75;
    std::vector<cv::Point2d> near;
    for (const cv::Point2d& p : pts) {
      const double e = std::hypot(p.x - cx, p.y - cy) - r;
      if (e < band_out && e > -band_in && keep(p, cx, cy)) near.push_back(p);
    }
    double ncx, ncy, nr;
    if (!FitCircle(near, &ncx, &ncy, &nr)) break;
    cx = ncx;
    cy = ncy;
    r = nr;
    s->contour_points_used = static_cast<int>(near.size());
    double sq = 0;
    for (const cv::Point2d& p : near) sq += std::pow(std::hypot(p.x - cx, p.y - cy) - r, 2);
    s->fit_rms_px = std::sqrt(sq / near.size());
  }
  // Boundary pixel centres lie about half a pixel inside the true edge.
  s->center_x = cx;
  s->center_y = cy;
  s->radius = r + 0.5;
}

// The region that differs from the background: the background level is the median of the
// picture's 2-px border, its noise 1.4826 x the median absolute deviation there (a robust
// standard deviation); a pixel differs when it is more than max(3 codes, 4 sigma) away, darker
// or brighter. This finds a dark mirror ball in a dim room, whose only bright part is its
// highlight, as well as a bright ball: the ball is the largest region after an opening (specks)
// and a closing (which joins the highlight to the ball around it). That first region reaches
// into every edge pixel the ball covers a little; the second pass thresholds linear luminance
// halfway between the background and the ball's median, where a pixel half covered by the ball
// lies, so that the outline sits on the silhouette (as FitOuterCircle's half-pixel assumes).
std::vector<cv::Point> ContrastRegion(const cv::Mat& gray, const Image& linear, double white) {
  const int w = gray.cols, h = gray.rows;
  std::vector<int> border;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (x < 2 || y < 2 || x >= w - 2 || y >= h - 2) {
        border.push_back(gray.at<unsigned char>(y, x));
      }
    }
  }
  auto median = [](std::vector<int> v) { return static_cast<double>(Percentile(v, 0.5)); };
  const double level = median(border);
  std::vector<int> dev;
  for (int v : border) dev.push_back(static_cast<int>(std::lround(std::abs(v - level))));
  const double sigma = 1.4826 * median(dev);
  const double t = std::max(3.0, 4.0 * sigma);
  auto region_of = [&](auto differs) {
    cv::Mat binary(h, w, CV_8U);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) binary.at<unsigned char>(y, x) = differs(x, y) ? 255 : 0;
    }
    cv::morphologyEx(binary, binary, cv::MORPH_OPEN,
                     cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(3, 3)));
    cv::morphologyEx(binary, binary, cv::MORPH_CLOSE,
                     cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(7, 7)));
    return LargestContour(binary);
  };
  const std::vector<cv::Point> first = region_of(
      [&](int x, int y) { return std::abs(gray.at<unsigned char>(y, x) - level) > t; });
  if (first.size() < 16) return first;
  // The ball's level: median code inside the first region.
  cv::Mat filled = cv::Mat::zeros(h, w, CV_8U);
  cv::drawContours(filled, std::vector<std::vector<cv::Point>>{first}, 0, 255, cv::FILLED);
  std::vector<int> inside;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (filled.at<unsigned char>(y, x)) inside.push_back(gray.at<unsigned char>(y, x));
    }
  }
  const double bg = SrgbToLinear(static_cast<float>(level / 255.0));
  const double ball = SrgbToLinear(static_cast<float>(median(inside) / 255.0));
  const double half = 0.5 * std::abs(ball - bg);
  if (!(half > 0)) return first;
  return region_of([&](int x, int y) {
    // Away from the background by half the ball's contrast, on the ball's side or beyond it
    // (the highlight), within a band of the first region (nothing new far from it).
    const double l = Luminance(linear, x, y) / white;
    return filled.at<unsigned char>(y, x) || std::abs(gray.at<unsigned char>(y, x) - level) > t
               ? std::abs(l - bg) > half
               : false;
  });
}

// The highlight on the disc (and the mask, when given): the connected pixels with at least
// `fraction` of the peak luminance, their centroid weighted by luminance minus that threshold,
// and the light as the mirror direction of the view about the normal there.
void FindHighlight(const Image& linear, const cv::Mat& gray, const Image* mask, double fraction,
                   SphereEstimate* s) {
  const int w = linear.width, h = linear.height;
  const double cx = s->center_x, cy = s->center_y, r = s->radius;
  double peak = 0;
  cv::Point peak_at(-1, -1);
  cv::Mat inside = cv::Mat::zeros(h, w, CV_8U);
  std::vector<int> codes;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (std::hypot(x + 0.5 - cx, y + 0.5 - cy) > 0.97 * r) continue;
      if (mask && !(mask->at(x, y, 0) > 0.5f)) continue;
      inside.at<unsigned char>(y, x) = 1;
      codes.push_back(gray.at<unsigned char>(y, x));
      const double l = Luminance(linear, x, y);
      if (l > peak) {
        peak = l;
        peak_at = {x, y};
      }
    }
  }
  if (peak <= 0 || peak_at.x < 0) return;
  s->median_code = Percentile(codes, 0.5);
  s->peak_code = gray.at<unsigned char>(peak_at.y, peak_at.x);
  const double threshold = fraction * peak;
  cv::Mat bright = cv::Mat::zeros(h, w, CV_8U);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (inside.at<unsigned char>(y, x) && Luminance(linear, x, y) >= threshold) {
        bright.at<unsigned char>(y, x) = 255;
      }
    }
  }
  cv::Mat labels;
  cv::connectedComponents(bright, labels, 8, CV_32S);
  const int label = labels.at<int>(peak_at.y, peak_at.x);
  double sx = 0, sy = 0, sw = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (labels.at<int>(y, x) != label) continue;
      // + 1e-6 peak: a pixel at the threshold still counts a little (and a flat blob evenly).
      const double wt = Luminance(linear, x, y) - threshold + 1e-6 * peak;
      s->highlight_pixels.push_back({x + 0.5, y + 0.5, wt});
      sx += wt * (x + 0.5);
      sy += wt * (y + 0.5);
      sw += wt;
    }
  }
  s->highlight_x = sx / sw;
  s->highlight_y = sy / sw;
  // Scene of OrthographicSphereSceneToml: camera on -Y looking at +Y, image right = +X, image up
  // = +Z, unit sphere; the view direction (to the eye) is -Y everywhere.
  const double nx = (s->highlight_x - cx) / r, nz = (cy - s->highlight_y) / r;
  const double ny = -std::sqrt(std::max(0.0, 1.0 - nx * nx - nz * nz));
  s->normal_at_highlight = Normalize(Vec3d{nx, ny, nz});
  const Vec3d v{0, -1, 0};
  const Vec3d& n = s->normal_at_highlight;
  s->light_direction = Normalize(n * (2.0 * Dot(n, v)) - v);  // mirror of v about n
  s->light_found = true;
}

}  // namespace

SphereEstimate DetectSphere(const Image& linear, double white, const std::string& path,
                            const Image* mask, double highlight_fraction) {
  const int w = linear.width, h = linear.height;
  const cv::Mat gray = DisplayGray(linear, white);
  const double min_radius = kMinSphereRadiusFraction * std::min(w, h);
  SphereEstimate s;
  if (mask) {
    cv::Mat binary(h, w, CV_8U);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        binary.at<unsigned char>(y, x) = mask->at(x, y, 0) > 0.5f ? 255 : 0;
      }
    }
    const std::vector<cv::Point> region = LargestContour(binary);
    if (region.size() < 16 || EnclosingRadius(region) < 4.0) {
      throw Error(path, "auto-sphere", "the mask has no region large enough to be a sphere");
    }
    s.found_by = "mask";
    FitOuterCircle(region, [](const cv::Point2d&, double, double) { return true; }, &s);
  } else {
    // Otsu (1979) separates "dark" from "bright"; on a lit sphere that split can fall between
    // the shadowed and the lit side, so half of it (at least 4 codes above black) is used, which
    // only assumes the background is darker than the lit sphere.
    cv::Mat binary;
    const double otsu = cv::threshold(gray, binary, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
    const double level = std::max(4.0, 0.5 * otsu);
    cv::threshold(gray, binary, level, 255, cv::THRESH_BINARY);
    // Remove isolated specks (sensor noise, dust) before looking for the largest region.
    cv::morphologyEx(binary, binary, cv::MORPH_OPEN,
                     cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(3, 3)));
    const std::vector<cv::Point> bright = LargestContour(binary);
    // A bright region that reaches two sides of the frame is a lit background (a dark ball in
    // a brighter room), not a sphere: the sphere must be inside the picture.
    auto reaches_two_sides = [&](const std::vector<cv::Point>& c) {
      if (c.empty()) return false;
      const cv::Rect b = cv::boundingRect(c);
      return (b.x <= 0) + (b.y <= 0) + (b.x + b.width >= w) + (b.y + b.height >= h) >= 2;
    };
    if (bright.size() >= 16 && EnclosingRadius(bright) >= min_radius &&
        !reaches_two_sides(bright)) {
      // Refine on the well-lit silhouette only: points whose inside, 3 px inwards, is at least
      // twice the threshold (where the limb is dim, the threshold crossing creeps inwards and
      // would pull the circle towards the light).
      auto strong_edge = [&](const cv::Point2d& p, double ccx, double ccy) {
        const double d = std::hypot(p.x - ccx, p.y - ccy);
        if (d < 1e-9) return false;
        const int x = static_cast<int>(std::floor(p.x - 3.0 * (p.x - ccx) / d));
        const int y = static_cast<int>(std::floor(p.y - 3.0 * (p.y - ccy) / d));
        if (x < 0 || y < 0 || x >= w || y >= h) return false;
        return gray.at<unsigned char>(y, x) >= 2.0 * level;
      };
      s.found_by = "bright region";
      FitOuterCircle(bright, strong_edge, &s);
    } else {
      // The brightest region is too small for a sphere, or is the background: a dark ball.
      const std::vector<cv::Point> region = ContrastRegion(gray, linear, white);
      if (region.size() < 16 || EnclosingRadius(region) < min_radius) {
        throw Error(path, "auto-sphere",
                    fmt::format("no region brighter than, or differing from, the background "
                                "has a radius of at least {:.1f} px ({} of the shorter side)",
                                min_radius, kMinSphereRadiusFraction));
      }
      s.found_by = "contrast with the background";
      FitOuterCircle(region, [](const cv::Point2d&, double, double) { return true; }, &s);
    }
  }
  if (s.radius < 4.0) {
    throw Error(path, "auto-sphere", fmt::format("radius {:.2f} px is too small", s.radius));
  }
  FindHighlight(linear, gray, mask, highlight_fraction, &s);
  return s;
}

std::string OrthographicSphereSceneToml(const SphereEstimate& s, int width, int height,
                                        const std::string& source_name) {
  // One world unit (the sphere's radius) is s.radius pixels. The camera is shifted so that the
  // sphere's centre lands on (center_x, center_y): world x of column px is
  // ox + (px - W/2) / r, world z of row py is oz + (H/2 - py) / r.
  const double ox = (0.5 * width - s.center_x) / s.radius;
  const double oz = (s.center_y - 0.5 * height) / s.radius;
  std::string toml = fmt::format(
      "# Written by `shadefit refs import --auto-sphere` for {}.\n"
      "# Sphere found at ({:.3f}, {:.3f}) px, radius {:.3f} px; orthographic view assumed.\n"
      "[camera]\n"
      "type = \"orthographic\"\n"
      "position = [{:.9g}, -10.0, {:.9g}]\n"
      "look_at = [{:.9g}, 0.0, {:.9g}]\n"
      "up = [0.0, 0.0, 1.0]\n"
      "height = {:.9g}\n"
      "resolution = [{}, {}]\n"
      "supersample = 4\n\n"
      "[[objects]]\n"
      "type = \"sphere\"\n"
      "center = [0.0, 0.0, 0.0]\n"
      "radius = 1.0\n",
      source_name, s.center_x, s.center_y, s.radius, ox, oz, ox, oz, height / s.radius, width,
      height);
  if (s.light_found) {
    const Vec3d& l = s.light_direction;
    toml += fmt::format(
        "\n# Initial guess: mirror direction of the view about the normal at the highlight\n"
        "# centroid ({:.2f}, {:.2f}) px. Irradiance is arbitrary (exposure unknown).\n"
        "[[lights]]\n"
        "type = \"directional\"\n"
        "direction = [{:.9g}, {:.9g}, {:.9g}]\n"
        "irradiance = 1.0\n",
        s.highlight_x, s.highlight_y, -l.x, -l.y, -l.z);
  }
  toml += "\n[background]\ntransparent = true\n";
  return toml;
}

}  // namespace shadefit::reference_images
