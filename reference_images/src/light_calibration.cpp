// Light calibration from mirror-ball photographs (light_calibration.h).
#include "shadefit/refs/light_calibration.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>

#include "shadefit/render/error.h"
#include "shadefit/render/files.h"

namespace shadefit::refs {
namespace {
namespace fs = std::filesystem;

// A mirror ball's highlight is a few pixels: its blob reaches down to a quarter of the peak so
// that the partly lit pixels around a clipped core place it to a fraction of a pixel.
constexpr double kMirrorHighlightFraction = 0.25;

// The study's naming rule (docs/studies.md): the lighting is the stem after its first '-'.
std::string LightingOf(const std::string& path) {
  const std::string stem = fs::path(path).stem().string();
  const std::size_t dash = stem.find('-');
  return dash == std::string::npos || dash + 1 == stem.size() ? stem : stem.substr(dash + 1);
}

Image ReadMask(const std::string& path) {
  if (!fs::exists(path)) throw Error(path, "mask", "file not found");
  try {
    return ReadImage(path);
  } catch (const Error& e) {
    throw Error(path, "mask", OneLine(e.what()));
  }
}

// The mirror direction of the view about the ball's normal at pixel position (px, py).
Vec3d MirrorDirectionAt(const SphereEstimate& ball, const Camera& camera, double px, double py) {
  Vec3d right, up, forward;
  camera.Basis(&right, &up, &forward);
  const Ray ray = CameraRay(camera, px, py);
  Vec3d n;
  if (camera.type == Camera::Type::kOrthographic) {
    const double nx = (px - ball.center_x) / ball.radius;
    const double nu = (ball.center_y - py) / ball.radius;
    const double nb = std::sqrt(std::max(0.0, 1.0 - nx * nx - nu * nu));
    n = Normalize(right * nx + up * nu - forward * nb);
  } else {
    // Camera at the origin, ball of radius 1: its centre C lies along the centre pixel's ray at
    // distance 1 / sin(alpha), alpha the angle between that ray and the ray through the rim.
    const Vec3d dc = CameraRay(camera, ball.center_x, ball.center_y).direction;
    const Vec3d dr = CameraRay(camera, ball.center_x + ball.radius, ball.center_y).direction;
    const double sin_alpha = std::sqrt(std::max(1e-12, 1.0 - std::pow(Dot(dc, dr), 2)));
    const Vec3d c = dc * (1.0 / sin_alpha);
    const double b = Dot(ray.direction, c);
    const double disc = b * b - (Dot(c, c) - 1.0);
    // A highlight just outside the fitted rim (disc < 0) is taken at the grazing point.
    const double t = b - std::sqrt(std::max(0.0, disc));
    n = Normalize(ray.direction * t - c);
  }
  const Vec3d v = ray.direction * -1.0;  // To the eye.
  return Normalize(n * (2.0 * Dot(n, v)) - v);
}

}  // namespace

Vec3d MirrorBallLight(const SphereEstimate& ball, const Camera& camera) {
  if (ball.highlight_pixels.empty()) {
    return MirrorDirectionAt(ball, camera, ball.highlight_x, ball.highlight_y);
  }
  // The weighted mean of the blob's mirror directions: the centroid direction of a light of
  // some extent, and immune to the ball's foreshortening, which skews a centroid taken in pixels.
  Vec3d sum{0, 0, 0};
  for (const SphereEstimate::HighlightPixel& p : ball.highlight_pixels) {
    sum = sum + MirrorDirectionAt(ball, camera, p.x, p.y) * p.weight;
  }
  return Normalize(sum);
}

std::vector<CalibratedLight> CalibrateLightsFromMirrorBall(const LightCalibrationOptions& o) {
  // --- Validate the request before reading any image.
  if (o.ball_paths.empty()) throw Error("", "ball", "no mirror-ball photograph given");
  if (o.output_dir.empty() || !fs::is_directory(o.output_dir)) {
    throw Error(o.output_dir, "output", "output directory does not exist");
  }
  if (!(o.irradiance > 0) || !std::isfinite(o.irradiance)) {
    throw Error("", "irradiance", fmt::format("{} is not a finite number > 0", o.irradiance));
  }
  if (!fs::exists(o.scene_template))
    throw Error(o.scene_template, "scene-template", "file not found");
  const Scene tmpl = LoadScene(o.scene_template);
  if (!tmpl.lights.empty()) {
    throw Error(o.scene_template, "lights",
                fmt::format("the template has {} light(s); it must have none (one directional "
                            "light per ball photograph is added)",
                            tmpl.lights.size()));
  }
  const std::string stem = fs::path(o.scene_template).stem().string();
  std::vector<CalibratedLight> out;
  std::set<std::string> lightings;
  for (const std::string& path : o.ball_paths) {
    CalibratedLight c;
    c.ball_path = path;
    c.lighting = LightingOf(path);
    if (!lightings.insert(c.lighting).second) {
      throw Error(path, "ball", fmt::format("a second photograph of lighting '{}'", c.lighting));
    }
    c.scene_path = (fs::path(o.output_dir) / (stem + "-" + c.lighting + ".toml")).string();
    out.push_back(c);
  }
  const Image mask = o.mask_path.empty() ? Image() : ReadMask(o.mask_path);

  // --- Every ball: disc, highlight, direction.
  for (CalibratedLight& c : out) {
    const LoadedImage loaded = LoadImageForImport(c.ball_path);
    const Image linear = DecodeToLinear(loaded, o.encoding, nullptr);
    if (linear.width != tmpl.camera.width || linear.height != tmpl.camera.height_px) {
      throw Error(
          c.ball_path, "resolution",
          fmt::format("image is {}x{}, the camera of {} is {}x{}", linear.width, linear.height,
                      o.scene_template, tmpl.camera.width, tmpl.camera.height_px));
    }
    if (!mask.empty() && (mask.width != linear.width || mask.height != linear.height)) {
      throw Error(o.mask_path, "resolution",
                  fmt::format("mask is {}x{}, the image {} is {}x{}", mask.width, mask.height,
                              c.ball_path, linear.width, linear.height));
    }
    c.ball = DetectSphere(linear, DisplayWhite(loaded, linear), c.ball_path,
                          mask.empty() ? nullptr : &mask, kMirrorHighlightFraction);
    if (!c.ball.light_found || c.ball.peak_code - c.ball.median_code < o.min_highlight_contrast) {
      throw Error(c.ball_path, "highlight",
                  fmt::format("no highlight on the ball: its brightest pixel (code {:.0f}) is not "
                              "{:.0f} codes above the ball's median ({:.0f})",
                              c.ball.peak_code, o.min_highlight_contrast, c.ball.median_code));
    }
    c.to_light = MirrorBallLight(c.ball, tmpl.camera);
  }

  // --- Scenes: the template's text and one directional light, checked by the scene parser.
  std::vector<std::string> texts;
  nlohmann::json summary = {{"generator", "shadefit refs lights"},
                            {"scene_template", fs::absolute(o.scene_template).string()},
                            {"method",
                             "mirror direction of the view about the ball normal at the "
                             "highlight centroid"},
                            {"lights", nlohmann::json::array()}};
  for (const CalibratedLight& c : out) {
    const SphereEstimate& b = c.ball;
    std::string text = tmpl.source_text;
    if (!text.empty() && text.back() != '\n') text += '\n';
    text += fmt::format(
        "\n# Written by `shadefit refs lights` from {}: ball at ({:.2f}, {:.2f}) px, radius "
        "{:.2f} px ({}),\n# highlight at ({:.2f}, {:.2f}) px; towards the light ({:.6f}, "
        "{:.6f}, {:.6f}).\n"
        "[[lights]]\ntype = \"directional\"\ndirection = [{:.9g}, {:.9g}, {:.9g}]\n"
        "irradiance = {:.9g}\n",
        fs::path(c.ball_path).filename().string(), b.center_x, b.center_y, b.radius, b.found_by,
        b.highlight_x, b.highlight_y, c.to_light.x, c.to_light.y, c.to_light.z, -c.to_light.x,
        -c.to_light.y, -c.to_light.z, o.irradiance);
    ParseScene(text, c.scene_path);  // Throws on anything the template got wrong.
    texts.push_back(text);
    summary["lights"].push_back({{"ball", fs::absolute(c.ball_path).string()},
                                 {"ball_sha256", Sha256File(c.ball_path)},
                                 {"lighting", c.lighting},
                                 {"scene", fs::path(c.scene_path).filename().string()},
                                 {"ball_center_px", {b.center_x, b.center_y}},
                                 {"ball_radius_px", b.radius},
                                 {"found_by", b.found_by},
                                 {"highlight_px", {b.highlight_x, b.highlight_y}},
                                 {"highlight_peak_code", b.peak_code},
                                 {"ball_median_code", b.median_code},
                                 {"to_light", {c.to_light.x, c.to_light.y, c.to_light.z}}});
  }

  // --- Write: every scene, then the summary; all of them or none (render/files.h).
  std::vector<OutputWrite> writes;
  for (std::size_t i = 0; i < out.size(); ++i) {
    writes.push_back({out[i].scene_path, [&, i] { WriteTextAtomic(out[i].scene_path, texts[i]); }});
  }
  const std::string summary_path = (fs::path(o.output_dir) / (stem + "-lights.json")).string();
  writes.push_back(
      {summary_path, [&] { WriteTextAtomic(summary_path, summary.dump(1) + "\n"); }});
  WriteAllOrNothing(writes);
  return out;
}

}  // namespace shadefit::refs
