// The twin's environment quadrature (gbuffer.h, AttachEnvironmentSamples): per pixel, a fixed
// set of directions from several sampling techniques, each weighted with the balance heuristic
// over all of them (Veach and Guibas 1995, sec. 3 and 4). The GL renderer estimates the same
// integral with the same techniques, but its GGX proposal follows the model's current lobe width,
// so its sample directions move with the roughness parameter; here they never do.
#include <cmath>
#include <cstdint>
#include <memory>

#include "shadefit/render/brdf.h"
#include "shadefit/render/environment.h"
#include "shadefit/base/error.h"
#include "shadefit/render/gbuffer.h"
#include "shadefit/render/shadows.h"

namespace shadefit {
namespace {

// Same offset as kRayEpsilon in render/shaders/render.frag.
constexpr double kOcclusionEpsilon = 1e-4;


// Per-pixel Cranley-Patterson rotation of the Hammersley set: decorrelates pixels, and is a
// function of the pixel and the seed only.
void PixelOffset(int x, int y, std::uint32_t seed, double* o1, double* o2) {
  std::uint32_t h = static_cast<std::uint32_t>(x) * 1973u + static_cast<std::uint32_t>(y) * 9277u +
                    26699u + seed * 0x9E3779B9u;
  h = (h ^ (h >> 16u)) * 0x45d9f3bu;
  h = (h ^ (h >> 16u)) * 0x45d9f3bu;
  h ^= h >> 16u;
  *o1 = static_cast<double>(h & 0xFFFFu) / 65536.0;
  *o2 = static_cast<double>(h >> 16u) / 65536.0;
}

double Fract(double x) { return x - std::floor(x); }

// Orthonormal frame (t, b, n) around a unit normal, built as the GL shader's FrameAround
// (render/shaders/environment.glsl) builds it, so both estimators orient their samples alike.
void Frame(const Vec3d& n, Vec3d* t, Vec3d* b) {
  *t = std::abs(n.z) < 0.999 ? Normalize(Cross(Vec3d{0, 0, 1}, n))
                             : Normalize(Cross(Vec3d{1, 0, 0}, n));
  *b = Cross(n, *t);
}

// Density over solid angle of l = reflect(v, h) with h ~ D(h) (n.h): D (n.h) / (4 v.h).
double GgxLightPdf(const Vec3d& n, const Vec3d& v, const Vec3d& l, double alpha) {
  if (Dot(n, l) <= 0) return 0;
  const Vec3d h = Normalize(l + v);
  const double noh = Dot(n, h), voh = Dot(v, h);
  if (noh <= 0 || voh <= 0) return 0;
  const Vec3d nxh = Cross(n, h);
  return D_GGX(noh, Dot(nxh, nxh), alpha) * noh / (4.0 * voh);
}

}  // namespace

void AttachEnvironmentSamples(const Scene& scene, const EnvironmentQuadrature& q,
                              std::vector<ShadingPoint>* points) {
  const int index = scene.EnvironmentLight();
  if (index < 0) return;
  const Light& source = scene.lights[index];
  DistantLight light;
  if (source.type == Light::Type::kEnvironment) {
    light.map = LoadEnvironmentCached(source.file, source.strength, source.rotation_z_deg);
  } else {
    light.uniform = source.value;
  }
  const int k = std::max(1, q.samples_per_technique);
  const int techniques = 2 + static_cast<int>(q.lobe_alphas.size());
  const bool occlusion = scene.objects.size() > 1 || scene.HasSurfaceObjects();
  std::vector<Vec3d> dirs;
  dirs.reserve(static_cast<std::size_t>(k) * techniques);
  for (ShadingPoint& sp : *points) {
    sp.environment.clear();
    Vec3d t, b;
    Frame(sp.n, &t, &b);
    double o1, o2;
    PixelOffset(sp.x, sp.y, q.seed, &o1, &o2);
    dirs.clear();
    for (int i = 0; i < k; ++i) {
      const double u1 = Fract((i + 0.5) / k + o1);
      const double u2 = Fract(RadicalInverseBase2(static_cast<std::uint32_t>(i)) + o2);
      // 1. The light's own distribution.
      dirs.push_back(light.Sample(u1, u2));
      // 2. Cosine-weighted hemisphere (Malley's method).
      const double r = std::sqrt(u1), phi = 2 * kPi * u2;
      dirs.push_back(t * (r * std::cos(phi)) + b * (r * std::sin(phi)) +
                     sp.n * std::sqrt(std::max(0.0, 1.0 - u1)));
      // 3. GGX half vectors of each proposal width, reflected about v.
      for (double alpha : q.lobe_alphas) {
        const double a2 = alpha * alpha;
        const double cos2 = (1.0 - u1) / (1.0 + (a2 - 1.0) * u1);
        const double c = std::sqrt(std::max(0.0, cos2)), s = std::sqrt(std::max(0.0, 1.0 - cos2));
        const Vec3d h = t * (s * std::cos(phi)) + b * (s * std::sin(phi)) + sp.n * c;
        dirs.push_back(h * (2.0 * Dot(sp.v, h)) - sp.v);
      }
    }
    for (const Vec3d& l : dirs) {
      const double nol = Dot(sp.n, l);
      if (!(nol > 0)) continue;
      double pdf = light.Pdf(l) + nol / kPi;
      for (double alpha : q.lobe_alphas) pdf += GgxLightPdf(sp.n, sp.v, l, alpha);
      if (!(pdf > 0)) continue;
      // Surface objects: the shadow rays of their point lights and of the GL render's
      // environment visibility (LightReaches); analytic objects: as the shader casts them.
      if (scene.ray_caster ? !LightReaches(scene, sp.object, sp.p, sp.n, l, 1e30)
                           : occlusion && Intersect(scene, Ray{sp.p + sp.n * kOcclusionEpsilon, l},
                                                    1e-4, 1e30, nullptr)) {
        continue;
      }
      const Vec3d radiance = light.Radiance(l);
      if (radiance.x <= 0 && radiance.y <= 0 && radiance.z <= 0) continue;
      sp.environment.push_back(PixelLight{l, radiance / (k * pdf)});
    }
  }
}

}  // namespace shadefit
