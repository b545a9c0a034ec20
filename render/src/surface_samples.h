// The surface path's per-sample geometry (renderer.cpp, "surface objects"): the G-buffer of every
// camera sample of a scene whose objects are meshes or a normal map, and each sample's light
// visibility. Internal to render/.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "shadefit/render/gbuffer.h"
#include "shadefit/render/image.h"
#include "shadefit/render/scene.h"

namespace shadefit::internal {

// Samples of a frame at `ss` per pixel side: texel (x * ss + sx, y * ss + sy) is the camera ray
// through (x + (sx + 0.5) / ss, y + (sy + 0.5) / ss). ss = 1: the pixel centres.
struct SurfaceSamples {
  int ss = 1, width = 0, height = 0;  // width = camera width * ss, ...
  Image position;  // xyz world, w = object + 1 (0 = nothing)
  Image normal;    // xyz unit shading normal facing the eye, w = 1 on a hit
};

// What the samples depend on: the camera and the objects (by identity of their loaded data).
std::string SurfaceGeometryKey(const Scene& scene, int ss);
// ... and what the visibility depends on besides: each point or directional light's place.
std::string SurfaceLightsKey(const Scene& scene, int ss);

// A normal-map object's samples: each sample takes its pixel's data (the data has one normal per
// pixel), so coverage is the mask.
SurfaceSamples PixelSurfaceSamples(const Scene& scene, int ss);

// The same samples by CPU ray casting (Intersect): what the GL raster of a mesh gives, up to float
// rounding. For the shadow-edge mask and tests.
SurfaceSamples RayCastSurfaceSamples(const Scene& scene, int ss);

// Bit i: point-or-directional light i (in the scene's order of such lights) reaches the sample
// (LightReaches). Ray cast on 2 threads.
std::vector<std::uint32_t> SampleVisibility(const Scene& scene, const SurfaceSamples& samples);

// The image's G-buffer from the pixel-centre samples (ss = 1) and the coverage of `samples`.
GBuffer SurfaceGBuffer(const Scene& scene, const SurfaceSamples& centres,
                       const SurfaceSamples& samples);

}  // namespace shadefit::internal
