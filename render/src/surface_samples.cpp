#include "surface_samples.h"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <mutex>
#include <thread>

#include "shadefit/render/pixel_surface.h"
#include "shadefit/render/ray_caster.h"
#include "shadefit/render/shadows.h"

namespace shadefit::internal {
namespace {

// Runs fn(row) for every row on two threads (the machines this runs on have few cores; the
// study runner's workers use the rest).
template <typename F>
void ForEachRow(int rows, F&& fn) {
  const int threads = std::min(2, std::max(1, rows));
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    pool.emplace_back([&, t] {
      for (int y = t; y < rows; y += threads) fn(y);
    });
  }
  for (std::thread& th : pool) th.join();
}

Vec3d At3(const Image& img, int x, int y) {
  return {img.at(x, y, 0), img.at(x, y, 1), img.at(x, y, 2)};
}

}  // namespace

std::string SurfaceGeometryKey(const Scene& scene, int ss) {
  const Camera& c = scene.camera;
  std::string key = fmt::format(
      "{}|{:.17g},{:.17g},{:.17g}|{:.17g},{:.17g},{:.17g}|{:.17g},{:.17g},{:.17g}|{:.17g}|{:.17g}|"
      "{}x{}|{}",
      static_cast<int>(c.type), c.position.x, c.position.y, c.position.z, c.look_at.x,
      c.look_at.y, c.look_at.z, c.up.x, c.up.y, c.up.z, c.fov_y_deg, c.height, c.width,
      c.height_px, ss);
  for (const SceneObject& o : scene.objects) {
    key += fmt::format("|{}:{}:{}:{}", static_cast<int>(o.type),
                       static_cast<const void*>(o.mesh.get()),
                       static_cast<const void*>(o.normal_map.get()),
                       static_cast<const void*>(o.pixels.get()));
  }
  return key;
}

std::string SurfaceLightsKey(const Scene& scene, int ss) {
  std::string key = SurfaceGeometryKey(scene, ss);
  for (const Light& l : scene.lights) {
    if (l.type == Light::Type::kPoint) {
      key += fmt::format("|p{:.17g},{:.17g},{:.17g}", l.position.x, l.position.y, l.position.z);
    } else if (l.type == Light::Type::kDirectional) {
      key += fmt::format("|d{:.17g},{:.17g},{:.17g}", l.direction.x, l.direction.y, l.direction.z);
    }
  }
  return key;
}

SurfaceSamples PixelSurfaceSamples(const Scene& scene, int ss) {
  const PixelSurface& s = *scene.objects.at(0).pixels;
  SurfaceSamples out;
  out.ss = ss;
  out.width = s.width * ss;
  out.height = s.height * ss;
  out.position = Image(out.width, out.height, 4);
  out.normal = Image(out.width, out.height, 4);
  for (int y = 0; y < out.height; ++y) {
    for (int x = 0; x < out.width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y / ss) * s.width + x / ss;
      if (!s.mask[i]) continue;
      for (int c = 0; c < 3; ++c) {
        out.position.at(x, y, c) = s.position[3 * i + c];
        out.normal.at(x, y, c) = s.normal[3 * i + c];
      }
      out.position.at(x, y, 3) = 1.0f;  // Object 0.
      out.normal.at(x, y, 3) = 1.0f;
    }
  }
  return out;
}

SurfaceSamples RayCastSurfaceSamples(const Scene& scene, int ss) {
  if (scene.objects.size() == 1 && scene.objects[0].type == SceneObject::Type::kNormalMap) {
    return PixelSurfaceSamples(scene, ss);
  }
  SurfaceSamples out;
  out.ss = ss;
  out.width = scene.camera.width * ss;
  out.height = scene.camera.height_px * ss;
  out.position = Image(out.width, out.height, 4);
  out.normal = Image(out.width, out.height, 4);
  ForEachRow(out.height, [&](int y) {
    for (int x = 0; x < out.width; ++x) {
      const Ray ray = CameraRay(scene.camera, (x + 0.5) / ss, (y + 0.5) / ss);
      Hit hit;
      if (!Intersect(scene, ray, 0.0, 1e30, &hit)) continue;
      for (int c = 0; c < 3; ++c) {
        out.position.at(x, y, c) = static_cast<float>(hit.position[c]);
        out.normal.at(x, y, c) = static_cast<float>(hit.normal[c]);
      }
      out.position.at(x, y, 3) = static_cast<float>(hit.object + 1);
      out.normal.at(x, y, 3) = 1.0f;
    }
  });
  return out;
}

std::vector<std::uint32_t> SampleVisibility(const Scene& scene, const SurfaceSamples& samples) {
  struct L {
    bool point;
    Vec3d value;
  };
  std::vector<L> lights;
  for (const Light& l : scene.lights) {
    if (l.type == Light::Type::kPoint) lights.push_back({true, l.position});
    if (l.type == Light::Type::kDirectional) lights.push_back({false, -l.direction});
  }
  std::vector<std::uint32_t> bits(static_cast<std::size_t>(samples.width) * samples.height, 0u);
  ForEachRow(samples.height, [&](int y) {
    for (int x = 0; x < samples.width; ++x) {
      if (!(samples.position.at(x, y, 3) > 0.5f)) continue;
      const int object = static_cast<int>(samples.position.at(x, y, 3)) - 1;
      const Vec3d p = At3(samples.position, x, y);
      const Vec3d n = Normalize(At3(samples.normal, x, y));
      std::uint32_t b = 0;
      for (std::size_t i = 0; i < lights.size(); ++i) {
        Vec3d l = lights[i].value;
        double dist = 1e30;
        if (lights[i].point) {
          const Vec3d d = lights[i].value - p;
          dist = Length(d);
          l = d / dist;
        }
        if (LightReaches(scene, object, p, n, l, dist)) b |= 1u << i;
      }
      bits[static_cast<std::size_t>(y) * samples.width + x] = b;
    }
  });
  return bits;
}

GBuffer SurfaceGBuffer(const Scene& scene, const SurfaceSamples& centres,
                       const SurfaceSamples& samples) {
  const Camera& cam = scene.camera;
  GBuffer g;
  g.width = cam.width;
  g.height = cam.height_px;
  g.position = Image(g.width, g.height, 4);
  g.normal = Image(g.width, g.height, 4);
  g.view = Image(g.width, g.height, 4);
  const int ss = samples.ss;
  for (int y = 0; y < g.height; ++y) {
    for (int x = 0; x < g.width; ++x) {
      int hits = 0;
      for (int sy = 0; sy < ss; ++sy) {
        for (int sx = 0; sx < ss; ++sx) hits += samples.position.at(x * ss + sx, y * ss + sy, 3) > 0.5f;
      }
      const Ray ray = CameraRay(cam, x + 0.5, y + 0.5);
      for (int c = 0; c < 3; ++c) g.view.at(x, y, c) = static_cast<float>(-ray.direction[c]);
      g.normal.at(x, y, 3) = static_cast<float>(hits) / static_cast<float>(ss * ss);
      if (!(centres.position.at(x, y, 3) > 0.5f)) continue;
      for (int c = 0; c < 4; ++c) g.position.at(x, y, c) = centres.position.at(x, y, c);
      for (int c = 0; c < 3; ++c) g.normal.at(x, y, c) = centres.normal.at(x, y, c);
      if (cam.type == Camera::Type::kPerspective) {  // From the surface point to the eye.
        const Vec3d v = Normalize(cam.position - At3(centres.position, x, y));
        for (int c = 0; c < 3; ++c) g.view.at(x, y, c) = static_cast<float>(v[c]);
      }
    }
  }
  return g;
}

}  // namespace shadefit::internal

namespace shadefit {

bool LightReaches(const Scene& scene, int object, const Vec3d& p, const Vec3d& n, const Vec3d& l,
                  double dist) {
  if (Dot(n, l) <= 0) return false;
  if (!scene.ray_caster) {
    return !(scene.objects.size() > 1 &&
             Intersect(scene, Ray{p + n * kRayEpsilon, l}, 1e-4, dist, nullptr));
  }
  // A mesh's shadow ray starts on the surface and skips only kRayEpsilon along the light, as
  // Cycles' does (with its terminator offsets at 0, which the object references set): where the
  // smooth normal faces the light but the facet does not, the ray enters the solid and the point
  // is in shadow in both renderers. An offset along the shading normal would lift it over the
  // neighbouring facets instead (measured: lit pixels Cycles leaves black on the knot's tube).
  // A normal-map object's depth surface is a facet approximation of the data: its rays start 1.5
  // pixels out along the normal.
  double offset = 0;
  if (object >= 0 && object < static_cast<int>(scene.objects.size()) &&
      scene.objects[object].pixels) {
    offset = scene.objects[object].pixels->ray_offset;
  }
  return !scene.ray_caster->Occluded(Ray{p + n * offset, l}, kRayEpsilon, dist);
}

Image ShadowEdgeMask(const Scene& scene) {
  if (!scene.HasSurfaceObjects()) return Image();
  // A normal-map object alone gives every sample of a pixel the pixel's data
  // (PixelSurfaceSamples), so each sample sees the lights its pixel's centre sees: one sample per
  // pixel gives the same mask as 3 x 3, for a ninth of the rays and memory.
  const bool one_per_pixel =
      scene.objects.size() == 1 && scene.objects[0].type == SceneObject::Type::kNormalMap;
  const int ss = one_per_pixel ? 1 : std::max(3, scene.camera.supersample);
  const std::string key = internal::SurfaceLightsKey(scene, ss);
  static std::mutex mutex;
  static std::map<std::string, Image> cache;
  {
    std::lock_guard<std::mutex> lock(mutex);
    auto it = cache.find(key);
    if (it != cache.end()) return it->second;
  }
  const internal::SurfaceSamples samples = internal::RayCastSurfaceSamples(scene, ss);
  const std::vector<std::uint32_t> bits = internal::SampleVisibility(scene, samples);
  const int w = scene.camera.width, h = scene.camera.height_px;
  // Per pixel: its object (the one most of its samples hit), and the lights every sample of that
  // object sees (and) and any sees (or). A silhouette between two objects is no shadow edge.
  const std::size_t np = static_cast<std::size_t>(w) * h;
  std::vector<int> object(np, -1);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      int count[8] = {0, 0, 0, 0, 0, 0, 0, 0};
      for (int sy = 0; sy < ss; ++sy) {
        for (int sx = 0; sx < ss; ++sx) {
          const int id = static_cast<int>(samples.position.at(x * ss + sx, y * ss + sy, 3)) - 1;
          if (id >= 0 && id < 8) ++count[id];
        }
      }
      int best = 0;
      for (int k = 1; k < 8; ++k) best = count[k] > count[best] ? k : best;
      if (count[best] > 0) object[static_cast<std::size_t>(y) * w + x] = best;
    }
  }
  std::vector<std::uint32_t> all(np, ~0u), any(np, 0u);
  for (int y = 0; y < samples.height; ++y) {
    for (int x = 0; x < samples.width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y / ss) * w + x / ss;
      if (static_cast<int>(samples.position.at(x, y, 3)) - 1 != object[i] || object[i] < 0) continue;
      const std::uint32_t b = bits[static_cast<std::size_t>(y) * samples.width + x];
      all[i] &= b;
      any[i] |= b;
    }
  }
  Image mask(w, h, 1);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * w + x;
      if (object[i] < 0) continue;
      bool edge = all[i] != any[i];
      for (int dy = -1; dy <= 1 && !edge; ++dy) {
        for (int dx = -1; dx <= 1 && !edge; ++dx) {
          const int nx = x + dx, ny = y + dy;
          if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
          const std::size_t j = static_cast<std::size_t>(ny) * w + nx;
          edge = object[j] == object[i] && (any[j] != any[i] || all[j] != all[i]);
        }
      }
      mask.at(x, y, 0) = edge ? 1.0f : 0.0f;
    }
  }
  std::lock_guard<std::mutex> lock(mutex);
  return cache.emplace(key, std::move(mask)).first->second;
}

}  // namespace shadefit
