// Renderer speed: milliseconds per frame, float RGBA readback included, per model and size.
// Results and the command line are recorded in BENCHMARKS.md.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>

#include "shadefit/render/gl_context.h"
#include "shadefit/render/models.h"
#include "shadefit/render/renderer.h"
#include "shadefit/render/scene.h"

namespace shadefit {
namespace {

GlContext& SharedContext() {
  static GlContext* context = new GlContext();
  return *context;
}

Renderer& SharedRenderer() {
  static Renderer* renderer = new Renderer(SharedContext());
  return *renderer;
}

// Every pixel ray cast (RendererOptions::bound_objects = false): the frame before the bounds.
Renderer& FullScreenRenderer() {
  static Renderer* renderer = new Renderer(SharedContext(), RendererOptions{false});
  return *renderer;
}

Scene SphereScene(int size) {
  const std::string n = std::to_string(size);
  return ParseScene(
      "[camera]\nposition = [0.0, -6.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\n"
      "fov_y = 22.0\nresolution = [" + n + ", " + n + "]\n"
      "[[objects]]\ntype = \"sphere\"\n"
      "[[lights]]\ntype = \"point\"\nposition = [4.0, -4.0, 3.0]\npower = 1000.0\n",
      "bench.toml");
}

void RenderFrame(benchmark::State& state, const char* model_name, Renderer& renderer,
                 const Scene& scene) {
  const ModelInfo& model = FindModel(model_name);
  const std::vector<double> params = DefaultParams(model);
  renderer.Render(scene, model.id, params);  // Compile the program outside the timing.
  for (auto _ : state) {
    Image image = renderer.Render(scene, model.id, params);
    benchmark::DoNotOptimize(image.data.data());
  }
  state.counters["px"] = static_cast<double>(state.range(0) * state.range(0));
}

void BM_RenderFrame(benchmark::State& state, const char* model_name) {
  RenderFrame(state, model_name, SharedRenderer(), SphereScene(static_cast<int>(state.range(0))));
}

void BM_RenderFrameFullScreen(benchmark::State& state, const char* model_name) {
  RenderFrame(state, model_name, FullScreenRenderer(),
              SphereScene(static_cast<int>(state.range(0))));
}

void BM_GBuffer(benchmark::State& state) {
  const Scene scene = SphereScene(static_cast<int>(state.range(0)));
  Renderer& renderer = SharedRenderer();
  renderer.RenderGBuffer(scene);
  for (auto _ : state) {
    GBuffer g = renderer.RenderGBuffer(scene);
    benchmark::DoNotOptimize(g.position.data.data());
  }
}

#define SHADEFIT_RENDER_BENCH(name, model)                                             \
  BENCHMARK_CAPTURE(BM_RenderFrame, name, model)->Arg(256)->Arg(512)->Unit(benchmark::kMillisecond) \
      ->UseRealTime()
SHADEFIT_RENDER_BENCH(lambert, "lambert");
SHADEFIT_RENDER_BENCH(phong, "phong");
SHADEFIT_RENDER_BENCH(blinn_phong, "blinn-phong");
SHADEFIT_RENDER_BENCH(blinn_phong_normalized, "blinn-phong-normalized");
SHADEFIT_RENDER_BENCH(ggx, "ggx");
SHADEFIT_RENDER_BENCH(cycles_principled, "cycles-principled");
BENCHMARK_CAPTURE(BM_RenderFrameFullScreen, ggx, "ggx")->Arg(512)->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_RenderFrameFullScreen, lambert, "lambert")->Arg(512)
    ->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_GBuffer)->Arg(256)->Arg(512)->Unit(benchmark::kMillisecond)->UseRealTime();

// The environment-lit frame a GL-path fit renders: the sphere under Debian blender-data's studio
// map (read by path, as sphere-env.toml does), 64 samples per technique.
constexpr const char* kStudioMap = "/usr/share/blender/datafiles/studiolights/world/studio.exr";
void BM_RenderFrameEnvironment(benchmark::State& state, const char* model_name) {
  if (!std::filesystem::exists(kStudioMap)) {
    state.SkipWithError("blender-data's studio.exr is not installed");
    return;
  }
  const std::string n = std::to_string(state.range(0));
  const Scene scene = ParseScene(
      "[camera]\nposition = [0.0, -6.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\n"
      "fov_y = 22.0\nresolution = [" +
          n + ", " + n +
          "]\n"
          "[[objects]]\ntype = \"sphere\"\n"
          "[[lights]]\ntype = \"environment\"\nfile = \"" +
          std::string(kStudioMap) + "\"\nsamples = 64\n[background]\ntransparent = true\n",
      "bench-env.toml");
  RenderFrame(state, model_name, SharedRenderer(), scene);
}
BENCHMARK_CAPTURE(BM_RenderFrameEnvironment, cycles_principled, "cycles-principled")
    ->Arg(256)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace shadefit

BENCHMARK_MAIN();
