#include "shadefit/render/scene.h"

#include <fmt/format.h>

#include <toml++/toml.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <utility>

#include "shadefit/base/error.h"
#include "shadefit/base/files.h"
#include "shadefit/render/pixel_surface.h"
#include "shadefit/render/ray_caster.h"

namespace shadefit {
namespace {

namespace fs = std::filesystem;

constexpr double kMaxMagnitude = 1e9;  // Largest vector component a scene may give.

// Reads typed, validated values out of one TOML table, naming file, line and key on error.
class TableReader {
 public:
  TableReader(const toml::table& table, std::string file, std::string prefix)
      : table_(table), file_(std::move(file)), prefix_(std::move(prefix)) {}

  [[noreturn]] void Fail(const std::string& key, const std::string& problem,
                         const toml::node* node = nullptr) const {
    const auto& src = node ? node->source() : table_.source();
    const std::string where =
        src.begin.line > 0 ? fmt::format("{}:{}", file_, src.begin.line) : file_;
    throw Error(where, prefix_ + key, problem);
  }

  void CheckKeys(const std::set<std::string>& allowed) const {
    for (const auto& [key, node] : table_) {
      if (!allowed.count(std::string(key.str()))) {
        Fail(std::string(key.str()),
             "unknown key" + DidYouMean(key.str(), {allowed.begin(), allowed.end()}), &node);
      }
    }
  }

  bool Has(const std::string& key) const { return table_.contains(key); }

  double Number(const std::string& key, double def, double min, double max,
                bool required = false) const {
    const toml::node* node = table_.get(key);
    if (!node) {
      if (required) Fail(key, "missing");
      return def;
    }
    const auto v = node->value<double>();
    if (!v) Fail(key, "expected a number", node);
    if (!std::isfinite(*v) || *v < min || *v > max) {
      Fail(key, fmt::format("value {} outside [{}, {}]", *v, min, max), node);
    }
    return *v;
  }

  int Integer(const std::string& key, int def, int min, int max) const {
    const toml::node* node = table_.get(key);
    if (!node) return def;
    // The type first: toml++'s value<int64_t>() converts a float, and one beyond int64's range
    // (samples = 1.9e41) is undefined behaviour (found by fuzz_scene).
    if (!node->is_integer()) Fail(key, "expected an integer", node);
    const int64_t v = node->as_integer()->get();
    if (v < min || v > max) Fail(key, fmt::format("value {} outside [{}, {}]", v, min, max), node);
    return static_cast<int>(v);
  }

  bool Bool(const std::string& key, bool def) const {
    const toml::node* node = table_.get(key);
    if (!node) return def;
    const auto v = node->value<bool>();
    if (!v) Fail(key, "expected true or false", node);
    return *v;
  }

  std::string String(const std::string& key, const std::string& def, bool required = false) const {
    const toml::node* node = table_.get(key);
    if (!node) {
      if (required) Fail(key, "missing");
      return def;
    }
    const auto v = node->value<std::string>();
    if (!v) Fail(key, "expected a string", node);
    return *v;
  }

  // A 3-vector; with allow_scalar a single number fills all three (colours, powers).
  Vec3d Vector(const std::string& key, const Vec3d& def, bool required = false,
               bool allow_scalar = false, double min = -kMaxMagnitude) const {
    const toml::node* node = table_.get(key);
    if (!node) {
      if (required) Fail(key, "missing");
      return def;
    }
    Vec3d out;
    if (allow_scalar && node->is_number()) {
      const double v = *node->value<double>();
      out = {v, v, v};
    } else {
      const toml::array* arr = node->as_array();
      if (!arr || arr->size() != 3) {
        Fail(key, allow_scalar ? "expected a number or an array of 3 numbers"
                               : "expected an array of 3 numbers", node);
      }
      for (int i = 0; i < 3; ++i) {
        const auto v = (*arr)[i].value<double>();
        if (!v) Fail(key, "expected an array of 3 numbers", node);
        out[i] = *v;
      }
    }
    for (int i = 0; i < 3; ++i) {
      if (!std::isfinite(out[i]) || out[i] < min) {
        Fail(key, fmt::format("component {} = {} is not allowed (minimum {})", i, out[i], min),
             node);
      }
      // The GL renderer works in float32: beyond 1e9 squared distances and powers overflow.
      if (std::abs(out[i]) > kMaxMagnitude) {
        Fail(key, fmt::format("component {} = {} is beyond +-{}", i, out[i], kMaxMagnitude), node);
      }
    }
    return out;
  }

  const toml::table& table() const { return table_; }

 private:
  const toml::table& table_;
  std::string file_;
  std::string prefix_;
};

Vec3d UnitOrFail(const TableReader& r, const std::string& key, const Vec3d& v) {
  const double len = Length(v);
  if (!(len > 1e-12)) r.Fail(key, "must not be the zero vector");
  return v / len;
}

void ParseCamera(const TableReader& r, Camera* cam) {
  r.CheckKeys({"type", "position", "look_at", "up", "fov_y", "height", "resolution",
               "supersample"});
  const std::string type = r.String("type", "perspective");
  if (type == "perspective") {
    cam->type = Camera::Type::kPerspective;
  } else if (type == "orthographic") {
    cam->type = Camera::Type::kOrthographic;
  } else {
    r.Fail("type", "expected \"perspective\" or \"orthographic\"" +
                       DidYouMean(type, {"perspective", "orthographic"}),
           r.table().get("type"));
  }
  cam->position = r.Vector("position", cam->position, true);
  cam->look_at = r.Vector("look_at", cam->look_at, true);
  cam->up = r.Vector("up", cam->up);
  cam->fov_y_deg = r.Number("fov_y", cam->fov_y_deg, 0.1, 179.0);
  cam->height = r.Number("height", cam->height, 1e-6, 1e6);
  if (r.Has("resolution")) {
    const toml::node* node = r.table().get("resolution");
    const toml::array* arr = node->as_array();
    if (!arr || arr->size() != 2 || !(*arr)[0].is_integer() || !(*arr)[1].is_integer()) {
      r.Fail("resolution", "expected [width, height] integers", node);
    }
    const int64_t w = (*arr)[0].as_integer()->get();
    const int64_t h = (*arr)[1].as_integer()->get();
    if (w < 1 || h < 1 || w > 8192 || h > 8192) r.Fail("resolution", "must be 1..8192", node);
    cam->width = static_cast<int>(w);
    cam->height_px = static_cast<int>(h);
  }
  cam->supersample = r.Integer("supersample", 1, 1, 16);
  const Vec3d forward = cam->look_at - cam->position;
  if (!(Length(forward) > 1e-9)) r.Fail("look_at", "equals position");
  if (!(Length(Cross(Normalize(forward), UnitOrFail(r, "up", cam->up))) > 1e-6)) {
    r.Fail("up", "is parallel to the view direction");
  }
}

// A path given in a scene file, relative to the scene's folder; must exist.
std::string ScenePath(const TableReader& r, const std::string& key, const std::string& scene_dir) {
  fs::path file = r.String(key, "", true);
  if (file.is_relative() && !scene_dir.empty()) file = fs::path(scene_dir) / file;
  PathKind kind = PathKind::kMissing;
  try {
    kind = KindOfPath(file.string());
  } catch (const Error& e) {
    r.Fail(key, e.what(), r.table().get(key));
  }
  if (kind == PathKind::kMissing) {
    r.Fail(key, fmt::format("'{}' not found", file.string()), r.table().get(key));
  }
  if (kind != PathKind::kFile) {
    r.Fail(key, fmt::format("'{}' is not a regular file", file.string()), r.table().get(key));
  }
  return file.string();
}

// Errors from reading a mesh or normals file carry that file's name; the scene's key comes first
// so that the user knows which line named it.
template <typename F>
auto Naming(const TableReader& r, const std::string& key, F&& read) {
  try {
    return read();
  } catch (const Error& e) {
    r.Fail(key, e.what(), r.table().get(key));
  }
}

SceneObject ParseMesh(const TableReader& r, const std::string& scene_dir) {
  r.CheckKeys({"type", "file", "translate", "rotate", "scale", "normals", "normal_map",
               "normal_map_flip_green"});
  SceneObject o;
  o.type = SceneObject::Type::kMesh;
  MeshTransform t;
  t.translate = r.Vector("translate", t.translate);
  t.rotate_deg = r.Vector("rotate", t.rotate_deg);
  t.scale = r.Vector("scale", t.scale, false, true);
  for (int i = 0; i < 3; ++i) {
    if (!(std::abs(t.scale[i]) >= 1e-9)) r.Fail("scale", "must not be 0 (or below 1e-9) on an axis");
  }
  const std::string normals = r.String("normals", "auto");
  MeshNormals mode = MeshNormals::kAuto;
  if (normals == "smooth") {
    mode = MeshNormals::kSmooth;
  } else if (normals == "flat") {
    mode = MeshNormals::kFlat;
  } else if (normals != "auto") {
    r.Fail("normals", "expected \"auto\", \"smooth\" or \"flat\"" +
                          DidYouMean(normals, {"auto", "smooth", "flat"}),
           r.table().get("normals"));
  }
  const std::string file = ScenePath(r, "file", scene_dir);
  o.mesh = Naming(r, "file", [&] { return LoadMesh(file, t, mode); });
  if (r.Has("normal_map")) {
    const std::string map = ScenePath(r, "normal_map", scene_dir);
    if (o.mesh->uvs.empty()) {
      r.Fail("normal_map", fmt::format("the mesh {} has no texture coordinates", file));
    }
    const bool flip = r.Bool("normal_map_flip_green", false);
    o.normal_map = Naming(r, "normal_map", [&] { return LoadNormalMap(map, flip); });
  } else if (r.Has("normal_map_flip_green")) {
    r.Fail("normal_map_flip_green", "given without a normal_map");
  }
  return o;
}

SceneObject ParseNormalMapObject(const TableReader& r, const std::string& scene_dir,
                                 const Camera& camera) {
  r.CheckKeys({"type", "normals", "mask", "depth", "variable", "y_axis"});
  SceneObject o;
  o.type = SceneObject::Type::kNormalMap;
  NormalMapSpec spec;
  spec.normals = ScenePath(r, "normals", scene_dir);
  if (r.Has("mask")) spec.mask = ScenePath(r, "mask", scene_dir);
  if (r.Has("depth")) spec.depth = ScenePath(r, "depth", scene_dir);
  spec.variable = r.String("variable", "");
  const std::string y_axis = r.String("y_axis", "up");
  if (y_axis != "up" && y_axis != "down") {
    r.Fail("y_axis", "expected \"up\" or \"down\"", r.table().get("y_axis"));
  }
  spec.y_down = y_axis == "down";
  o.pixels = Naming(r, "normals", [&] { return LoadPixelSurface(spec, camera); });
  o.mesh = o.pixels->depth_mesh;
  return o;
}

SceneObject ParseObject(const TableReader& r, const std::string& scene_dir, const Camera& camera) {
  SceneObject o;
  const std::string type = r.String("type", "", true);
  if (type == "mesh") return ParseMesh(r, scene_dir);
  if (type == "normal_map") return ParseNormalMapObject(r, scene_dir, camera);
  if (type == "sphere") {
    r.CheckKeys({"type", "center", "radius"});
    o.type = SceneObject::Type::kSphere;
    o.center = r.Vector("center", o.center);
    o.radius = r.Number("radius", 1.0, 1e-9, 1e9);
  } else if (type == "plane") {
    r.CheckKeys({"type", "point", "normal", "half_size"});
    o.type = SceneObject::Type::kPlane;
    o.point = r.Vector("point", o.point);
    o.normal = UnitOrFail(r, "normal", r.Vector("normal", o.normal, true));
    if (r.Has("half_size")) {
      const toml::node* node = r.table().get("half_size");
      const toml::array* arr = node->as_array();
      if (!arr || arr->size() != 2 || !(*arr)[0].value<double>() || !(*arr)[1].value<double>()) {
        r.Fail("half_size", "expected [half_u, half_v] numbers", node);
      }
      o.half_u = *(*arr)[0].value<double>();
      o.half_v = *(*arr)[1].value<double>();
      if (!(o.half_u > 0) || !(o.half_v > 0)) r.Fail("half_size", "must be positive", node);
    }
  } else {
    const std::vector<std::string> kinds = {"sphere", "plane", "mesh", "normal_map"};
    r.Fail("type", "expected \"sphere\", \"plane\", \"mesh\" or \"normal_map\"" + DidYouMean(type, kinds),
           r.table().get("type"));
  }
  return o;
}

Light ParseLight(const TableReader& r, const std::string& scene_dir) {
  Light l;
  const std::string type = r.String("type", "", true);
  constexpr double kInv4Pi = 1.0 / (4.0 * 3.14159265358979323846);
  if (type == "point") {
    r.CheckKeys({"type", "position", "power", "intensity"});
    l.type = Light::Type::kPoint;
    l.position = r.Vector("position", l.position, true);
    if (r.Has("power") == r.Has("intensity")) {
      r.Fail("power", "give exactly one of power (W) or intensity (W/sr)");
    }
    // Cycles: a point light of power P and radius 0 has intensity P / (4 pi) W/sr.
    l.value = r.Has("power") ? r.Vector("power", {}, true, true, 0.0) * kInv4Pi
                             : r.Vector("intensity", {}, true, true, 0.0);
  } else if (type == "directional") {
    r.CheckKeys({"type", "direction", "irradiance"});
    l.type = Light::Type::kDirectional;
    l.direction = UnitOrFail(r, "direction", r.Vector("direction", {}, true));
    l.value = r.Vector("irradiance", {}, true, true, 0.0);
  } else if (type == "ambient") {
    r.CheckKeys({"type", "radiance"});
    l.type = Light::Type::kAmbient;
    l.value = r.Vector("radiance", {}, true, true, 0.0);
  } else if (type == "environment") {
    r.CheckKeys({"type", "file", "strength", "rotation_z", "samples"});
    l.type = Light::Type::kEnvironment;
    fs::path file = r.String("file", "", true);
    if (file.is_relative()) file = fs::path(scene_dir) / file;
    PathKind kind = PathKind::kMissing;
    try {
      kind = KindOfPath(file.string());
    } catch (const Error& e) {
      r.Fail("file", e.what(), r.table().get("file"));
    }
    if (kind == PathKind::kMissing) {
      r.Fail("file",
             fmt::format("'{}' not found (the Blender maps come with Debian's blender-data "
                         "package)", file.string()),
             r.table().get("file"));
    }
    l.file = file.string();
    l.strength = r.Number("strength", 1.0, 0.0, 1e9);
    l.rotation_z_deg = r.Number("rotation_z", 0.0, -1e4, 1e4);
    l.samples = r.Integer("samples", 256, 1, 65536);
  } else if (type == "uniform") {
    r.CheckKeys({"type", "radiance", "samples"});
    l.type = Light::Type::kUniform;
    l.value = r.Vector("radiance", {}, true, true, 0.0);
    l.samples = r.Integer("samples", 256, 1, 65536);
  } else {
    r.Fail("type",
           "expected point, directional, ambient, environment or uniform" +
               DidYouMean(type, {"point", "directional", "ambient", "environment", "uniform"}),
           r.table().get("type"));
  }
  return l;
}

// Without a [camera], a scene whose one object is a normal map is seen as photometric stereo
// assumes: orthographically along the normals' z axis (world -Z, up +Y), at the normals'
// resolution, the longer side spanning 2 world units. False when the scene is not of that form.
bool NormalMapCamera(const toml::table& root, const std::string& name, const std::string& dir,
                     Camera* cam) {
  const toml::array* objects = root["objects"].as_array();
  if (!objects || objects->size() != 1 || !(*objects)[0].is_table()) return false;
  const toml::table& t = *(*objects)[0].as_table();
  if (t["type"].value_or(std::string()) != "normal_map") return false;
  const TableReader r(t, name, "objects[0].");
  const std::string normals = ScenePath(r, "normals", dir);
  const std::string mask = r.Has("mask") ? ScenePath(r, "mask", dir) : "";
  const ImageSize img = Naming(r, "normals", [&] {
    return NormalImageSize(normals, mask, r.String("variable", ""),
                           r.String("y_axis", "up") == "down");
  });
  if (img.width > 8192 || img.height > 8192) r.Fail("normals", "larger than 8192 pixels a side");
  cam->type = Camera::Type::kOrthographic;
  cam->position = {0, 0, 10};
  cam->look_at = {0, 0, 0};
  cam->up = {0, 1, 0};
  cam->width = img.width;
  cam->height_px = img.height;
  cam->height = 2.0 * img.height / std::max(img.width, img.height);
  return true;
}

}  // namespace

void Camera::Basis(Vec3d* right, Vec3d* true_up, Vec3d* forward) const {
  *forward = Normalize(look_at - position);
  *right = Normalize(Cross(*forward, up));
  *true_up = Cross(*right, *forward);
}

void SceneObject::PlaneTangents(Vec3d* u, Vec3d* v) const {
  const Vec3d ref = std::abs(normal.x) > 0.9 ? Vec3d{0, 1, 0} : Vec3d{1, 0, 0};
  *u = Normalize(Cross(normal, ref));
  *v = Cross(normal, *u);
}

bool Scene::HasSurfaceObjects() const {
  for (const SceneObject& o : objects) {
    if (o.IsSurface()) return true;
  }
  return false;
}

int Scene::EnvironmentLight() const {
  for (std::size_t i = 0; i < lights.size(); ++i) {
    if (lights[i].type == Light::Type::kEnvironment || lights[i].type == Light::Type::kUniform) {
      return static_cast<int>(i);
    }
  }
  return -1;
}

Scene ParseScene(const std::string& text, const std::string& name) {
  toml::table root;
  try {
    root = toml::parse(text, name);
  } catch (const toml::parse_error& e) {
    throw Error(fmt::format("{}:{}", name, e.source().begin.line), "",
                fmt::format("malformed TOML: {}", e.description()));
  }
  Scene scene;
  scene.path = name;
  scene.source_text = text;
  const std::string dir = fs::path(name).parent_path().string();
  TableReader top(root, name, "");
  top.CheckKeys({"camera", "objects", "lights", "background"});

  const toml::table* cam = root["camera"].as_table();
  if (cam) {
    ParseCamera(TableReader(*cam, name, "camera."), &scene.camera);
  } else if (!NormalMapCamera(root, name, dir, &scene.camera)) {
    top.Fail("camera", "missing [camera] table");
  }

  auto for_each_table = [&](const char* key, auto&& fn) {
    const toml::node* node = root.get(key);
    if (!node) return;
    const toml::array* arr = node->as_array();
    if (!arr) top.Fail(key, fmt::format("expected [[{}]] tables", key), node);
    for (std::size_t i = 0; i < arr->size(); ++i) {
      const toml::table* t = (*arr)[i].as_table();
      if (!t) top.Fail(key, fmt::format("expected [[{}]] tables", key), node);
      fn(TableReader(*t, name, fmt::format("{}[{}].", key, i)));
    }
  };
  for_each_table("objects", [&](const TableReader& r) {
    scene.objects.push_back(ParseObject(r, dir, scene.camera));
    const SceneObject& o = scene.objects.back();
    // One G-buffer path per scene: the analytic ray cast or the surface objects' raster.
    if (scene.objects.size() > 1 && o.IsSurface() != scene.objects.front().IsSurface()) {
      r.Fail("type", "a scene holds analytic objects (sphere, plane) or surface objects (mesh, "
                     "normal_map), not both: make a ground plane a mesh");
    }
    if (o.type == SceneObject::Type::kNormalMap && scene.objects.size() > 1) {
      r.Fail("type", "a normal_map object is the whole picture: it must be the only object");
    }
  });
  for_each_table("lights", [&](const TableReader& r) {
    scene.lights.push_back(ParseLight(r, dir));
    const Light::Type t = scene.lights.back().type;
    if ((t == Light::Type::kEnvironment || t == Light::Type::kUniform) &&
        scene.EnvironmentLight() != static_cast<int>(scene.lights.size()) - 1) {
      r.Fail("type", "only one environment or uniform light per scene");
    }
  });
  if (scene.objects.empty()) top.Fail("objects", "the scene has no [[objects]]");
  if (scene.objects.size() > 8) top.Fail("objects", "at most 8 objects");
  if (scene.lights.size() > 8) top.Fail("lights", "at most 8 lights");

  if (scene.HasSurfaceObjects()) {
    // Environment light on surface objects is occluded per quadrature direction by ray casting
    // (a bit per direction and sample, render/src/surface_samples.h): bounded here.
    const int env = scene.EnvironmentLight();
    if (env >= 0 && scene.lights[env].samples > kMaxSurfaceEnvironmentSamples) {
      top.Fail(fmt::format("lights[{}].samples", env),
               fmt::format("at most {} on mesh or normal-map objects (each sample's directions "
                           "are ray cast once per geometry), got {}",
                           kMaxSurfaceEnvironmentSamples, scene.lights[env].samples));
    }
    std::vector<RayCaster::Part> parts;
    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
      if (scene.objects[i].mesh) parts.push_back({static_cast<int>(i), scene.objects[i].mesh});
    }
    scene.ray_caster = SharedRayCaster(std::move(parts));
  }

  if (const toml::table* bg = root["background"].as_table()) {
    TableReader r(*bg, name, "background.");
    r.CheckKeys({"transparent", "color"});
    scene.background.transparent = r.Bool("transparent", true);
    scene.background.color = r.Vector("color", {0, 0, 0}, false, true, 0.0);
  }
  return scene;
}

Scene LoadScene(const std::string& path) {
  // Not a FIFO or a device: a scene named /dev/zero would be read forever.
  const PathKind kind = KindOfPath(path, "scene");
  if (kind != PathKind::kMissing && kind != PathKind::kFile) {
    throw Error(path, "", "scene file is not a regular file");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "", "scene file not found or unreadable");
  std::stringstream ss;
  ss << in.rdbuf();
  return ParseScene(ss.str(), path);
}

Ray CameraRay(const Camera& cam, double px, double py) {
  Vec3d right, up, forward;
  cam.Basis(&right, &up, &forward);
  const double aspect = static_cast<double>(cam.width) / cam.height_px;
  // Normalised device coordinates, +y up; row 0 is the top of the picture.
  const double nx = 2.0 * px / cam.width - 1.0;
  const double ny = 1.0 - 2.0 * py / cam.height_px;
  Ray ray;
  if (cam.type == Camera::Type::kPerspective) {
    const double t = std::tan(0.5 * cam.fov_y_deg * 3.14159265358979323846 / 180.0);
    ray.origin = cam.position;
    ray.direction = Normalize(forward + right * (nx * t * aspect) + up * (ny * t));
  } else {
    const double h = 0.5 * cam.height;
    ray.origin = cam.position + right * (nx * h * aspect) + up * (ny * h);
    ray.direction = forward;
  }
  return ray;
}

bool Intersect(const Scene& scene, const Ray& ray, double t_min, double t_max, Hit* hit) {
  bool found = false;
  for (std::size_t i = 0; i < scene.objects.size(); ++i) {
    const SceneObject& o = scene.objects[i];
    double t = -1;
    if (o.type == SceneObject::Type::kSphere) {
      // Same robust form as render/shaders/scene.glsl (Haines et al. 2019).
      const double r = o.radius;
      const Vec3d oc = ray.origin - o.center;
      const double b = Dot(oc, ray.direction);
      const Vec3d qc = oc - ray.direction * b;
      const double disc = r * r - Dot(qc, qc);
      if (disc < 0) continue;
      const double c = Dot(oc, oc) - r * r;
      const double q = b > 0 ? -b - std::sqrt(disc) : -b + std::sqrt(disc);
      double t0 = c / q, t1 = q;
      if (t0 > t1) std::swap(t0, t1);
      t = t0;
      if (t <= t_min) t = t1;
    } else {
      const double denom = Dot(o.normal, ray.direction);
      if (std::abs(denom) < 1e-12) continue;
      t = Dot(o.point - ray.origin, o.normal) / denom;
      if (o.half_u > 0) {
        Vec3d u, v;
        o.PlaneTangents(&u, &v);
        const Vec3d q = ray.origin + ray.direction * t - o.point;
        if (std::abs(Dot(q, u)) > o.half_u || std::abs(Dot(q, v)) > o.half_v) continue;
      }
    }
    if (o.IsSurface()) continue;  // The ray caster's, below.
    if (t <= t_min || t >= t_max) continue;
    t_max = t;
    found = true;
    if (hit) {
      hit->t = t;
      hit->object = static_cast<int>(i);
      hit->position = ray.origin + ray.direction * t;
      if (o.type == SceneObject::Type::kSphere) {
        hit->normal = (hit->position - o.center) / o.radius;
      } else {
        hit->normal = Dot(o.normal, ray.direction) < 0 ? o.normal : -o.normal;
      }
      hit->geometric_normal = hit->normal;
    }
  }
  if (!scene.ray_caster) return found;
  RayCaster::TriangleHit th;
  if (!scene.ray_caster->Nearest(ray, t_min, t_max, &th)) return found;
  if (hit) {
    const RayCaster::Part& part = scene.ray_caster->parts()[th.part];
    const SceneObject& o = scene.objects[part.object];
    hit->t = th.t;
    hit->object = part.object;
    hit->position = ray.origin + ray.direction * th.t;
    SurfaceFrame frame = MeshSurfaceFrame(o, th.triangle, th.u, th.v);
    const bool back = Dot(frame.geometric_normal, ray.direction) > 0;
    hit->geometric_normal = back ? -frame.geometric_normal : frame.geometric_normal;
    if (o.type == SceneObject::Type::kNormalMap) {
      // The data's normal at the pixel whose centre is nearest (the pixels are the vertices).
      const std::uint32_t* idx = &part.mesh->indices[3 * th.triangle];
      const double w[3] = {1 - th.u - th.v, th.u, th.v};
      const std::uint32_t v = idx[w[0] >= w[1] && w[0] >= w[2] ? 0 : (w[1] >= w[2] ? 1 : 2)];
      frame.normal = Vec3d{o.pixels->normal[3 * v], o.pixels->normal[3 * v + 1],
                           o.pixels->normal[3 * v + 2]};
      hit->normal = frame.normal;
    } else {
      hit->normal = back ? -frame.normal : frame.normal;
    }
  }
  return true;
}

SurfaceFrame MeshSurfaceFrame(const SceneObject& o, unsigned triangle, double u, double v) {
  const TriangleMesh& m = *o.mesh;
  const std::uint32_t* i = &m.indices[3 * triangle];
  const double w[3] = {1 - u - v, u, v};
  SurfaceFrame f;
  const Vec3d p0 = m.Position(i[0]), p1 = m.Position(i[1]), p2 = m.Position(i[2]);
  const Vec3d ng = Cross(p1 - p0, p2 - p0);
  const double len = Length(ng);
  f.geometric_normal = len > 0 ? ng / len : Vec3d{0, 0, 1};
  Vec3d n{0, 0, 0};
  for (int k = 0; k < 3; ++k) n += m.Normal(i[k]) * w[k];
  const double nl = Length(n);
  f.normal = nl > 1e-12 ? n / nl : f.geometric_normal;
  if (o.normal_map && !m.uvs.empty()) {
    double uv[2] = {0, 0};
    Vec3d t{0, 0, 0};
    double hand = 0;
    for (int k = 0; k < 3; ++k) {
      uv[0] += w[k] * m.uvs[2 * i[k]];
      uv[1] += w[k] * m.uvs[2 * i[k] + 1];
      t += Vec3d{m.tangents[4 * i[k]], m.tangents[4 * i[k] + 1], m.tangents[4 * i[k] + 2]} * w[k];
      hand += w[k] * m.tangents[4 * i[k] + 3];
    }
    // The interpolated frame, orthonormalised as the GLSL twin does (render/shaders/surface.glsl).
    t = t - f.normal * Dot(f.normal, t);
    const double tl = Length(t);
    if (tl > 1e-12) {
      t = t / tl;
      const Vec3d b = Cross(f.normal, t) * (hand < 0 ? -1.0 : 1.0);
      const Vec3d ts = o.normal_map->Sample(uv[0], uv[1]);
      f.normal = Normalize(t * ts.x + b * ts.y + f.normal * ts.z);
    }
  }
  return f;
}

}  // namespace shadefit
