// The surface path's per-sample geometry (renderer.cpp, "surface objects"): the G-buffer of every
// camera sample of a scene whose objects are meshes or a normal map, and each sample's light
// visibility. Internal to render/.
#pragma once

#include <cstdint>
#include <memory>
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

// RayCastSurfaceSamples, kept for the few geometries asked for last (within a byte budget):
// the frames of a data set share one geometry under many lights, and each light's shadow-edge
// mask casts its shadow rays from the same samples. The entries hold the objects' data, so that
// the addresses in their keys (SurfaceGeometryKey) name the same data while they are kept.
std::shared_ptr<const SurfaceSamples> KeptRayCastSurfaceSamples(const Scene& scene, int ss);

// Bit i: point-or-directional light i (in the scene's order of such lights) reaches the sample
// (LightReaches). Ray cast on 2 threads.
std::vector<std::uint32_t> SampleVisibility(const Scene& scene, const SurfaceSamples& samples);

// Environment (or uniform) light on surface objects: whether each of the quadrature directions
// environment.glsl's ShadeEnvironment draws at a sample reaches the sky (LightReaches, as the
// point lights' shadows), so that the shader occludes every quadrature sample of the
// environment exactly as the CPU ray caster does (issue 45, docs/scenes.md, "Shadows"). The
// directions are the shader's, computed here in the same float arithmetic from the same inputs
// (the pixel's Cranley-Patterson offset, the radical inverse, the frame around n, the light's
// tabulated directions and, for the GGX proposal, its width `lobe_alpha`): direction i of
// technique t of a sample is bit i % 32 of word layer t * words + i / 32, words = ceil(samples /
// 32). Techniques: 0 the light's own directions, 1 the cosine-weighted ones (both fixed per
// geometry and light), 2 the GGX proposal of width lobe_alpha (EnvTechniques::kLobe alone).
// Layer-major: layer k's words are samples.width * samples.height, row by row. Ray cast on 2
// threads.
enum class EnvTechniques { kLightAndCosine, kLobe };
std::vector<std::uint32_t> EnvironmentVisibility(const Scene& scene, const SurfaceSamples& samples,
                                                 EnvTechniques which, float lobe_alpha,
                                                 int* layers);
// Words per technique: ceil(the environment light's samples / 32).
int EnvironmentVisibilityWords(const Scene& scene);

// The image's G-buffer from the pixel-centre samples (ss = 1) and the coverage of `samples`.
GBuffer SurfaceGBuffer(const Scene& scene, const SurfaceSamples& centres,
                       const SurfaceSamples& samples);

}  // namespace shadefit::internal
