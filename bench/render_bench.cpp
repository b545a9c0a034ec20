// Renderer speed: milliseconds per frame, float RGBA readback included, per model and size.
// Results and the command line are recorded in BENCHMARKS.md.
#include <benchmark/benchmark.h>

#include <cmath>
#include <filesystem>
#include <fstream>
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

namespace shadefit {
namespace {

// Surface objects (issue 45 item 7): a UV sphere of 100,352 triangles, written once as OBJ.
std::string HundredKMesh() {
  static const std::string path = [] {
    const std::string p =
        (std::filesystem::temp_directory_path() / "shadefit_bench_sphere100k.obj").string();
    std::ofstream out(p);
    const int rings = 112, segments = 448;  // 2 * 112 * 448 = 100,352 triangles.
    for (int i = 0; i <= rings; ++i) {
      const double th = M_PI * i / rings;
      for (int j = 0; j < segments; ++j) {
        const double ph = 2 * M_PI * j / segments;
        out << "v " << std::sin(th) * std::cos(ph) << " " << std::sin(th) * std::sin(ph) << " "
            << std::cos(th) << "\n";
      }
    }
    for (int i = 0; i < rings; ++i) {
      for (int j = 0; j < segments; ++j) {
        const int a = i * segments + j + 1, b = (i + 1) * segments + j + 1;
        const int c = (i + 1) * segments + (j + 1) % segments + 1, d = i * segments + (j + 1) % segments + 1;
        out << "f " << a << " " << b << " " << c << "\nf " << a << " " << c << " " << d << "\n";
      }
    }
    return p;
  }();
  return path;
}

// The mesh sphere where SphereScene has the analytic one; `shift` moves the camera or the light
// by a hair so that the renderer's per-geometry or per-light caches miss.
Scene MeshScene(int size, double camera_shift, double light_shift) {
  const std::string n = std::to_string(size);
  return ParseScene(
      "[camera]\nposition = [" + std::to_string(camera_shift) + ", -6.0, 0.0]\nlook_at = [0.0, "
      "0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nfov_y = 22.0\nresolution = [" + n + ", " + n + "]\n"
      "[[objects]]\ntype = \"mesh\"\nfile = \"" + HundredKMesh() + "\"\n"
      "[[lights]]\ntype = \"point\"\nposition = [" + std::to_string(4.0 + light_shift) +
      ", -4.0, 3.0]\npower = 1000.0\n",
      "bench.toml");
}

// The G-buffer of a new geometry: raster of 100k triangles, readback, the image's G-buffer.
void BM_MeshGBuffer(benchmark::State& state) {
  Renderer& renderer = SharedRenderer();
  int k = 0;
  for (auto _ : state) {
    state.PauseTiming();
    const Scene scene = MeshScene(static_cast<int>(state.range(0)), 1e-6 * (++k % 2), 0);
    state.ResumeTiming();
    GBuffer g = renderer.RenderGBuffer(scene);
    benchmark::DoNotOptimize(g.position.data.data());
  }
}
BENCHMARK(BM_MeshGBuffer)->Arg(512)->Unit(benchmark::kMillisecond)->UseRealTime();

// A frame of the mesh with its visibility cached (what every fit iteration pays).
void BM_MeshFrame(benchmark::State& state) {
  const Scene scene = MeshScene(static_cast<int>(state.range(0)), 0, 0);
  RenderFrame(state, "ggx", SharedRenderer(), scene);
}
BENCHMARK(BM_MeshFrame)->Arg(512)->Unit(benchmark::kMillisecond)->UseRealTime();

// A frame under a new light: the shadow precompute (Embree, one ray per sample) and the frame.
void BM_MeshFrameNewLight(benchmark::State& state) {
  Renderer& renderer = SharedRenderer();
  const ModelInfo& model = FindModel("ggx");
  const std::vector<double> params = DefaultParams(model);
  int k = 0;
  for (auto _ : state) {
    state.PauseTiming();
    const Scene scene = MeshScene(static_cast<int>(state.range(0)), 0, 1e-3 * ++k);
    state.ResumeTiming();
    Image image = renderer.Render(scene, model.id, params);
    benchmark::DoNotOptimize(image.data.data());
  }
}
BENCHMARK(BM_MeshFrameNewLight)->Arg(512)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace shadefit

BENCHMARK_MAIN();
