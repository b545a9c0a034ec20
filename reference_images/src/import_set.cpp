#include "shadefit/reference_images/import_set.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "shadefit/base/error.h"
#include "shadefit/base/files.h"
#include "shadefit/reference_images/import.h"
#include "shadefit/render/brdf.h"
#include "shadefit/render/pixel_surface.h"
#include "shadefit/render/shadows.h"

namespace shadefit::reference_images {
namespace {

namespace fs = std::filesystem;

struct ObjectFiles {
  std::string name;
  fs::path dir;
  std::vector<std::string> images;  // Absolute.
  std::vector<Vec3d> directions;    // Unit, toward the light.
  std::vector<Vec3d> intensities;
  std::string normals, mask;        // Absolute; mask "" when none.
};

bool IsDigits(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); });
}

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Rows of `per_row` numbers (blank lines and '#' comments skipped).
std::vector<std::vector<double>> ReadRows(const fs::path& path, int per_row) {
  std::ifstream in(path);
  if (!in) throw Error(path.string(), "", "cannot open");
  std::vector<std::vector<double>> rows;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    line = line.substr(0, line.find('#'));
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream ss(line);
    std::vector<double> row;
    std::string tok;
    while (ss >> tok) {
      char* end = nullptr;
      const double v = std::strtod(tok.c_str(), &end);
      if (end == tok.c_str() || *end != '\0' || !std::isfinite(v)) {
        throw Error(fmt::format("{}:{}", path.string(), line_no), "",
                    fmt::format("'{}' is not a finite number", tok));
      }
      row.push_back(v);
    }
    if (row.empty()) continue;
    if (static_cast<int>(row.size()) != per_row) {
      throw Error(fmt::format("{}:{}", path.string(), line_no), "",
                  fmt::format("{} numbers, expected {}", row.size(), per_row));
    }
    rows.push_back(row);
  }
  return rows;
}

std::vector<std::string> ListImages(const fs::path& dir) {
  const fs::path list = dir / "filenames.txt";
  std::vector<std::string> out;
  if (PathExists(list.string())) {
    std::ifstream in(list);
    std::string line;
    while (std::getline(in, line)) {
      while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
      if (line.empty()) continue;
      const fs::path p = dir / line;
      if (!PathExists(p.string())) throw Error(list.string(), line, "listed image not found");
      out.push_back(p.string());
    }
    if (out.empty()) throw Error(list.string(), "", "lists no image");
    return out;
  }
  std::vector<std::pair<long, std::string>> numbered;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string ext = Lower(entry.path().extension().string());
    const std::string stem = entry.path().stem().string();
    if ((ext == ".png" || ext == ".tif" || ext == ".tiff" || ext == ".exr") && IsDigits(stem) &&
        stem.size() < 10) {
      numbered.emplace_back(std::stol(stem), entry.path().string());
    }
  }
  if (ec) throw Error(dir.string(), "", "cannot list the folder: " + ec.message());
  std::sort(numbered.begin(), numbered.end());
  for (auto& [n, p] : numbered) out.push_back(p);
  if (out.empty()) {
    throw Error(dir.string(), "images", "no filenames.txt and no numbered images (001.png, ...)");
  }
  return out;
}

std::string FindNormals(const fs::path& dir, const std::string& given) {
  if (!given.empty()) {
    const fs::path p = dir / given;
    if (!PathExists(p.string())) throw Error(p.string(), "normals", "file not found");
    return p.string();
  }
  for (const char* name : {"Normal_gt.mat", "normal_gt.mat", "normals.mat", "normal.mat",
                           "Normal_gt.npy", "normal.npy", "normals.npy", "normal.txt",
                           "normals.txt", "Normal_gt.txt", "normal.exr", "normals.exr",
                           "Normal_gt.png", "normal.png", "normals.png"}) {
    const fs::path p = dir / name;
    if (PathExists(p.string())) return p.string();
  }
  throw Error(dir.string(), "normals",
              "no ground-truth normals (Normal_gt.mat, normal.txt, normal(s).npy/.png/.exr; or "
              "name the file with --normals)");
}

ObjectFiles ReadObject(const fs::path& dir, const std::string& name, const ImportSetOptions& o) {
  ObjectFiles f;
  f.name = name;
  f.dir = dir;
  f.images = ListImages(dir);
  const fs::path dirs = dir / "light_directions.txt";
  for (const auto& r : ReadRows(dirs, 3)) {
    const Vec3d d{r[0], r[1], r[2]};
    const double len = Length(d);
    if (!(len > 1e-9)) {  // Any other length is normalised, as `refs lights` does.
      throw Error(dirs.string(), fmt::format("line {}", f.directions.size() + 1),
                  "a direction of length 0");
    }
    f.directions.push_back(d / len);
  }
  if (f.directions.size() != f.images.size()) {
    throw Error(dirs.string(), "", fmt::format("{} directions for {} images", f.directions.size(),
                                               f.images.size()));
  }
  const fs::path ints = dir / "light_intensities.txt";
  if (PathExists(ints.string())) {
    for (const auto& r : ReadRows(ints, 3)) {
      if (!(r[0] > 0 && r[1] > 0 && r[2] > 0)) {
        throw Error(ints.string(), fmt::format("line {}", f.intensities.size() + 1),
                    "intensities must be positive");
      }
      f.intensities.push_back({r[0], r[1], r[2]});
    }
    if (f.intensities.size() != f.images.size()) {
      throw Error(ints.string(), "", fmt::format("{} intensities for {} images",
                                                 f.intensities.size(), f.images.size()));
    }
  } else {
    f.intensities.assign(f.images.size(), Vec3d{1, 1, 1});
  }
  f.normals = FindNormals(dir, o.normals);
  const fs::path mask = dir / "mask.png";
  if (PathExists(mask.string())) f.mask = mask.string();
  return f;
}

std::string FileSafeName(const std::string& s) {
  std::string out;
  for (char c : s) out += std::isalnum(static_cast<unsigned char>(c)) || c == '-' ? c : '_';
  return out.empty() ? "object" : out;
}

std::string LightName(std::size_t k) { return fmt::format("L{:03d}", k + 1); }

double Luminance(const Image& img, std::size_t i) {
  return 0.2126 * img.data[i * img.channels] + 0.7152 * img.data[i * img.channels + 1] +
         0.0722 * img.data[i * img.channels + 2];
}

// Median angle between calibrated Lambertian photometric stereo (Woodham 1980, "Photometric
// method for determining surface orientation from multiple images") and the data's normals, as
// given and with y flipped. Per pixel: the brightest 70% of the unclipped, lit observations
// (shadows and specular peaks are what Lambert does not model; the middle holds up best).
void CheckNormals(const ObjectFiles& f, const std::vector<Image>& linear, const NormalImage& n,
                  double* angle, double* angle_flipped) {
  std::vector<double> a, b;
  const int step = std::max(1, static_cast<int>(std::sqrt(n.width * n.height / 4000.0)));
  for (int y = 0; y < n.height; y += step) {
    for (int x = 0; x < n.width; x += step) {
      const std::size_t i = static_cast<std::size_t>(y) * n.width + x;
      if (!n.mask[i]) continue;
      std::vector<std::pair<double, std::size_t>> obs;
      for (std::size_t k = 0; k < linear.size(); ++k) {
        const double v = Luminance(linear[k], i) /
                         (0.2126 * f.intensities[k].x + 0.7152 * f.intensities[k].y +
                          0.0722 * f.intensities[k].z);
        if (v > 0 && v < 0.99) obs.emplace_back(v, k);
      }
      if (obs.size() < 6) continue;
      std::sort(obs.begin(), obs.end());
      const std::size_t keep_from = obs.size() * 3 / 10, keep_to = obs.size() * 9 / 10;
      if (keep_to - keep_from < 3) continue;
      Eigen::MatrixXd l(keep_to - keep_from, 3);
      Eigen::VectorXd v(keep_to - keep_from);
      for (std::size_t r = keep_from; r < keep_to; ++r) {
        const Vec3d d = f.directions[obs[r].second];
        l.row(static_cast<Eigen::Index>(r - keep_from)) << d.x, d.y, d.z;
        v[static_cast<Eigen::Index>(r - keep_from)] = obs[r].first;
      }
      const Eigen::Vector3d g = l.colPivHouseholderQr().solve(v);
      if (!(g.norm() > 0)) continue;
      const Eigen::Vector3d ps = g.normalized();
      const Eigen::Vector3d gt(n.normal[3 * i], n.normal[3 * i + 1], n.normal[3 * i + 2]);
      const Eigen::Vector3d flipped(gt.x(), -gt.y(), gt.z());
      a.push_back(std::acos(std::clamp(ps.dot(gt), -1.0, 1.0)) * 180 / kPi);
      b.push_back(std::acos(std::clamp(ps.dot(flipped), -1.0, 1.0)) * 180 / kPi);
    }
  }
  if (a.empty()) {
    *angle = *angle_flipped = std::nan("");
    return;
  }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  *angle = median(a);
  *angle_flipped = median(b);
}

// Mean |curl| of the slope field the normals give (p = -nx/nz along the columns, q = +ny/nz down
// the rows, as IntegrateNormals reads them), with y as stored or flipped, over the 2 x 2 blocks of
// masked pixels facing the camera (nz > 0.3): normals of a real surface are integrable (curl 0)
// only in the frame whose y runs up the picture (Frankot and Chellappa 1988's integrability).
double MeanCurl(const NormalImage& n, bool flip_y) {
  double sum = 0;
  long count = 0;
  auto ok = [&](std::size_t i) { return n.mask[i] && n.normal[3 * i + 2] > 0.3; };
  auto p = [&](std::size_t i) { return -n.normal[3 * i] / n.normal[3 * i + 2]; };
  auto q = [&](std::size_t i) { return (flip_y ? -1.0 : 1.0) * n.normal[3 * i + 1] / n.normal[3 * i + 2]; };
  for (int y = 0; y + 1 < n.height; ++y) {
    for (int x = 0; x + 1 < n.width; ++x) {
      const std::size_t a = static_cast<std::size_t>(y) * n.width + x, b = a + 1, c = a + n.width;
      if (!ok(a) || !ok(b) || !ok(c)) continue;
      sum += std::abs((p(c) - p(a)) - (q(b) - q(a)));
      ++count;
    }
  }
  return count > 0 ? sum / count : 0.0;
}

void WriteFileAtomic(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".partial";
  {
    std::ofstream out(tmp);
    out << text;
    if (!out) throw Error(path.string(), "", "cannot write");
  }
  fs::rename(tmp, path);
}

// The pixels whose cast shadow the object's depth does not reproduce: dark in the image where the
// scene lights them, or lit in the image where the scene's depth casts a shadow. A normal-map
// object's depth is integrated from its normals, which says nothing across a depth discontinuity
// (an ear in front of a head), so its cast shadows can fall where the photograph's do not; those
// pixels are outside what the renderer reproduces, as a shadow's edge is. Only pixels facing the
// light (n.l > 0.1) are judged: the attached shadow is the model's own. "Dark": below 10% of what
// the object's typical albedo would give there (the 90th percentile of luminance / n.l over the
// facing pixels, times n.l). Returns the mask with those pixels set to 0 and their count.
Image ShadowAgreementMask(const Scene& scene, const Image& linear, const Vec3d& intensity,
                          long long* removed) {
  const SceneObject& o = scene.objects.at(0);
  const PixelSurface& s = *o.pixels;
  const Light* light = nullptr;
  for (const Light& l : scene.lights) {
    if (l.type == Light::Type::kDirectional) light = &l;
  }
  Image mask(s.width, s.height, 1);
  *removed = 0;
  if (!light) return mask;
  const Vec3d to_light = -light->direction;
  const double scale = 0.2126 * intensity.x + 0.7152 * intensity.y + 0.0722 * intensity.z;
  std::vector<double> albedo;
  const std::size_t n = static_cast<std::size_t>(s.width) * s.height;
  std::vector<double> ndotl(n, 0.0), lum(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    if (!s.mask[i]) continue;
    const Vec3d nn{s.normal[3 * i], s.normal[3 * i + 1], s.normal[3 * i + 2]};
    ndotl[i] = Dot(nn, to_light);
    lum[i] = Luminance(linear, i) / scale;
    if (ndotl[i] > 0.1) albedo.push_back(lum[i] / ndotl[i]);
  }
  if (albedo.empty()) {
    for (std::size_t i = 0; i < n; ++i) mask.data[i] = s.mask[i];
    return mask;
  }
  std::nth_element(albedo.begin(), albedo.begin() + static_cast<long>(albedo.size() * 9 / 10),
                   albedo.end());
  const double typical = albedo[albedo.size() * 9 / 10];
  for (std::size_t i = 0; i < n; ++i) {
    if (!s.mask[i]) continue;
    mask.data[i] = 1.0f;
    if (ndotl[i] <= 0.1) continue;
    const Vec3d p{s.position[3 * i], s.position[3 * i + 1], s.position[3 * i + 2]};
    const Vec3d nn{s.normal[3 * i], s.normal[3 * i + 1], s.normal[3 * i + 2]};
    const bool shadowed = !LightReaches(scene, 0, p, nn, to_light, 1e30);
    const bool dark = lum[i] < 0.1 * typical * ndotl[i];
    if (shadowed != dark) {
      mask.data[i] = 0.0f;
      ++*removed;
    }
  }
  return mask;
}

std::string Vec(const Vec3d& v) { return fmt::format("[{:.9g}, {:.9g}, {:.9g}]", v.x, v.y, v.z); }

}  // namespace

std::vector<int> SpreadSubset(const std::vector<Vec3d>& dirs, int count) {
  std::vector<int> out;
  const int n = static_cast<int>(dirs.size());
  if (count >= n) {
    for (int i = 0; i < n; ++i) out.push_back(i);
    return out;
  }
  std::vector<double> nearest(n, 1e9);  // Smallest angle to the chosen ones.
  int next = 0;
  for (int i = 1; i < n; ++i) next = dirs[i].z > dirs[next].z ? i : next;
  for (int taken = 0; taken < count; ++taken) {
    out.push_back(next);
    for (int i = 0; i < n; ++i) {
      nearest[i] = std::min(nearest[i], std::acos(std::clamp(Dot(dirs[i], dirs[next]), -1.0, 1.0)));
    }
    int best = -1;
    for (int i = 0; i < n; ++i) {
      if (std::find(out.begin(), out.end(), i) != out.end()) continue;
      if (best < 0 || nearest[i] > nearest[best]) best = i;
    }
    next = best;
  }
  std::sort(out.begin(), out.end());
  return out;
}

ImportSetResult ImportPhotometricSet(const ImportSetOptions& o, Renderer& renderer) {
  const fs::path input = fs::absolute(o.input);
  if (KindOfPath(input.string(), "input") != PathKind::kDirectory) {
    throw Error(input.string(), "", "not a folder");
  }
  if (o.y_axis != "auto" && o.y_axis != "up" && o.y_axis != "down") {
    throw Error("", "--y-axis", "expected auto, up or down");
  }
  if (o.train_lights < 1) throw Error("", "--train", "must be at least 1");
  // 1. Every input read and checked before anything is written.
  std::vector<ObjectFiles> objects;
  if (PathExists((input / "light_directions.txt").string())) {
    objects.push_back(ReadObject(input, FileSafeName(input.filename().string()), o));
  } else {
    std::vector<fs::path> dirs;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(input, ec)) {
      if (e.is_directory() && PathExists((e.path() / "light_directions.txt").string())) {
        dirs.push_back(e.path());
      }
    }
    std::sort(dirs.begin(), dirs.end());
    if (dirs.empty()) {
      throw Error(input.string(), "",
                  "no light_directions.txt here or in any subfolder (the photometric-stereo "
                  "layout: docs/measured_and_imported.md)");
    }
    for (const fs::path& d : dirs) objects.push_back(ReadObject(d, FileSafeName(d.filename().string()), o));
  }
  ImportSetResult result;
  std::vector<std::vector<Image>> images;  // Per object, per light: linear RGB.
  std::vector<NormalImage> frames;         // Per object: the normals in shadefit's frame.
  for (const ObjectFiles& f : objects) {
    ImportedObject obj;
    obj.name = f.name;
    obj.lights = static_cast<int>(f.images.size());
    obj.normals_file = f.normals;
    // The data set's frame, found from the data: z toward the camera (most normals face it, and
    // a photograph sees its lights' side), y up the picture (the normals integrate), and the
    // lights' y the normals' (Lambertian photometric stereo agrees); or as --y-axis says.
    NormalImage normals = ReadNormalImage(f.normals, f.mask, "", false, /*check_facing=*/false);
    long facing = 0, masked = 0;
    for (std::size_t i = 0; i < normals.mask.size(); ++i) {
      masked += normals.mask[i];
      facing += normals.mask[i] && normals.normal[3 * i + 2] > 0;
    }
    obj.normals_z_flipped = facing < masked / 2;
    if (obj.normals_z_flipped) {
      for (std::size_t i = 0; i < normals.mask.size(); ++i) normals.normal[3 * i + 2] *= -1;
    }
    long lights_toward = 0;
    for (const Vec3d& d : f.directions) lights_toward += d.z > 0;
    ObjectFiles& fm = objects[&f - &objects[0]];
    obj.lights_z_flipped = lights_toward < static_cast<long>(f.directions.size()) / 2;
    if (obj.lights_z_flipped) {
      for (Vec3d& d : fm.directions) d.z = -d.z;
    }
    obj.curl_as_stored = MeanCurl(normals, false);
    obj.curl_flipped = MeanCurl(normals, true);
    const bool normals_y_down =
        o.y_axis == "auto" ? obj.curl_flipped < obj.curl_as_stored : o.y_axis == "down";
    if (normals_y_down) {
      for (std::size_t i = 0; i < normals.mask.size(); ++i) normals.normal[3 * i + 1] *= -1;
    }
    obj.y_axis = normals_y_down ? "down" : "up";
    std::vector<Image> linear;
    for (const std::string& path : f.images) {
      const LoadedImage loaded = LoadImageForImport(path);
      if (loaded.rgb.width != normals.width || loaded.rgb.height != normals.height) {
        throw Error(path, "resolution", fmt::format("is {}x{} but the normals are {}x{}",
                                                    loaded.rgb.width, loaded.rgb.height,
                                                    normals.width, normals.height));
      }
      Encoding applied;
      linear.push_back(DecodeToLinear(loaded, Encoding::kLinear, &applied));
    }
    CheckNormals(fm, linear, normals, &obj.check_angle_deg, &obj.check_angle_flipped_deg);
    obj.lights_y_flipped = obj.check_angle_flipped_deg < obj.check_angle_deg;
    if (obj.lights_y_flipped) {  // The lights' y runs the other way: turn them, not the normals.
      for (Vec3d& d : fm.directions) d.y = -d.y;
      std::swap(obj.check_angle_deg, obj.check_angle_flipped_deg);
    }
    if (!(obj.check_angle_deg < 45)) {
      throw Error(f.normals, "normals",
                  fmt::format("Lambertian photometric stereo on the images disagrees with these "
                              "normals by {:.0f} degrees (median) in every frame tried: are they "
                              "the ground truth of these images and lights?", obj.check_angle_deg));
    }
    obj.masked_pixels = masked;
    frames.push_back(std::move(normals));
    result.objects.push_back(obj);
    images.push_back(std::move(linear));
  }
  // The training lights, spread over the first object's directions (in shadefit's frame).
  const std::vector<int> train = SpreadSubset(objects[0].directions, o.train_lights);
  for (std::size_t j = 0; j < objects.size(); ++j) {
    if (objects[j].images.size() <= static_cast<std::size_t>(train.back())) {
      throw Error(objects[j].dir.string(), "images",
                  fmt::format("{} images; the training lights (chosen on {}) need {}",
                              objects[j].images.size(), objects[0].name, train.back() + 1));
    }
    for (int k : train) result.objects[j].train.push_back(LightName(static_cast<std::size_t>(k)));
  }
  // 2. Scenes, references, the study.
  const fs::path out = fs::absolute(o.output);
  fs::create_directories(out / "scenes");
  fs::create_directories(out / "refs");
  fs::create_directories(out / "masks");
  fs::create_directories(out / "normals");
  for (std::size_t j = 0; j < objects.size(); ++j) {
    const fs::path npy = out / "normals" / (objects[j].name + ".npy");
    WriteNormalsNpy(npy.string(), frames[j]);
    objects[j].normals = npy.string();  // The scenes read the normals in shadefit's frame.
  }
  std::vector<long long> obj_removed(objects.size(), 0);
  for (std::size_t j = 0; j < objects.size(); ++j) {
    const ObjectFiles& f = objects[j];
    for (std::size_t k = 0; k < f.images.size(); ++k) {
      const std::string stem = f.name + "-" + LightName(k);
      const fs::path scene = out / "scenes" / (stem + ".toml");
      std::string text = fmt::format(
          "# {}: light {} of {} of {} ({}, line {}). No [camera]: orthographic along the "
          "normals'\n# z axis, whose frame (x right, y up, z toward the camera) is the world's "
          "(docs/scenes.md).\n[[objects]]\ntype = \"normal_map\"\nnormals = \"{}\"\n",
          f.name, k + 1, f.images.size(), input.string(), "light_directions.txt", k + 1, f.normals);
      if (!f.mask.empty()) text += fmt::format("mask = \"{}\"\n", f.mask);
      text += "\n[[lights]]\ntype = \"directional\"\n";
      text += fmt::format("direction = {}  # travel: minus light_directions.txt's\n",
                          Vec(-f.directions[k]));
      text += fmt::format("irradiance = {}  # light_intensities.txt\n", Vec(f.intensities[k]));
      WriteFileAtomic(scene, text);
      // The object's mask less the pixels whose cast shadow the depth does not reproduce.
      const Scene parsed = LoadScene(scene.string());
      long long removed = 0;
      const Image agree = ShadowAgreementMask(parsed, images[j][k], f.intensities[k], &removed);
      const fs::path mask_path = out / "masks" / (stem + ".png");
      WritePng8(mask_path.string(), agree);
      obj_removed[j] += removed;
      ImportOptions io;
      io.image_path = f.images[k];
      io.scene_path = scene.string();
      io.mask_path = mask_path.string();
      io.encoding = Encoding::kLinear;  // Photometric-stereo sets store linear radiance.
      io.clip_threshold = o.clip_threshold;
      io.direct_light_only = o.direct_light_only;
      io.output = (out / "refs" / (stem + ".exr")).string();
      ImportReference(io, renderer);
    }
  }
  for (std::size_t j = 0; j < objects.size(); ++j) {
    const double judged = static_cast<double>(objects[j].images.size()) *
                          static_cast<double>(result.objects[j].masked_pixels);
    result.objects[j].shadow_disagreement_fraction =
        judged > 0 ? static_cast<double>(obj_removed[j]) / judged : 0.0;
  }
  const std::string name = o.name.empty() ? FileSafeName(input.filename().string()) : o.name;
  std::string study = fmt::format(
      "# Made by `shadefit refs import-set {}`: {} object(s), each a normal-map object under its\n"
      "# data set's lights; fitted jointly on {} spread lights (farthest-point on the first "
      "object's\n# directions) and tested on the rest. docs/measured_and_imported.md, "
      "\"Photometric-stereo data sets\".\n",
      input.string(), objects.size(), train.size());
  for (const ImportedObject& obj : result.objects) {
    study += fmt::format(
        "# {}: {} lights; normals {} read with y {}{} (mean curl {:.3g}, {:.3g} the other way), "
        "lights{}{};\n#   Lambertian photometric stereo vs these normals: median {:.1f} deg "
        "({:.1f} with the lights' y flipped);\n#   {:.1f}% of the object's pixel-lights left "
        "out (masks/): a cast shadow the integrated depth does not reproduce\n",
        obj.name, obj.lights, obj.normals_file, obj.y_axis, obj.normals_z_flipped ? ", z flipped" : "",
        obj.y_axis == "up" ? obj.curl_as_stored : obj.curl_flipped,
        obj.y_axis == "up" ? obj.curl_flipped : obj.curl_as_stored,
        obj.lights_y_flipped ? " y flipped" : " as given", obj.lights_z_flipped ? ", z flipped" : "",
        obj.check_angle_deg, obj.check_angle_flipped_deg, 100 * obj.shadow_disagreement_fraction);
  }
  study += fmt::format("\n[study]\nname = \"{}\"\ndescription = \"{} object(s) under their "
                       "data set's lights: joint fit on {}, tested on the rest\"\n",
                       name, objects.size(), train.size());
  for (const ObjectFiles& f : objects) {
    study += fmt::format("\n[[group]]\nmaterial = \"{}\"\nobject = \"{}\"\nimages = "
                         "[\"refs/{}-L*.exr\"]\n", f.name, f.name, f.name);
  }
  std::string models, train_names;
  for (std::size_t i = 0; i < o.models.size(); ++i) models += fmt::format("{}\"{}\"", i ? ", " : "", o.models[i]);
  for (std::size_t i = 0; i < result.objects[0].train.size(); ++i) {
    train_names += fmt::format("{}\"{}\"", i ? ", " : "", result.objects[0].train[i]);
  }
  study += fmt::format(
      "\n[fit]\n# The first model is the one the others are compared with.\nmodels = [{}]\n"
      "train = [[{}]]\nloss = \"l2\"\nstarts = 2\n# The camera's exposure and the lights' "
      "absolute scale are unknown: one free scale per fit.\nexposure = \"free\"\nencoding = "
      "\"as-imported\"\nmax_iterations = 60\npixel_stride = {}\n\n[metrics]\nexposure_stops = "
      "0.0\n\n[outputs]\npreviews = true\nreport = true\n",
      models, train_names, o.pixel_stride);
  result.study_path = (out / (name + ".toml")).string();
  WriteFileAtomic(result.study_path, study);
  return result;
}

}  // namespace shadefit::reference_images
