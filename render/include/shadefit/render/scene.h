// Scenes: camera, analytic objects, lights, background (format in docs/scenes.md).
// World coordinates are Blender's (+Z up); the conventions match Blender Cycles.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "shadefit/render/mesh.h"
#include "shadefit/render/vec.h"

namespace shadefit {

// Environment (or uniform) light samples per technique on mesh and normal-map objects, whose
// occlusion is ray cast for every direction of every sample.
inline constexpr int kMaxSurfaceEnvironmentSamples = 1024;

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

struct PixelSurface;
class RayCaster;

struct SceneObject {
  // Spheres and planes are ray cast analytically; meshes and normal-map objects are "surface
  // objects": the GL renderer rasterises (or reads) them into a per-sample G-buffer and shades it,
  // and cast shadows come from ray casting their triangles (docs/scenes.md, "Objects").
  enum class Type { kSphere, kPlane, kMesh, kNormalMap };
  Type type = Type::kSphere;
  Vec3d center{0, 0, 0};   // Sphere.
  double radius = 1.0;
  Vec3d point{0, 0, 0};    // Plane: a point on it, its normal, optional half extents
  Vec3d normal{0, 0, 1};   //   along its tangents (0 = infinite).
  double half_u = 0.0, half_v = 0.0;
  // Mesh: world-space triangles (mesh.h) and an optional tangent-space normal map. Normal map:
  // the surface through the pixels (pixel_surface.h), whose `mesh` is its depth surface.
  std::shared_ptr<const TriangleMesh> mesh;
  std::shared_ptr<const NormalMap> normal_map;
  std::shared_ptr<const PixelSurface> pixels;
  bool IsSurface() const { return type == Type::kMesh || type == Type::kNormalMap; }
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

  // The triangles of the surface objects for CPU ray casting; null when there are none.
  std::shared_ptr<const RayCaster> ray_caster;

  // Index of the environment or uniform light, -1 when there is none (at most one allowed).
  int EnvironmentLight() const;
  // Whether any object is a mesh or a normal-map object (the renderer's surface path).
  bool HasSurfaceObjects() const;
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
  // Normal faces the ray origin for planes and surface objects (two-sided); for those it is the
  // shading normal (interpolated, normal-mapped) and geometric_normal the triangle's.
  Vec3d position, normal, geometric_normal;
};

// Nearest hit with t in (t_min, t_max); false when none. Surface objects through
// scene.ray_caster.
bool Intersect(const Scene& scene, const Ray& ray, double t_min, double t_max, Hit* hit);

// A mesh object's geometry at barycentrics (u, v) of a triangle: the face's unit normal (counter-
// clockwise front) and the shading normal (interpolated, then normal-mapped), both unflipped.
struct SurfaceFrame {
  Vec3d geometric_normal, normal;
};
SurfaceFrame MeshSurfaceFrame(const SceneObject& object, unsigned triangle, double u, double v);

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
