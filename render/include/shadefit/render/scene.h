// Scenes: camera, analytic objects, lights, background (format in docs/scenes.md).
// World coordinates are Blender's (+Z up); the conventions match Blender Cycles.
#pragma once

#include <string>
#include <vector>

#include "shadefit/render/vec.h"

namespace shadefit {

struct Camera {
  enum class Type { kPerspective, kOrthographic };
  Type type = Type::kPerspective;
  Vec3d position{0, -6, 0};
  Vec3d look_at{0, 0, 0};
  Vec3d up{0, 0, 1};
  double fov_y_deg = 22.0;   // Perspective: full vertical field of view.
  double height = 2.4;       // Orthographic: full vertical extent in world units.
  int width = 256;
  int height_px = 256;
  int supersample = 1;       // N x N samples per pixel; 1 samples the pixel centre.

  // Orthonormal basis: right (+x on screen), up (+y), forward (view direction, camera -Z).
  void Basis(Vec3d* right, Vec3d* true_up, Vec3d* forward) const;
};

struct SceneObject {
  enum class Type { kSphere, kPlane };
  Type type = Type::kSphere;
  Vec3d center{0, 0, 0};   // Sphere.
  double radius = 1.0;
  Vec3d point{0, 0, 0};    // Plane: a point on it, its normal, optional half extents
  Vec3d normal{0, 0, 1};   //   along its tangents (0 = infinite).
  double half_u = 0.0, half_v = 0.0;
  void PlaneTangents(Vec3d* u, Vec3d* v) const;
};

struct Light {
  enum class Type { kPoint, kDirectional, kAmbient, kEnvironment, kUniform };
  Type type = Type::kPoint;
  Vec3d position{0, 0, 0};    // Point.
  Vec3d direction{0, 0, -1};  // Directional: unit direction in which the light travels.
  Vec3d value{0, 0, 0};       // Point: intensity W/sr; directional: irradiance W/m^2;
                              // ambient, uniform: radiance.
  std::string file;           // Environment: equirectangular map (absolute path).
  double strength = 1.0;      // Environment: radiance scale.
  double rotation_z_deg = 0;  // Environment: rotation about +Z.
  int samples = 256;          // Environment, uniform: samples per technique per pixel.
};

struct Background {
  bool transparent = true;    // Cycles film_transparent: RGB premultiplied, alpha = coverage.
  Vec3d color{0, 0, 0};
};

struct Scene {
  std::string path;          // Where it was read from ("" when parsed from a string).
  std::string source_text;   // The TOML text, kept for provenance (EXR metadata, sidecars).
  Camera camera;
  std::vector<SceneObject> objects;
  std::vector<Light> lights;
  Background background;

  // Index of the environment or uniform light, -1 when there is none (at most one allowed).
  int EnvironmentLight() const;
};

// Parses and validates a scene. Throws shadefit::Error "<file>:<line>: <key>: <problem>".
Scene LoadScene(const std::string& path);
Scene ParseScene(const std::string& text, const std::string& name);

// --- CPU geometry with the same conventions as the GL renderer (render/shaders/scene.glsl). ---

struct Ray {
  Vec3d origin, direction;
};

// Ray through the image point (px, py) in pixel units, origin top-left: the centre of pixel
// (i, j) is (i + 0.5, j + 0.5).
Ray CameraRay(const Camera& camera, double px, double py);

struct Hit {
  double t = 0;
  int object = -1;
  Vec3d position, normal;  // Normal faces the ray origin for planes (two-sided).
};

// Nearest hit with t in (t_min, t_max); false when none.
bool Intersect(const Scene& scene, const Ray& ray, double t_min, double t_max, Hit* hit);

// Pixels [x0, x1) x [y0, y1), row 0 on top.
struct PixelRect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  bool empty() const { return x0 >= x1 || y0 >= y1; }
  int width() const { return x1 - x0; }
  int height() const { return y1 - y0; }
};

// The pixels of the frame whose square meets the projection of an object, grown by the GL ray
// cast's float rounding: no camera ray outside them, of any supersample, hits an object. Exact
// projected bounds of spheres (render/src/screen_bounds.cpp), corner hulls of bounded planes;
// the whole frame for an unbounded plane or an object reaching the camera plane.
PixelRect ObjectPixelBounds(const Scene& scene);

// A convex polygon in continuous pixel coordinates (x right, y down, as CameraRay's).
struct PixelPoint {
  double x = 0, y = 0;
};
using PixelPolygon = std::vector<PixelPoint>;

// Convex polygons, at most one per object, whose union holds the centre of every pixel whose
// square meets an object's projection, grown by the GL ray cast's float rounding: the proxy a
// bounded frame rasterises instead of ObjectPixelBounds' rectangle (a sphere's disc fills pi / 4
// of its square). A sphere gets a 16-gon about its silhouette, a bounded plane its projected
// corners. None, with *whole_frame set, when an object cannot be bounded (as ObjectPixelBounds).
std::vector<PixelPolygon> ObjectPixelPolygons(const Scene& scene, bool* whole_frame);

}  // namespace shadefit
