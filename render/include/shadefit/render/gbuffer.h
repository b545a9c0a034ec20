// The G-buffer (what the GL renderer saw at each pixel centre) and the C++ twin of the shading
// pass evaluated on it. The fitter's exact-derivative path and the GLSL-vs-C++ test use this.
#pragma once

#include <cstdint>
#include <vector>

#include "shadefit/render/image.h"
#include "shadefit/render/models.h"
#include "shadefit/render/scene.h"

namespace shadefit {

struct GBuffer {
  int width = 0, height = 0;
  Image position;  // xyz world position; w = object index + 1 (0 = background)
  Image normal;    // xyz unit normal facing the camera; w = coverage in [0, 1]
  Image view;      // xyz unit direction from the surface to the eye

  bool Hit(int x, int y) const { return position.at(x, y, 3) > 0.5f; }
  float Coverage(int x, int y) const { return normal.at(x, y, 3); }
};

// One light as seen from one pixel: unit direction to it and the irradiance it delivers at
// normal incidence (I / d^2 or E). Only lights above the surface and unoccluded are kept.
struct PixelLight {
  Vec3d l;
  Vec3d irradiance;
};

struct ShadingPoint {
  int x = 0, y = 0;
  int object = -1;                 // the scene object hit (the G-buffer's position.w - 1)
  Vec3d p;                         // world position (occlusion rays start here)
  Vec3d n, v;
  Vec3d ambient;                   // ambient radiance (times ka for classic models)
  std::vector<PixelLight> lights;  // point and directional lights: exact
  // Environment or uniform light as a fixed quadrature (AttachEnvironmentSamples): direction and
  // radiance times quadrature weight, so that it is shaded exactly like `lights`.
  std::vector<PixelLight> environment;
};

// True when every light of the scene is point, directional or ambient: the twin evaluates them
// exactly. Environment and uniform lights need the GL renderer or a quadrature (below).
bool TwinSupportsScene(const Scene& scene);

// Environment (or uniform) light for the twin: a quadrature whose directions and weights depend
// on the pixel and on these settings only, never on the model's parameters. The estimate
//   L_o = sum_i f(l_i) (n.l_i) L_env(l_i) / (K sum_t p_t(l_i))
// over K samples of each technique t (multiple importance sampling with the balance heuristic,
// Veach and Guibas 1995): the environment's luminance distribution, cosine-weighted hemisphere,
// and one GGX half-vector distribution per entry of lobe_alphas (Walter et al. 2007, eqs. 35-36).
// Because nothing in it moves with the parameters, the twin's image is a smooth function of them
// and AutoDiff gives the derivative of the very estimate that is fitted. It is unbiased for
// every parameter value; lobe_alphas only set its variance (fitter: near the fitted lobe width).
struct EnvironmentQuadrature {
  int samples_per_technique = 64;
  std::vector<double> lobe_alphas;  // GGX widths of the specular proposals; empty = none.
  std::uint32_t seed = 0;           // Mixed into each pixel's Cranley-Patterson rotation.
};

// The scene's environment/uniform light as seen from each point, replacing point.environment.
// Samples below the horizon or occluded by another object are dropped. No-op without such a
// light. Throws shadefit::Error when the map cannot be read.
void AttachEnvironmentSamples(const Scene& scene, const EnvironmentQuadrature& quadrature,
                              std::vector<ShadingPoint>* points);

// The pixels with a hit and coverage >= min_coverage, with their light geometry.
std::vector<ShadingPoint> PrepareShading(const Scene& scene, const GBuffer& gbuffer,
                                         float min_coverage);

// Radiance of one shading point, RGB into out[0..2]; T = double or ceres::Jet. A `term` other
// than kReflect shades that term of the model alone, without ambient (as Renderer::Render).
template <typename T>
void ShadePoint(ModelId model, const T* params, const ShadingPoint& point, T* out,
                ModelTerm term = ModelTerm::kReflect) {
  T ka[3] = {T(0), T(0), T(0)};
  if (term == ModelTerm::kReflect) AmbientReflectance(model, params, ka);
  for (int c = 0; c < 3; ++c) out[c] = ka[c] * T(point.ambient[c]);
  for (const std::vector<PixelLight>* set : {&point.lights, &point.environment}) {
    for (const PixelLight& light : *set) {
      T f[3];
      Reflect(model, params, point.n, light.l, point.v, f, term);
      for (int c = 0; c < 3; ++c) out[c] += f[c] * T(light.irradiance[c]);
    }
  }
}

// Twin image (RGBA, alpha = coverage) for pixels with a hit; 0 elsewhere.
Image ShadeGBuffer(const Scene& scene, const GBuffer& gbuffer, ModelId model,
                   const std::vector<double>& params, ModelTerm term = ModelTerm::kReflect);

}  // namespace shadefit
