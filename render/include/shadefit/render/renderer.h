// The headless GL renderer: scene + model + parameters -> linear radiance, and the G-buffer.
#pragma once

#include <memory>
#include <vector>

#include "shadefit/render/gbuffer.h"
#include "shadefit/render/gl_context.h"
#include "shadefit/render/image.h"
#include "shadefit/render/models.h"
#include "shadefit/render/scene.h"

namespace shadefit {

struct RendererOptions {
  // On a transparent background, shade only the pixels inside ObjectPixelPolygons and read back
  // only ObjectPixelBounds (scene.h); every other pixel is what the shader would write there, 0
  // in all four channels. false: ray cast every pixel (the reference
  // tests/render/screen_bounds_test.cpp holds the bounded frame to).
  bool bound_objects = true;
};

class Renderer {
 public:
  // Every call makes `context` current on the calling thread first, so other contexts created
  // on the same thread in between do no harm; one renderer is used by one thread at a time.
  explicit Renderer(GlContext& context, const RendererOptions& options = {});
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // RGBA float: RGB = linear radiance (premultiplied when the background is transparent),
  // A = coverage. Row 0 is the top row. `term` other than kReflect renders that term of the
  // model alone in place of Reflect (no ambient): the twin test's view of each derived piece.
  Image Render(const Scene& scene, ModelId model, const std::vector<double>& params,
               ModelTerm term = ModelTerm::kReflect);

  // Position, normal + coverage, view direction at every pixel centre.
  GBuffer RenderGBuffer(const Scene& scene);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace shadefit
