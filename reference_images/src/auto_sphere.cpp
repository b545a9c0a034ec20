// Sphere and light estimation for imported pictures of a single sphere (see import.h for the
// assumptions; docs/measured_and_imported.md for their consequences).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "shadefit/refs/import.h"
#include "shadefit/render/error.h"

namespace shadefit::refs {
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

}  // namespace

SphereEstimate DetectSphere(const Image& linear, double white, const std::string& path) {
  const int w = linear.width, h = linear.height;
  // 8-bit display-referred luminance for thresholding: sRGB OETF of luminance / white.
  cv::Mat gray(h, w, CV_8U);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double v = std::clamp(Luminance(linear, x, y) / white, 0.0, 1.0);
      gray.at<unsigned char>(y, x) =
          static_cast<unsigned char>(std::lround(SrgbOetf(static_cast<float>(v)) * 255.0));
    }
  }
  // Otsu (1979) separates "dark" from "bright"; on a lit sphere that split can fall between the
  // shadowed and the lit side, so half of it (at least 4 codes above black) is used, which only
  // assumes the background is darker than the lit sphere.
  cv::Mat binary;
  const double otsu = cv::threshold(gray, binary, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  const double level = std::max(4.0, 0.5 * otsu);
  cv::threshold(gray, binary, level, 255, cv::THRESH_BINARY);
  // Remove isolated specks (sensor noise, dust) before looking for the largest region.
  cv::morphologyEx(binary, binary, cv::MORPH_OPEN,
                   cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(3, 3)));
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(binary, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  if (contours.empty()) {
    throw Error(path, "auto-sphere", "no region brighter than the background was found");
  }
  const auto largest = std::max_element(
      contours.begin(), contours.end(),
      [](const auto& a, const auto& b) { return cv::contourArea(a) < cv::contourArea(b); });
  if (largest->size() < 16 || cv::contourArea(*largest) < 50.0) {
    throw Error(path, "auto-sphere", "the largest bright region is too small to be a sphere");
  }
  // Contour points are pixel indices; our pixel centres are at +0.5.
  std::vector<cv::Point2d> pts;
  for (const cv::Point& p : *largest) pts.emplace_back(p.x + 0.5, p.y + 0.5);
  cv::Point2f c0;
  float r0;
  cv::minEnclosingCircle(*largest, c0, r0);
  double cx = c0.x + 0.5, cy = c0.y + 0.5, r = r0;
  // Refine on the well-lit silhouette only: points within a band of the current circle (the
  // terminator, inside the disc, falls outside it) whose inside, 3 px inwards, is at least twice
  // the threshold (where the limb is dim, the threshold crossing creeps inwards and would pull
  // the circle towards the light).
  auto strong_edge = [&](const cv::Point2d& p, double ccx, double ccy) {
    const double d = std::hypot(p.x - ccx, p.y - ccy);
    if (d < 1e-9) return false;
    const int x = static_cast<int>(std::floor(p.x - 3.0 * (p.x - ccx) / d));
    const int y = static_cast<int>(std::floor(p.y - 3.0 * (p.y - ccy) / d));
    if (x < 0 || y < 0 || x >= w || y >= h) return false;
    return gray.at<unsigned char>(y, x) >= 2.0 * level;
  };
  // Shading can only move the threshold crossing inwards (towards the terminator), never out:
  // after two symmetric passes, points more than 0.75 px inside the fit are trimmed, so the
  // fit settles on the outer envelope of the contour, which is the silhouette.
  SphereEstimate s;
  for (int iter = 0; iter < 8; ++iter) {
    const double band_out = std::max(1.5, 0.03 * r);
    const double band_in = iter < 2 ? band_out : 0.75;
    std::vector<cv::Point2d> near;
    for (const cv::Point2d& p : pts) {
      const double e = std::hypot(p.x - cx, p.y - cy) - r;
      if (e < band_out && e > -band_in && strong_edge(p, cx, cy)) near.push_back(p);
    }
    double ncx, ncy, nr;
    if (!FitCircle(near, &ncx, &ncy, &nr)) break;
    cx = ncx;
    cy = ncy;
    r = nr;
    s.contour_points_used = static_cast<int>(near.size());
    double sq = 0;
    for (const cv::Point2d& p : near) sq += std::pow(std::hypot(p.x - cx, p.y - cy) - r, 2);
    s.fit_rms_px = std::sqrt(sq / near.size());
  }
  // Boundary pixel centres lie about half a pixel inside the true edge.
  r += 0.5;
  if (r < 4.0) throw Error(path, "auto-sphere", fmt::format("radius {:.2f} px is too small", r));
  s.center_x = cx;
  s.center_y = cy;
  s.radius = r;

  // Highlight: connected pixels within 90% of the peak luminance inside the disc (a clipped
  // highlight is a plateau; its centroid is its centre).
  double peak = 0;
  cv::Point peak_at(-1, -1);
  cv::Mat inside = cv::Mat::zeros(h, w, CV_8U);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (std::hypot(x + 0.5 - cx, y + 0.5 - cy) > 0.97 * r) continue;
      inside.at<unsigned char>(y, x) = 1;
      const double l = Luminance(linear, x, y);
      if (l > peak) {
        peak = l;
        peak_at = {x, y};
      }
    }
  }
  if (peak <= 0 || peak_at.x < 0) return s;
  cv::Mat bright = cv::Mat::zeros(h, w, CV_8U);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (inside.at<unsigned char>(y, x) && Luminance(linear, x, y) >= 0.9 * peak) {
        bright.at<unsigned char>(y, x) = 255;
      }
    }
  }
  cv::Mat labels;
  cv::connectedComponents(bright, labels, 8, CV_32S);
  const int label = labels.at<int>(peak_at.y, peak_at.x);
  double sx = 0, sy = 0, count = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (labels.at<int>(y, x) == label) {
        sx += x + 0.5;
        sy += y + 0.5;
        count += 1;
      }
    }
  }
  s.highlight_x = sx / count;
  s.highlight_y = sy / count;
  // Scene of OrthographicSphereSceneToml: camera on -Y looking at +Y, image right = +X, image up
  // = +Z, unit sphere; the view direction (to the eye) is -Y everywhere.
  const double nx = (s.highlight_x - cx) / r, nz = (cy - s.highlight_y) / r;
  const double ny = -std::sqrt(std::max(0.0, 1.0 - nx * nx - nz * nz));
  s.normal_at_highlight = Normalize(Vec3d{nx, ny, nz});
  const Vec3d v{0, -1, 0};
  const Vec3d& n = s.normal_at_highlight;
  s.light_direction = Normalize(n * (2.0 * Dot(n, v)) - v);  // mirror of v about n
  s.light_found = true;
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

}  // namespace shadefit::refs
