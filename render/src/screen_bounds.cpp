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
  double max_margin = 0;  // The largest margin added (an object's float rounding and slack).
  void Add(double x, double y, double margin) {
    max_margin = std::max(max_margin, margin);
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

void AddObject(const View& view, const Camera& cam, const SceneObject& o, Extent* e) {
  if (o.IsSurface()) {  // The renderer's surface path reads its own G-buffer: no bounds here.
    e->full = true;
  } else if (o.type == SceneObject::Type::kSphere) {
    AddSphere(view, cam, o, e);
  } else {
    AddPlane(view, cam, o, e);
  }
}

// The pixels whose square [i, i + 1) meets the extent: every sample of them may hit.
PixelRect PixelsOf(const Extent& e, const Camera& cam) {
  const PixelRect frame{0, 0, cam.width, cam.height_px};
  if (!(e.x0 <= e.x1) || !(e.y0 <= e.y1)) return PixelRect{};  // Nothing in front.
  if (!std::isfinite(e.x0 + e.x1 + e.y0 + e.y1)) return frame;
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

// A convex polygon grown outward by `margin` pixels: each edge moved out along its normal, the
// new corners where neighbouring edges meet (the miter, n1 + n2 over 1 + n1.n2 for unit
// normals). False when an edge is degenerate (a plane seen edge-on): the caller falls back.
bool GrowConvex(double margin, PixelPolygon* poly) {
  const int n = static_cast<int>(poly->size());
  double area2 = 0, size = 1;
  for (int k = 0; k < n; ++k) {
    const PixelPoint& a = (*poly)[k];
    const PixelPoint& b = (*poly)[(k + 1) % n];
    area2 += a.x * b.y - a.y * b.x;
    size = std::max({size, std::abs(a.x), std::abs(a.y)});
  }
  // Relative to the corners' size: far off-screen corners round the sum by ~1e-16 size^2, and a
  // sign flipped by rounding would shrink the polygon instead of growing it.
  if (!(std::abs(area2) > 1e-9 * size * size)) return false;
  const double side = area2 > 0 ? 1.0 : -1.0;
  std::vector<PixelPoint> normal(n);
  for (int k = 0; k < n; ++k) {
    const PixelPoint& a = (*poly)[k];
    const PixelPoint& b = (*poly)[(k + 1) % n];
    const double ex = b.x - a.x, ey = b.y - a.y, len = std::hypot(ex, ey);
    if (!(len > 1e-9)) return false;
    normal[k] = {side * ey / len, -side * ex / len};
  }
  PixelPolygon grown(n);
  for (int k = 0; k < n; ++k) {
    const PixelPoint& n1 = normal[(k + n - 1) % n];
    const PixelPoint& n2 = normal[k];
    const double s = margin / (1.0 + n1.x * n2.x + n1.y * n2.y);
    grown[k] = {(*poly)[k].x + s * (n1.x + n2.x), (*poly)[k].y + s * (n1.y + n2.y)};
  }
  *poly = std::move(grown);
  return true;
}

// Corners of the sphere's silhouette 16-gon in pixels, before growing: the tangent cone from
// the eye touches the sphere along a circle (centre c (1 - r^2 / d^2), radius r sqrt(d^2 - r^2)
// / d); a polygon about that circle in its plane contains the flat disc every silhouette ray
// crosses, and projects to a convex polygon about the silhouette. Orthographic: the circle of
// radius r about the centre, in the image plane. False when a corner is not in front.
constexpr int kSilhouetteCorners = 16;
bool SphereCorners(const View& view, const Camera& cam, const SceneObject& o, PixelPolygon* poly) {
  const Vec3d c = view.Local(o.center);
  const double r = o.radius;
  const double grow = 1.0 / std::cos(std::numbers::pi / kSilhouetteCorners);
  poly->clear();
  if (view.ortho) {
    for (int k = 0; k < kSilhouetteCorners; ++k) {
      const double a = 2.0 * std::numbers::pi * k / kSilhouetteCorners;
      poly->push_back({view.PixelX(c.x + grow * r * std::cos(a), cam),
                       view.PixelY(c.y + grow * r * std::sin(a), cam)});
    }
    return true;
  }
  const double d2 = Dot(c, c);
  const Vec3d axis = c / std::sqrt(d2);
  const Vec3d centre = c * (1.0 - r * r / d2);
  const double radius = grow * r * std::sqrt(std::max(d2 - r * r, 0.0) / d2);
  // Any unit vector not along the axis, then the plane's basis.
  const Vec3d pick = std::abs(axis.x) < 0.9 ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0};
  const Vec3d a = Normalize(Cross(axis, pick));
  const Vec3d b = Cross(axis, a);
  for (int k = 0; k < kSilhouetteCorners; ++k) {
    const double t = 2.0 * std::numbers::pi * k / kSilhouetteCorners;
    const Vec3d p = centre + (a * std::cos(t) + b * std::sin(t)) * radius;
    if (!(p.z > 1e-3 * r)) return false;
    poly->push_back({view.PixelX(p.x / p.z, cam), view.PixelY(p.y / p.z, cam)});
  }
  return true;
}

// The projected corners of a bounded plane, in order around it.
void PlaneCorners(const View& view, const Camera& cam, const SceneObject& o, PixelPolygon* poly) {
  Vec3d u, v;
  o.PlaneTangents(&u, &v);
  poly->clear();
  for (const double su : {-1.0, 1.0}) {
    for (const double sv : {-1.0, 1.0}) {
      // (-,-), (-,+), (+,+), (+,-): around the rectangle.
      const double sv_around = su < 0 ? sv : -sv;
      const Vec3d p = view.Local(o.point + u * (su * o.half_u) + v * (sv_around * o.half_v));
      poly->push_back(view.ortho
                          ? PixelPoint{view.PixelX(p.x, cam), view.PixelY(p.y, cam)}
                          : PixelPoint{view.PixelX(p.x / p.z, cam), view.PixelY(p.y / p.z, cam)});
    }
  }
}

}  // namespace

PixelRect ObjectPixelBounds(const Scene& scene) {
  const Camera& cam = scene.camera;
  const View view(cam);
  Extent e;
  for (const SceneObject& o : scene.objects) {
    AddObject(view, cam, o, &e);
    if (e.full) return PixelRect{0, 0, cam.width, cam.height_px};
  }
  return PixelsOf(e, cam);
}

std::vector<PixelPolygon> ObjectPixelPolygons(const Scene& scene, bool* whole_frame) {
  const Camera& cam = scene.camera;
  const View view(cam);
  // A pixel's centre lies within half its diagonal of every point of its square, so growing by
  // that reaches every pixel any of its samples may hit.
  const double half_diagonal = 0.5 * std::numbers::sqrt2;
  std::vector<PixelPolygon> out;
  *whole_frame = false;
  for (const SceneObject& o : scene.objects) {
    Extent e;
    AddObject(view, cam, o, &e);
    if (e.full) {
      *whole_frame = true;
      return {};
    }
    if (!(e.x0 <= e.x1) || !(e.y0 <= e.y1)) continue;  // Behind the camera.
    if (!std::isfinite(e.x0 + e.x1 + e.y0 + e.y1)) {
      *whole_frame = true;
      return {};
    }
    PixelPolygon poly;
    const bool sphere = o.type == SceneObject::Type::kSphere;
    bool ok =
        sphere ? SphereCorners(view, cam, o, &poly) : (PlaneCorners(view, cam, o, &poly), true);
    ok = ok && GrowConvex(e.max_margin + half_diagonal, &poly);
    for (const PixelPoint& p : poly) ok = ok && std::isfinite(p.x) && std::isfinite(p.y);
    if (!ok) {
      // The pixels of the bounds instead (PixelsOf): their centres are inside these edges.
      const double x0 = std::floor(e.x0), x1 = std::ceil(e.x1);
      const double y0 = std::floor(e.y0), y1 = std::ceil(e.y1);
      poly = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
    }
    out.push_back(std::move(poly));
  }
  return out;
}

}  // namespace shadefit
