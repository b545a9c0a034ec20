// Shadows: the one test of whether a light reaches a surface point, and the pixels at a shadow's
// edge, which no pixel-centre renderer reproduces (docs/scenes.md, "Shadows").
#pragma once

#include "shadefit/render/image.h"
#include "shadefit/render/scene.h"

namespace shadefit {

// Whether a light in unit direction `l`, `dist` away (1e30 for a directional light), reaches the
// point p with shading normal n on object `object`: n.l > 0 and nothing in between. Shadow rays
// start kRayEpsilon along n (a normal-map object: 1.5 of its pixels, whose depth surface is a
// facet approximation). Analytic scenes cast shadows between objects only (a sphere or a plane
// cannot shadow itself); surface objects shadow themselves and each other. The one shadow test
// of the C++ twin (PrepareShading), the GL surface path's visibility and the measured renderer.
bool LightReaches(const Scene& scene, int object, const Vec3d& p, const Vec3d& n, const Vec3d& l,
                  double dist);

// Offset of shadow-ray origins along the normal in world units (scenes are metre-sized); the GLSL
// twin is kRayEpsilon in render/shaders/render.frag.
constexpr double kRayEpsilon = 1e-4;

// One channel, the frame's size: 1 where a point or directional light's visibility changes within
// the pixel's camera samples (camera.supersample^2, at least 3 x 3) or between the pixel and one
// of its 8 neighbours, else 0: the shadow's edge, where the reference's answer depends on
// sub-pixel geometry (and, in a photograph, on the light's size) that a fit cannot see. Only
// scenes with surface objects cast such shadows here; others give an empty image. CPU only (ray
// cast); cached by geometry and lights.
Image ShadowEdgeMask(const Scene& scene);

// One channel, the frame's size: at each pixel centre on a surface object, the share of the
// cosine-weighted hemisphere about its normal that the scene's geometry hides (LightReaches along
// 256 stratified directions, the same for every pixel); 0 elsewhere and empty for a scene
// without surface objects. Light from those directions, in a real scene, is light reflected by
// the object itself: where the share is large, interreflection (which this renderer, direct light
// only, does not reproduce) is strong (reference_images/reference.h, kInterreflectionShareMax).
// CPU only (ray cast); made once per geometry (a second caller waits for the first).
Image SelfOcclusion(const Scene& scene);

}  // namespace shadefit
