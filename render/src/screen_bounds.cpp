// Screen-space bounds of a scene's objects: the pixels a frame must shade (scene.h).
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "shadefit/render/scene.h"

namespace shadefit {
namespace {

// Float rounding of the GL ray cast (camera basis, ray direction, object data are floats; about
// 8 ulps in all), as a fraction of the quantities involved.
constexpr double kFloatRelativeError = 1e-6;
// Slack in pixels added on every side beyond that, against rounding in this code itself.
constexpr double kMarginPixels = 0.05;

// A rectangle in continuous pixel coordinates (x right, y down, as CameraRay's).
struct Extent {
  double x0 = std::numeric_limits<double>::infinity(), y0 = x0;
  double x1 = -std::numeric_limits<double>::infinity(), y1 = x1;
  bool full = false;  // The whole frame (the object reaches the camera plane, or is unbounded).
  void Add(double x, double y, double margin) {
    x0 = std::min(x0, x - margin);
    x1 = std::max(x1, x + margin);
    y0 = std::min(y0, y - margin);
    y1 = std::max(y1, y + margin);
  }
};

struct View {
  Vec3d right, up, forward;
  double scale = 1;         // tan(fov_y / 2), or the orthographic half height.
  double aspect = 1;
  double pixels_per_unit;   // Pixels per unit of x/z (perspective) or of world x (ortho).
  bool ortho = false;
  Vec3d position;

  explicit View(const Camera& cam) {
    cam.Basis(&right, &up, &forward);
    ortho = cam.type == Camera::Type::kOrthographic;
    scale = ortho ? 0.5 * cam.height : std::tan(0.5 * cam.fov_y_deg * std::numbers::pi / 180.0);
    aspect = static_cast<double>(cam.width) / cam.height_px;
    pixels_per_unit = 0.5 * cam.height_px / scale;
    position = cam.position;
  }
  // Camera-space coordinates of a world point: x right, y up, z forward.
  Vec3d Local(const Vec3d& p) const {
    const Vec3d d = p - position;
    return {Dot(d, right), Dot(d, up), Dot(d, forward)};
  }
  // Image-plane coordinates (x/z, y/z for perspective; x, y for ortho) to pixels: the inverse
  // of CameraRay's nx = 2 px / W - 1, ny = 1 - 2 py / H.
  double PixelX(double u, const Camera& cam) const {
    return 0.5 * (u / (scale * aspect) + 1.0) * cam.width;
  }
  double PixelY(double v, const Camera& cam) const {
    return 0.5 * (1.0 - v / scale) * cam.height_px;
  }
};

// Perspective bounds of a sphere in front of the camera, one axis at a time: the planes through
// the eye and the other image axis that touch the sphere are the tangents of a circle of radius r
// about (a, z) in the 2D section (Mara and McGuire 2013, "2D Polyhedral Bounds of a Clipped,
// Perspective-Projected 3D Sphere", JCGT 2(2), sec. 3). Returns the [min, max] of x/z.
void TangentSlopes(double a, double z, double r, double* lo, double* hi) {
  const double t = std::sqrt(std::max(a * a + z * z - r * r, 0.0));  // tangent length
  *lo = (a * t - z * r) / (z * t + a * r);
  *hi = (a * t + z * r) / (z * t - a * r);
}

void AddSphere(const View& view, const Camera& cam, const SceneObject& o, Extent* e) {
  const Vec3d c = view.Local(o.center);
  const double r = o.radius;
  const double magnitude = Length(view.position) + Length(o.center) + r;
  if (view.ortho) {
    const double margin =
        kMarginPixels + kFloatRelativeError * magnitude * view.pixels_per_unit;
    e->Add(view.PixelX(c.x - r, cam), view.PixelY(c.y + r, cam), margin);
    e->Add(view.PixelX(c.x + r, cam), view.PixelY(c.y - r, cam), margin);
    return;
  }
  if (c.z + r <= 0) return;  // Wholly behind the camera: no ray (z > 0) reaches it.
  // Reaching the camera plane (or nearly so): its projection is unbounded.
  if (c.z - r <= 1e-3 * r) {
    e->full = true;
    return;
  }
  double xlo, xhi, ylo, yhi;
  TangentSlopes(c.x, c.z, r, &xlo, &xhi);
  TangentSlopes(c.y, c.z, r, &ylo, &yhi);
  const double margin = kMarginPixels + kFloatRelativeError * (1.0 + magnitude / (c.z - r)) *
                                            view.pixels_per_unit;
  e->Add(view.PixelX(xlo, cam), view.PixelY(yhi, cam), margin);
  e->Add(view.PixelX(xhi, cam), view.PixelY(ylo, cam), margin);
}

// A bounded plane is a rectangle: its projection lies in the hull of its corners' projections
// when all four are in front of the camera. An unbounded plane covers the frame.
void AddPlane(const View& view, const Camera& cam, const SceneObject& o, Extent* e) {
  if (!(o.half_u > 0)) {
    e->full = true;
    return;
  }
  Vec3d u, v;
  o.PlaneTangents(&u, &v);
  Vec3d corners[4];
  double z_min = std::numeric_limits<double>::infinity(), z_max = -z_min, magnitude = 0;
  for (int k = 0; k < 4; ++k) {
    const Vec3d p = o.point + u * ((k & 1) ? o.half_u : -o.half_u) +
                    v * ((k & 2) ? o.half_v : -o.half_v);
    corners[k] = view.Local(p);
    z_min = std::min(z_min, corners[k].z);
    z_max = std::max(z_max, corners[k].z);
    magnitude = std::max(magnitude, Length(p));
  }
  magnitude += Length(view.position);
  if (view.ortho) {
    const double margin =
        kMarginPixels + kFloatRelativeError * magnitude * view.pixels_per_unit;
    for (const Vec3d& c : corners) e->Add(view.PixelX(c.x, cam), view.PixelY(c.y, cam), margin);
    return;
  }
  if (z_max <= 0) return;
  const double extent = std::max(o.half_u, o.half_v);
  if (z_min <= 1e-3 * extent) {
    e->full = true;
    return;
  }
  const double margin =
      kMarginPixels + kFloatRelativeError * (1.0 + magnitude / z_min) * view.pixels_per_unit;
  for (const Vec3d& c : corners) {
    e->Add(view.PixelX(c.x / c.z, cam), view.PixelY(c.y / c.z, cam), margin);
  }
}

}  // namespace

PixelRect ObjectPixelBounds(const Scene& scene) {
  const Camera& cam = scene.camera;
  const PixelRect frame{0, 0, cam.width, cam.height_px};
  const View view(cam);
  Extent e;
  for (const SceneObject& o : scene.objects) {
    if (o.type == SceneObject::Type::kSphere) {
      AddSphere(view, cam, o, &e);
    } else {
      AddPlane(view, cam, o, &e);
    }
    if (e.full) return frame;
  }
  if (!(e.x0 <= e.x1) || !(e.y0 <= e.y1)) return PixelRect{};  // Nothing in front.
  if (!std::isfinite(e.x0 + e.x1 + e.y0 + e.y1)) return frame;
  // A pixel belongs when its square [i, i + 1) meets the extent: every sample of it may hit.
  auto clamp = [](double v, int hi) {
    return static_cast<int>(std::clamp(v, 0.0, static_cast<double>(hi)));
  };
  PixelRect r;
  r.x0 = clamp(std::floor(e.x0), cam.width);
  r.x1 = clamp(std::ceil(e.x1), cam.width);
  r.y0 = clamp(std::floor(e.y0), cam.height_px);
  r.y1 = clamp(std::ceil(e.y1), cam.height_px);
  if (r.x0 >= r.x1 || r.y0 >= r.y1) return PixelRect{};
  return r;
}

}  // namespace shadefit
