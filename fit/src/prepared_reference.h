// A reference reduced to what the fit reads (internal to fit/): its valid pixels with their
// shading geometry and reference values, and under environment light on the twin path a
// subsample that carries the quadrature. Also the renderer a fit borrows or owns.
#pragma once

#include <memory>
#include <vector>

#include "shadefit/fit/fit_types.h"
#include "shadefit/fit/residuals.h"
#include "shadefit/render/gbuffer.h"
#include "shadefit/render/gl_context.h"
#include "shadefit/render/models.h"
#include "shadefit/render/renderer.h"
#include "shadefit/render/scene.h"

namespace shadefit::fit::internal {

struct PreparedReference {
  const FitReference* source = nullptr;
  std::string label;                 // File (or name) for error messages.
  Scene scene;                       // Environment sample count possibly overridden.
  std::vector<ShadingPoint> points;  // Valid pixels only.
  std::vector<int> pixels;           // y * width + x of each point.
  std::vector<double> linear;        // 3 reference values per point, linear radiance.
  std::vector<double> targets;       // 3 compressed reference values per point.
  double p99_norm = 0;               // 99th percentile of the RGB norm over valid pixels.
  std::unique_ptr<GlRenderCache> cache;
  // Environment or uniform light on the twin path: `points` is a subsample and carries the
  // quadrature; the RMSE is taken over every valid pixel (these) from a GL render.
  bool environment = false;
  std::vector<int> all_pixels;
  std::vector<double> all_linear;
};

// What Prepare renders: the reference's scene (environment sample count possibly overridden)
// and the shading points of its G-buffer, before any pixel is chosen. Checks the image's and the
// mask's size against the scene (shadefit::Error naming the file). Depends on the scene, the
// image's size and the mask's, not the pixel values: the encoding search's candidates, the same
// references decoded differently, share it.
struct ShadedScene {
  Scene scene;
  std::vector<ShadingPoint> points;
};
ShadedScene ShadeScene(const FitReference& ref, Renderer& renderer, int environment_samples,
                       long* gbuffer_renders);

// Finds the valid pixels: full coverage in the reference (alpha) and in our G-buffer, inside the
// mask, not clipped. Throws on non-finite values there, and when nothing (or only black) is left.
PreparedReference Prepare(const FitReference& ref, Renderer& renderer, int environment_samples,
                          long* gbuffer_renders);
// The same from the reference's ShadeScene.
PreparedReference PrepareFrom(const FitReference& ref, ShadedScene shaded);

// The pixels Prepare keeps and their values, without the shading points (what comparing a render
// with the reference needs): the same pixels in the same order, and the same errors.
struct UsablePixelValues {
  std::vector<int> pixels;     // y * width + x
  std::vector<double> linear;  // RGB of each
};
UsablePixelValues UsablePixels(const FitReference& ref, Renderer& renderer);

// Fit() with each reference's ShadeScene taken from `shaded` where it holds one per reference
// (made by an earlier call on references of the same scenes and sizes, as the encoding search's
// candidates are), else made and left there. nullptr: Fit().
FitResult FitSharingShading(const FitProblem& problem, const FitOptions& options,
                            std::vector<ShadedScene>* shaded);

// Keeps `want` of the valid pixels, half of them from the brightest tenth (highlights are few
// and carry the lobe's shape) and half by a regular stride through the rest. Deterministic.
void SubsampleForEnvironment(PreparedReference* r, int want);

// The GGX proposal widths of the environment quadrature: before anything is fitted, a
// defensive spread over the range real materials take (Hesterberg 1995, "Weighted average
// importance sampling and defensive mixture distributions"); once a lobe width is known, that
// width and three times it (the tail), so the samples follow the lobe the fit settled on.
std::vector<double> ProposalAlphas(ModelId model, const std::vector<double>& params, bool fitted);

// Attaches a quadrature with these proposal widths to every environment-lit reference.
void AttachQuadrature(std::vector<PreparedReference>& refs, std::vector<double> lobe_alphas,
                      int samples);

// Owns a GL context and renderer when the caller gave none.
struct RendererHolder {
  std::unique_ptr<GlContext> context;
  std::unique_ptr<Renderer> owned;
  Renderer* renderer = nullptr;
  explicit RendererHolder(Renderer* given);
};

}  // namespace shadefit::fit::internal
