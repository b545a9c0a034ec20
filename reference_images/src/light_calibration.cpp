// Light calibration from mirror-ball photographs (light_calibration.h).
#include "shadefit/reference_images/light_calibration.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "shadefit/base/error.h"
#include "shadefit/base/files.h"

namespace shadefit::reference_images {
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
  if (!PathExists(path)) throw Error(path, "mask", "file not found");
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

// The template's text plus one directional light towards `to_light` (world, unit), preceded by
// `comment` (lines without '#'); checked by the scene parser. A grey irradiance is written as
// one number, a coloured one as [r, g, b].
std::string SceneWithLight(const Scene& tmpl, const std::string& comment, const Vec3d& to_light,
                           const Vec3d& irradiance, const std::string& scene_path) {
  std::string text = tmpl.source_text;
  if (!text.empty() && text.back() != '\n') text += '\n';
  text += "\n";
  std::size_t start = 0;
  while (start < comment.size()) {
    const std::size_t end = std::min(comment.find('\n', start), comment.size());
    text += "# " + comment.substr(start, end - start) + "\n";
    start = end + 1;
  }
  const std::string value =
      irradiance.x == irradiance.y && irradiance.y == irradiance.z
          ? fmt::format("{:.9g}", irradiance.x)
          : fmt::format("[{:.9g}, {:.9g}, {:.9g}]", irradiance.x, irradiance.y, irradiance.z);
  text += fmt::format(
      "[[lights]]\ntype = \"directional\"\ndirection = [{:.9g}, {:.9g}, {:.9g}]\n"
      "irradiance = {}\n",
      -to_light.x, -to_light.y, -to_light.z, value);
  ParseScene(text, scene_path);  // Throws on anything the template got wrong.
  return text;
}

// The template (no lights allowed) and the output folder (a file there is an error; a missing
// folder is created when the scenes are written).
Scene LoadLightlessTemplate(const std::string& path, const std::string& output_dir) {
  if (output_dir.empty()) throw Error("", "output", "no output folder given");
  if (fs::exists(output_dir) && !fs::is_directory(output_dir)) {
    throw Error(output_dir, "output", "exists and is not a folder");
  }
  if (!PathExists(path)) throw Error(path, "scene-template", "file not found");
  Scene tmpl = LoadScene(path);
  if (!tmpl.lights.empty()) {
    throw Error(path, "lights",
                fmt::format("the template has {} light(s); it must have none (one directional "
                            "light per photograph is added)",
                            tmpl.lights.size()));
  }
  return tmpl;
}

// Writes every scene, then the summary: all of them or none (base/files.h). The output folder
// is created first when missing, and removed again when nothing could be written into it.
void WriteScenesAndSummary(const std::string& output_dir, const std::vector<std::string>& paths,
                           const std::vector<std::string>& texts, const std::string& summary_path,
                           const nlohmann::json& summary) {
  const bool created = !PathExists(output_dir);
  std::error_code ec;
  if (created && !fs::create_directories(output_dir, ec)) {
    throw Error(output_dir, "output", "cannot create the folder: " + ec.message());
  }
  std::vector<OutputWrite> writes;
  for (std::size_t i = 0; i < paths.size(); ++i) {
    writes.push_back({paths[i], [&, i] { WriteTextAtomic(paths[i], texts[i]); }});
  }
  writes.push_back(
      {summary_path, [&] { WriteTextAtomic(summary_path, summary.dump(1) + "\n"); }});
  try {
    WriteAllOrNothing(writes);
  } catch (...) {
    if (created) fs::remove(output_dir, ec);  // Only when empty.
    throw;
  }
}

// One line of a data set's text file: the numbers on it (spaces, tabs or commas between them);
// blank and '#' lines give none and are skipped by the caller.
struct NumberLine {
  int line = 0;  // 1-based.
  std::vector<double> values;
};

std::vector<NumberLine> ReadNumberLines(const std::string& path, const std::string& field) {
  if (!PathExists(path)) throw Error(path, field, "file not found");
  std::ifstream in(path);
  if (!in) throw Error(path, field, "cannot read the file");
  std::vector<NumberLine> out;
  std::string text;
  for (int line = 1; std::getline(in, text); ++line) {
    std::replace(text.begin(), text.end(), ',', ' ');
    std::replace(text.begin(), text.end(), '\t', ' ');
    std::istringstream ss(text);
    std::string word;
    NumberLine n{line, {}};
    while (ss >> word) {
      if (n.values.empty() && word[0] == '#') break;
      std::size_t used = 0;
      double v = 0.0;
      try {
        v = std::stod(word, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != word.size() || !std::isfinite(v)) {
        throw Error(fmt::format("{}:{}", path, line), field,
                    fmt::format("'{}' is not a finite number", word));
      }
      n.values.push_back(v);
    }
    if (!n.values.empty()) out.push_back(std::move(n));
  }
  if (out.empty()) throw Error(path, field, "no line with numbers");
  return out;
}

std::vector<std::string> ReadNames(const std::string& path) {
  if (!PathExists(path)) throw Error(path, "names", "file not found");
  std::ifstream in(path);
  std::vector<std::string> out;
  std::set<std::string> seen;
  std::string text;
  for (int line = 1; std::getline(in, text); ++line) {
    const std::size_t a = text.find_first_not_of(" \t\r");
    if (a == std::string::npos || text[a] == '#') continue;
    const std::size_t b = text.find_last_not_of(" \t\r");
    const std::string name = fs::path(text.substr(a, b - a + 1)).stem().string();
    if (name.empty() || name.find_first_of("/\\ ") != std::string::npos) {
      throw Error(fmt::format("{}:{}", path, line), "names",
                  fmt::format("'{}' is no lighting name", text));
    }
    if (!seen.insert(name).second) {
      throw Error(fmt::format("{}:{}", path, line), "names",
                  fmt::format("lighting '{}' listed twice", name));
    }
    out.push_back(name);
  }
  return out;
}

}  // namespace

Vec3d AxisMapping::ToCamera(const Vec3d& file) const {
  const double f[3] = {file.x, file.y, file.z};
  return {sign[0] * f[axis[0]], sign[1] * f[axis[1]], sign[2] * f[axis[2]]};
}

AxisMapping ParseAxisMapping(const std::string& text) {
  AxisMapping m;
  m.text = text;
  std::istringstream ss(text);
  std::string item;
  int i = 0;
  bool used[3] = {false, false, false};
  const auto bad = [&] {
    return Error("", "axes",
                 fmt::format("'{}' is not three signed axes, each of x, y, z once (camera x, y, "
                             "z in the file's axes, e.g. x,-y,-z)",
                             text));
  };
  while (std::getline(ss, item, ',')) {
    item.erase(std::remove(item.begin(), item.end(), ' '), item.end());
    if (i >= 3 || item.empty()) throw bad();
    double sign = 1.0;
    if (item[0] == '-' || item[0] == '+') {
      sign = item[0] == '-' ? -1.0 : 1.0;
      item.erase(0, 1);
    }
    if (item.size() != 1 || item[0] < 'x' || item[0] > 'z' || used[item[0] - 'x']) throw bad();
    used[item[0] - 'x'] = true;
    m.axis[i] = item[0] - 'x';
    m.sign[i] = sign;
    ++i;
  }
  if (i != 3) throw bad();
  return m;
}

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

namespace {

// One entry per mirror-ball photograph: its lighting (one photograph each) and scene path.
std::vector<CalibratedLight> NameBalls(const LightCalibrationOptions& o, const std::string& stem) {
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
  return out;
}

// One ball: its disc, its highlight and the direction towards the light.
void FindBallLight(const LightCalibrationOptions& o, const Scene& tmpl, const Image& mask,
                   CalibratedLight* c) {
  const LoadedImage loaded = LoadImageForImport(c->ball_path);
  const Image linear = DecodeToLinear(loaded, o.encoding, nullptr);
  if (linear.width != tmpl.camera.width || linear.height != tmpl.camera.height_px) {
    throw Error(
        c->ball_path, "resolution",
        fmt::format("image is {}x{}, the camera of {} is {}x{}", linear.width, linear.height,
                    o.scene_template, tmpl.camera.width, tmpl.camera.height_px));
  }
  if (!mask.empty() && (mask.width != linear.width || mask.height != linear.height)) {
    throw Error(o.mask_path, "resolution",
                fmt::format("mask is {}x{}, the image {} is {}x{}", mask.width, mask.height,
                            c->ball_path, linear.width, linear.height));
  }
  c->ball = DetectSphere(linear, DisplayWhite(loaded, linear), c->ball_path,
                         mask.empty() ? nullptr : &mask, kMirrorHighlightFraction);
  if (!c->ball.light_found || c->ball.peak_code - c->ball.median_code < o.min_highlight_contrast) {
    throw Error(c->ball_path, "highlight",
                fmt::format("no highlight on the ball: its brightest pixel (code {:.0f}) is not "
                            "{:.0f} codes above the ball's median ({:.0f})",
                            c->ball.peak_code, o.min_highlight_contrast, c->ball.median_code));
  }
  c->to_light = MirrorBallLight(c->ball, tmpl.camera);
}

// Writes the scenes, the template's text and one directional light each (checked by the scene
// parser), and the summary of the balls.
void WriteMirrorBallScenes(const LightCalibrationOptions& o, const Scene& tmpl,
                           const std::string& stem, const std::vector<CalibratedLight>& out) {
  std::vector<std::string> texts;
  nlohmann::json summary = {{"generator", "shadefit refs lights"},
                            {"scene_template", fs::absolute(o.scene_template).string()},
                            {"method",
                             "mirror direction of the view about the ball normal at the "
                             "highlight centroid"},
                            {"lights", nlohmann::json::array()}};
  std::vector<std::string> paths;
  for (const CalibratedLight& c : out) {
    const SphereEstimate& b = c.ball;
    const std::string comment = fmt::format(
        "Written by `shadefit refs lights` from {}: ball at ({:.2f}, {:.2f}) px, radius "
        "{:.2f} px ({}),\nhighlight at ({:.2f}, {:.2f}) px; towards the light ({:.6f}, "
        "{:.6f}, {:.6f}).",
        fs::path(c.ball_path).filename().string(), b.center_x, b.center_y, b.radius, b.found_by,
        b.highlight_x, b.highlight_y, c.to_light.x, c.to_light.y, c.to_light.z);
    texts.push_back(SceneWithLight(tmpl, comment, c.to_light,
                                   {o.irradiance, o.irradiance, o.irradiance}, c.scene_path));
    paths.push_back(c.scene_path);
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

  const std::string summary_path = (fs::path(o.output_dir) / (stem + "-lights.json")).string();
  WriteScenesAndSummary(o.output_dir, paths, texts, summary_path, summary);
}

// The published files' lines: directions (x y z, or x y z r g b when `six`), intensities (one per
// light, or none) and names (L0, L1, ... when not given).
struct PublishedFiles {
  std::vector<NumberLine> dirs;
  bool six = false;
  std::vector<NumberLine> intensities;
  std::vector<std::string> names;
};

// Reads the directions, intensities and names files, one line per light in each.
PublishedFiles ReadPublishedFiles(const PublishedLightsOptions& o) {
  PublishedFiles f;
  f.dirs = ReadNumberLines(o.directions_path, "directions");
  const std::vector<NumberLine>& dirs = f.dirs;
  const bool six = f.six = dirs.front().values.size() == 6;
  for (const NumberLine& d : dirs) {
    if (d.values.size() != (six ? 6u : 3u)) {
      throw Error(fmt::format("{}:{}", o.directions_path, d.line), "directions",
                  fmt::format("{} numbers; every line has x y z{} (as the first line)",
                              d.values.size(), six ? " r g b" : ""));
    }
  }
  if (six && !o.intensities_path.empty()) {
    throw Error(o.intensities_path, "intensities",
                fmt::format("{} already gives each light's intensity (6 columns)",
                            o.directions_path));
  }
  if (!o.intensities_path.empty()) {
    f.intensities = ReadNumberLines(o.intensities_path, "intensities");
    if (f.intensities.size() != dirs.size()) {
      throw Error(o.intensities_path, "intensities",
                  fmt::format("{} lights, {} has {}", f.intensities.size(), o.directions_path,
                              dirs.size()));
    }
  }
  if (!o.names_path.empty()) {
    f.names = ReadNames(o.names_path);
    if (f.names.size() != dirs.size()) {
      throw Error(o.names_path, "names",
                  fmt::format("{} names, {} has {} lights", f.names.size(), o.directions_path,
                              dirs.size()));
    }
  } else {
    for (std::size_t i = 0; i < dirs.size(); ++i) f.names.push_back(fmt::format("L{}", i));
  }
  return f;
}

// Light i's colour from the directions' r g b or the intensities file (white without either);
// `where` is its directions line.
Vec3d PublishedColour(const PublishedLightsOptions& o, const PublishedFiles& f, std::size_t i,
                      const std::string& where) {
  const std::vector<double>& v = f.dirs[i].values;
  Vec3d rgb{1, 1, 1};
  if (f.six) rgb = {v[3], v[4], v[5]};
  if (!f.intensities.empty()) {
    const NumberLine& n = f.intensities[i];
    if (n.values.size() != 1 && n.values.size() != 3) {
      throw Error(
          fmt::format("{}:{}", o.intensities_path, n.line), "intensities",
          fmt::format("{} numbers; expected r g b (or one for a grey light)", n.values.size()));
    }
    rgb = n.values.size() == 1 ? Vec3d{n.values[0], n.values[0], n.values[0]}
                               : Vec3d{n.values[0], n.values[1], n.values[2]};
  }
  if (!(rgb.x >= 0 && rgb.y >= 0 && rgb.z >= 0) || !(rgb.x + rgb.y + rgb.z > 0)) {
    throw Error(f.six ? where : fmt::format("{}:{}", o.intensities_path, f.intensities[i].line),
                "intensities", "an intensity must be >= 0 in every channel and > 0 in one");
  }
  return rgb;
}

// Every light: the file's direction in the camera frame, then in the world; the files'
// directions in `file_dirs`.
std::vector<PublishedLight> PublishedLightsInWorld(const PublishedLightsOptions& o,
                                                   const Scene& tmpl, const PublishedFiles& f,
                                                   std::vector<Vec3d>* file_dirs) {
  Vec3d right, up, forward;
  tmpl.camera.Basis(&right, &up, &forward);
  const std::string stem = fs::path(o.scene_template).stem().string();
  std::vector<PublishedLight> out;
  bool any_facing_camera = false;
  for (std::size_t i = 0; i < f.dirs.size(); ++i) {
    const std::vector<double>& v = f.dirs[i].values;
    const std::string where = fmt::format("{}:{}", o.directions_path, f.dirs[i].line);
    const Vec3d file{v[0], v[1], v[2]};
    if (!(Length(file) > 1e-9)) throw Error(where, "directions", "a zero direction");
    const Vec3d cam = o.axes.ToCamera(file) * (1.0 / Length(file));
    any_facing_camera = any_facing_camera || cam.z > 0.0;
    PublishedLight l;
    l.lighting = f.names[i];
    l.scene_path = (fs::path(o.output_dir) / (stem + "-" + l.lighting + ".toml")).string();
    l.to_light = Normalize(right * cam.x + up * cam.y - forward * cam.z);
    l.irradiance = PublishedColour(o, f, i, where) * o.irradiance;
    out.push_back(l);
    file_dirs->push_back(file);
  }
  // Photographs see the lit side: with every light behind the object the mapping is wrong.
  if (!any_facing_camera) {
    throw Error(o.directions_path, "axes",
                fmt::format("with --axes {} every light points away from the camera (camera z "
                            "<= 0): is the data set's z into the scene (then -z)?",
                            o.axes.text));
  }
  return out;
}

// Writes the scenes and the summary, as the mirror-ball path writes them.
void WritePublishedScenes(const PublishedLightsOptions& o, const Scene& tmpl,
                          const std::vector<NumberLine>& dirs,
                          const std::vector<PublishedLight>& out,
                          const std::vector<Vec3d>& file_dirs) {
  const std::string stem = fs::path(o.scene_template).stem().string();
  std::vector<std::string> paths, texts;
  nlohmann::json summary = {{"generator", "shadefit refs lights"},
                            {"scene_template", fs::absolute(o.scene_template).string()},
                            {"method", "published light directions and intensities"},
                            {"directions", fs::absolute(o.directions_path).string()},
                            {"directions_sha256", Sha256File(o.directions_path)},
                            {"axes", o.axes.text},
                            {"irradiance", o.irradiance},
                            {"lights", nlohmann::json::array()}};
  if (!o.intensities_path.empty()) {
    summary["intensities"] = fs::absolute(o.intensities_path).string();
    summary["intensities_sha256"] = Sha256File(o.intensities_path);
  }
  for (std::size_t i = 0; i < out.size(); ++i) {
    const PublishedLight& l = out[i];
    const Vec3d& f = file_dirs[i];
    const std::string comment = fmt::format(
        "Written by `shadefit refs lights` from {} line {} ({}, {}, {}) with --axes {};\n"
        "towards the light ({:.6f}, {:.6f}, {:.6f}).",
        fs::path(o.directions_path).filename().string(), dirs[i].line, f.x, f.y, f.z,
        o.axes.text, l.to_light.x, l.to_light.y, l.to_light.z);
    texts.push_back(SceneWithLight(tmpl, comment, l.to_light, l.irradiance, l.scene_path));
    paths.push_back(l.scene_path);
    summary["lights"].push_back({{"lighting", l.lighting},
                                 {"scene", fs::path(l.scene_path).filename().string()},
                                 {"line", dirs[i].line},
                                 {"file_direction", {f.x, f.y, f.z}},
                                 {"to_light", {l.to_light.x, l.to_light.y, l.to_light.z}},
                                 {"irradiance", {l.irradiance.x, l.irradiance.y, l.irradiance.z}}});
  }
  const std::string summary_path = (fs::path(o.output_dir) / (stem + "-lights.json")).string();
  WriteScenesAndSummary(o.output_dir, paths, texts, summary_path, summary);
}

}  // namespace

std::vector<CalibratedLight> CalibrateLightsFromMirrorBall(const LightCalibrationOptions& o) {
  // --- Validate the request before reading any image.
  if (o.ball_paths.empty()) throw Error("", "ball", "no mirror-ball photograph given");
  if (!(o.irradiance > 0) || !std::isfinite(o.irradiance)) {
    throw Error("", "irradiance", fmt::format("{} is not a finite number > 0", o.irradiance));
  }
  const Scene tmpl = LoadLightlessTemplate(o.scene_template, o.output_dir);
  const std::string stem = fs::path(o.scene_template).stem().string();
  std::vector<CalibratedLight> out = NameBalls(o, stem);
  const Image mask = o.mask_path.empty() ? Image() : ReadMask(o.mask_path);
  for (CalibratedLight& c : out) FindBallLight(o, tmpl, mask, &c);
  WriteMirrorBallScenes(o, tmpl, stem, out);
  return out;
}

std::vector<PublishedLight> LightsFromPublishedFiles(const PublishedLightsOptions& o) {
  // --- Validate the request and read every file before writing anything.
  if (!(o.irradiance > 0) || !std::isfinite(o.irradiance)) {
    throw Error("", "irradiance", fmt::format("{} is not a finite number > 0", o.irradiance));
  }
  const Scene tmpl = LoadLightlessTemplate(o.scene_template, o.output_dir);
  const PublishedFiles files = ReadPublishedFiles(o);
  std::vector<Vec3d> file_dirs;
  const std::vector<PublishedLight> out = PublishedLightsInWorld(o, tmpl, files, &file_dirs);
  WritePublishedScenes(o, tmpl, files.dirs, out, file_dirs);
  return out;
}

}  // namespace shadefit::reference_images
