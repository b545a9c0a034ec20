#include "surface_samples.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <thread>

#include "shadefit/base/cpus.h"
#include "shadefit/base/made_once.h"
#include "shadefit/render/environment.h"
#include "shadefit/render/pixel_surface.h"
#include "shadefit/render/ray_caster.h"
#include "shadefit/render/shadows.h"

namespace shadefit::internal {
namespace {

// Runs fn(row) for every row on two threads, or one where this process may use one CPU (the
// machines this runs on have few cores; the study runner's workers use the rest).
template <typename F>
void ForEachRow(int rows, F&& fn) {
  const int threads = std::min({2, std::max(1, rows), UsableCpus()});
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

std::shared_ptr<const SurfaceSamples> KeptRayCastSurfaceSamples(const Scene& scene, int ss) {
  struct Entry {
    std::string key;
    std::shared_ptr<const SurfaceSamples> samples;
    std::vector<std::shared_ptr<const void>> data;  // Pins the addresses the key names.
  };
  constexpr std::size_t kBudgetBytes = std::size_t{256} << 20;
  static std::mutex mutex;
  static std::vector<Entry> kept;  // Most recent first.
  const std::string key = SurfaceGeometryKey(scene, ss);
  {
    std::lock_guard<std::mutex> lock(mutex);
    for (std::size_t i = 0; i < kept.size(); ++i) {
      if (kept[i].key != key) continue;
      std::rotate(kept.begin(), kept.begin() + static_cast<std::ptrdiff_t>(i),
                  kept.begin() + static_cast<std::ptrdiff_t>(i) + 1);
      return kept.front().samples;
    }
  }
  Entry entry{key, std::make_shared<const SurfaceSamples>(RayCastSurfaceSamples(scene, ss)), {}};
  for (const SceneObject& o : scene.objects) {
    entry.data.insert(entry.data.end(), {o.mesh, o.normal_map, o.pixels});
  }
  const auto bytes = [](const Entry& e) {
    return (e.samples->position.data.size() + e.samples->normal.data.size()) * sizeof(float);
  };
  std::shared_ptr<const SurfaceSamples> samples = entry.samples;
  std::lock_guard<std::mutex> lock(mutex);
  kept.insert(kept.begin(), std::move(entry));
  std::size_t total = 0, keep = 0;
  while (keep < kept.size() && (keep == 0 || total + bytes(kept[keep]) <= kBudgetBytes)) {
    total += bytes(kept[keep++]);
  }
  kept.resize(keep);
  return samples;
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

namespace {

// environment.glsl's RadicalInverse and PixelOffset, bit for bit (uint32 arithmetic, float out).
float RadicalInverseF(std::uint32_t bits) {
  return static_cast<float>(ReverseBits32(bits)) * 2.3283064365386963e-10f;
}

// Pixel (x, row from the top) of a frame `height` rows high; the shader counts rows from the
// bottom.
void PixelOffsetF(std::uint32_t x, std::uint32_t row, std::uint32_t height, float* o1, float* o2) {
  const std::uint32_t y = height - 1u - row;
  std::uint32_t h = x * 1973u + y * 9277u + 26699u;
  h = (h ^ (h >> 16u)) * 0x45d9f3bu;
  h = (h ^ (h >> 16u)) * 0x45d9f3bu;
  h ^= h >> 16u;
  *o1 = static_cast<float>(h & 0xFFFFu) / 65536.0f;
  *o2 = static_cast<float>(h >> 16u) / 65536.0f;
}

float FractF(float v) { return v - std::floor(v); }

struct Vec3f {
  float x, y, z;
};
Vec3f operator*(const Vec3f& a, float s) { return {a.x * s, a.y * s, a.z * s}; }
Vec3f operator+(const Vec3f& a, const Vec3f& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
Vec3f operator-(const Vec3f& a, const Vec3f& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
float DotF(const Vec3f& a, const Vec3f& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec3f CrossF(const Vec3f& a, const Vec3f& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
Vec3f NormalizeF(const Vec3f& a) { return a * (1.0f / std::sqrt(DotF(a, a))); }
Vec3f ToF(const Vec3d& v) {
  return {static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z)};
}
Vec3d ToD(const Vec3f& v) { return {v.x, v.y, v.z}; }

}  // namespace

int EnvironmentVisibilityWords(const Scene& scene) {
  const int index = scene.EnvironmentLight();
  return index < 0 ? 0 : (scene.lights[index].samples + 31) / 32;
}

std::vector<std::uint32_t> EnvironmentVisibility(const Scene& scene, const SurfaceSamples& samples,
                                                 EnvTechniques which, float lobe_alpha,
                                                 int* layers) {
  const int index = scene.EnvironmentLight();
  const int words = EnvironmentVisibilityWords(scene);
  const int techniques = which == EnvTechniques::kLightAndCosine ? 2 : 1;
  *layers = techniques * words;
  const std::size_t plane = static_cast<std::size_t>(samples.width) * samples.height;
  std::vector<std::uint32_t> bits(plane * static_cast<std::size_t>(*layers), 0u);
  if (index < 0) return bits;
  const Light& light = scene.lights[index];
  const int count = light.samples;
  // The light's own directions in world space: map_to_world (the transpose of the row-major
  // world_to_map) times the tabulated map-space directions; uniform light draws the sphere.
  std::vector<Vec3f> light_dirs;
  if (light.type == Light::Type::kEnvironment) {
    const auto map = LoadEnvironmentCached(light.file, light.strength, light.rotation_z_deg);
    const std::vector<float> tab = map->SampleSetMapSpace(count);
    float m[9];
    for (int i = 0; i < 9; ++i) m[i] = static_cast<float>(map->world_to_map()[i]);
    for (int i = 0; i < count; ++i) {
      const float* d = &tab[static_cast<std::size_t>(i) * 4];
      light_dirs.push_back({m[0] * d[0] + m[3] * d[1] + m[6] * d[2],
                            m[1] * d[0] + m[4] * d[1] + m[7] * d[2],
                            m[2] * d[0] + m[5] * d[1] + m[8] * d[2]});
    }
  }
  const Camera& cam = scene.camera;
  Vec3d right, up, forward;
  cam.Basis(&right, &up, &forward);
  const Vec3f eye = ToF(cam.position), back = ToF(-forward);
  const bool ortho = cam.type == Camera::Type::kOrthographic;
  const int ss = std::max(1, samples.ss);
  const float a2 = lobe_alpha * lobe_alpha;
  constexpr float kPiF = 3.14159265358979f;
  ForEachRow(samples.height, [&](int y) {
    for (int x = 0; x < samples.width; ++x) {
      if (!(samples.position.at(x, y, 3) > 0.5f)) continue;
      const int object = static_cast<int>(samples.position.at(x, y, 3)) - 1;
      const Vec3d p = At3(samples.position, x, y);
      const Vec3f pf = ToF(p);
      const Vec3f n = {samples.normal.at(x, y, 0), samples.normal.at(x, y, 1),
                       samples.normal.at(x, y, 2)};
      const Vec3d nd = Normalize(ToD(n));
      const Vec3f v = ortho ? back : NormalizeF(eye - pf);
      // environment.glsl's FrameAround(n): columns t, cross(n, t), n.
      const Vec3f t = std::abs(n.z) < 0.999f ? NormalizeF(CrossF({0, 0, 1}, n))
                                             : NormalizeF(CrossF({1, 0, 0}, n));
      const Vec3f b = CrossF(n, t);
      float o1, o2;
      PixelOffsetF(static_cast<std::uint32_t>(x / ss), static_cast<std::uint32_t>(y / ss),
                   static_cast<std::uint32_t>(cam.height_px), &o1, &o2);
      const std::size_t at = static_cast<std::size_t>(y) * samples.width + x;
      auto set = [&](int technique, int i, const Vec3f& l) {
        const Vec3d ld = ToD(l);
        if (!LightReaches(scene, object, p, nd, Normalize(ld), 1e30)) return;
        const std::size_t layer = static_cast<std::size_t>(technique * words + i / 32);
        bits[layer * plane + at] |= 1u << (i % 32);
      };
      for (int i = 0; i < count; ++i) {
        const float xi1 = FractF((static_cast<float>(i) + 0.5f) / static_cast<float>(count) + o1);
        const float xi2 = FractF(RadicalInverseF(static_cast<std::uint32_t>(i)) + o2);
        const float phi = 2.0f * kPiF * xi2;
        if (which == EnvTechniques::kLightAndCosine) {
          Vec3f l_env;
          if (light.type == Light::Type::kEnvironment) {
            l_env = light_dirs[static_cast<std::size_t>(i)];
          } else {
            const float z = 1.0f - 2.0f * xi1;
            const float r = std::sqrt(std::max(1.0f - z * z, 0.0f));
            l_env = {r * std::cos(phi), r * std::sin(phi), z};
          }
          set(0, i, l_env);
          const float r = std::sqrt(xi1);
          set(1, i, t * (r * std::cos(phi)) + b * (r * std::sin(phi)) +
                        n * std::sqrt(std::max(1.0f - xi1, 0.0f)));
        } else if (lobe_alpha > 0.0f) {
          const float cos2 = (1.0f - xi1) / (1.0f + (a2 - 1.0f) * xi1);
          const float sin_t = std::sqrt(std::max(1.0f - cos2, 0.0f));
          const Vec3f h = t * (sin_t * std::cos(phi)) + b * (sin_t * std::sin(phi)) +
                          n * std::sqrt(cos2);
          set(0, i, h * (2.0f * DotF(v, h)) - v);
        }
      }
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

namespace {

// ShadowEdgeMask's image at `ss` x `ss` samples a pixel, made anew.
Image MakeShadowEdgeMask(const Scene& scene, int ss) {
  const std::shared_ptr<const internal::SurfaceSamples> kept =
      internal::KeptRayCastSurfaceSamples(scene, ss);
  const internal::SurfaceSamples& samples = *kept;
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
  return mask;
}

}  // namespace

Image ShadowEdgeMask(const Scene& scene) {
  if (!scene.HasSurfaceObjects()) return Image();
  // A normal-map object alone gives every sample of a pixel the pixel's data
  // (PixelSurfaceSamples), so each sample sees the lights its pixel's centre sees: one sample per
  // pixel gives the same mask as 3 x 3, for a ninth of the rays and memory.
  const bool one_per_pixel =
      scene.objects.size() == 1 && scene.objects[0].type == SceneObject::Type::kNormalMap;
  const int ss = one_per_pixel ? 1 : std::max(3, scene.camera.supersample);
  // Made once per geometry and lights, as SelfOcclusion below.
  static MadeOnce<Image> made;
  return made.Get(internal::SurfaceLightsKey(scene, ss),
                  [&] { return MakeShadowEdgeMask(scene, ss); });
}

namespace {

// SelfOcclusion's image, made anew.
Image MakeSelfOcclusion(const Scene& scene) {
  const internal::SurfaceSamples centres =
      scene.objects.front().type == SceneObject::Type::kNormalMap
          ? internal::PixelSurfaceSamples(scene, 1)
          : internal::RayCastSurfaceSamples(scene, 1);
  // A 16 x 16 stratified grid over the unit square, mapped to the cosine-weighted hemisphere
  // (Malley's method): every direction carries the same weight.
  constexpr int kSide = 16;
  Image share(centres.width, centres.height, 1);
  internal::ForEachRow(centres.height, [&](int y) {
    for (int x = 0; x < centres.width; ++x) {
      if (!(centres.position.at(x, y, 3) > 0.5f)) continue;
      const int object = static_cast<int>(centres.position.at(x, y, 3)) - 1;
      const Vec3d p{centres.position.at(x, y, 0), centres.position.at(x, y, 1),
                    centres.position.at(x, y, 2)};
      const Vec3d n = Normalize(Vec3d{centres.normal.at(x, y, 0), centres.normal.at(x, y, 1),
                                      centres.normal.at(x, y, 2)});
      const Vec3d t = Normalize(std::abs(n.z) < 0.999 ? Cross(Vec3d{0, 0, 1}, n)
                                                      : Cross(Vec3d{1, 0, 0}, n));
      const Vec3d b = Cross(n, t);
      int hidden = 0;
      for (int i = 0; i < kSide * kSide; ++i) {
        const double u1 = (i % kSide + 0.5) / kSide, u2 = (i / kSide + 0.5) / kSide;
        const double r = std::sqrt(u1), phi = 2 * kPi * u2;
        const Vec3d l = Normalize(t * (r * std::cos(phi)) + b * (r * std::sin(phi)) +
                                  n * std::sqrt(std::max(0.0, 1.0 - u1)));
        hidden += !LightReaches(scene, object, p, n, l, 1e30);
      }
      share.at(x, y, 0) = static_cast<float>(hidden) / (kSide * kSide);
    }
  });
  return share;
}

}  // namespace

Image SelfOcclusion(const Scene& scene) {
  if (!scene.HasSurfaceObjects()) return Image();
  // Made once per geometry: every light of a photometric-stereo set has the same, and a study's
  // workers read the set's references side by side, each asking for it at once; the second now
  // waits for the first's (made on every core) instead of casting its ~24M rays again. The
  // 96-light 612 x 512 set's read stage: 10.1-10.4 -> 7.5-7.7 job-s (BENCHMARKS.md).
  static MadeOnce<Image> made;
  return made.Get(internal::SurfaceGeometryKey(scene, 1),
                  [&] { return MakeSelfOcclusion(scene); });
}

}  // namespace shadefit
