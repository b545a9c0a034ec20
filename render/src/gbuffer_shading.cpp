#include "shadefit/render/gbuffer.h"

#include <cmath>

#include "shadefit/render/shadows.h"

namespace shadefit {

bool TwinSupportsScene(const Scene& scene) { return scene.EnvironmentLight() < 0; }

std::vector<ShadingPoint> PrepareShading(const Scene& scene, const GBuffer& g,
                                         float min_coverage) {
  std::vector<ShadingPoint> points;
  long covered = 0;  // Reserved up front: a grown vector would move every point again.
  for (int y = 0; y < g.height; ++y) {
    for (int x = 0; x < g.width; ++x) covered += g.Hit(x, y) && g.Coverage(x, y) >= min_coverage;
  }
  points.reserve(static_cast<std::size_t>(covered));
  Vec3d ambient{0, 0, 0};
  for (const Light& light : scene.lights) {
    if (light.type == Light::Type::kAmbient) ambient += light.value;
  }
  for (int y = 0; y < g.height; ++y) {
    for (int x = 0; x < g.width; ++x) {
      if (!g.Hit(x, y) || g.Coverage(x, y) < min_coverage) continue;
      ShadingPoint sp;
      sp.x = x;
      sp.y = y;
      sp.object = static_cast<int>(g.position.at(x, y, 3)) - 1;
      const Vec3d p{g.position.at(x, y, 0), g.position.at(x, y, 1), g.position.at(x, y, 2)};
      // Renormalised in double: float storage leaves |n| = 1 +- 1e-7, which a Blinn-Phong
      // exponent of 10^4 would turn into a 1e-3 error.
      sp.p = p;
      sp.n = Normalize(Vec3d{g.normal.at(x, y, 0), g.normal.at(x, y, 1), g.normal.at(x, y, 2)});
      sp.v = Normalize(Vec3d{g.view.at(x, y, 0), g.view.at(x, y, 1), g.view.at(x, y, 2)});
      sp.ambient = ambient;
      for (const Light& light : scene.lights) {
        PixelLight pl;
        double dist = 1e30;
        if (light.type == Light::Type::kPoint) {
          const Vec3d d = light.position - p;
          const double d2 = Dot(d, d);
          dist = std::sqrt(d2);
          pl.l = d / dist;
          pl.irradiance = light.value / d2;
        } else if (light.type == Light::Type::kDirectional) {
          pl.l = -light.direction;
          pl.irradiance = light.value;
        } else {
          continue;
        }
        const int object = static_cast<int>(g.position.at(x, y, 3)) - 1;
        if (!LightReaches(scene, object, p, sp.n, pl.l, dist)) continue;
        sp.lights.push_back(pl);
      }
      points.push_back(std::move(sp));
    }
  }
  return points;
}

Image ShadeGBuffer(const Scene& scene, const GBuffer& g, ModelId model,
                   const std::vector<double>& params, ModelTerm term) {
  Image out(g.width, g.height, 4);
  for (const ShadingPoint& sp : PrepareShading(scene, g, 0.0f)) {
    double rgb[3];
    ShadePoint(model, params.data(), sp, rgb, term);
    for (int c = 0; c < 3; ++c) out.at(sp.x, sp.y, c) = static_cast<float>(rgb[c]);
    out.at(sp.x, sp.y, 3) = g.Coverage(sp.x, sp.y);
  }
  return out;
}

}  // namespace shadefit
