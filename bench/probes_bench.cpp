// Each probe on 256^2 references of a GGX material (kd 0.3, f0 0.04, roughness 0.3) under
// camera, side and rim point lights, one model under test (classic Blinn-Phong), GL renders
// (llvmpipe on the reference machine). Energy: 11 view angles, 64^2 white furnace.
#include <benchmark/benchmark.h>

#include "shadefit/probes/probes.h"
#include "shadefit/render/gl_context.h"
#include "shadefit/render/renderer.h"

namespace {

using namespace shadefit;

std::string Scene(const char* light) {
  return std::string(
             "[camera]\nposition = [0.0, -6.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\n"
             "up = [0.0, 0.0, 1.0]\nfov_y = 22.0\nresolution = [256, 256]\n"
             "[[objects]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n"
             "[[lights]]\ntype = \"point\"\npower = 1000.0\nposition = ") +
         light + "\n";
}

probes::ProbeInputs& Inputs() {
  static GlContext* context = new GlContext();
  static Renderer* renderer = new Renderer(*context);
  static probes::ProbeInputs* in = [] {
    auto* p = new probes::ProbeInputs;
    p->renderer = renderer;
    probes::ModelUnderTest truth{"truth", FindModel("ggx"), {0.3, 0.3, 0.3, 0.04, 0.04, 0.04, 0.3}};
    p->truth = truth;
    const std::pair<const char*, const char*> lights[] = {
        {"camera", "[0.0, -6.0, 0.0]"},
        {"side", "[4.9240388, 0.0, 0.8682409]"},
        {"rim", "[1.7677670, 4.3301270, 1.7677670]"}};
    for (const auto& [name, pos] : lights) {
      probes::ProbeReference r;
      r.name = std::string("ggx-") + name;
      r.lighting = name;
      r.scene = ParseScene(Scene(pos), r.name);
      r.gbuffer = renderer->RenderGBuffer(r.scene);
      r.image = renderer->Render(r.scene, ModelId::kGgx, truth.params);
      p->references.push_back(r);
    }
    probes::ModelUnderTest bp{
        "blinn-phong", FindModel("blinn-phong"), {0, 0, 0, 0.3, 0.3, 0.3, 0.3, 0.3, 0.3, 40}};
    bp.trained_on = {"ggx-camera"};
    p->models.push_back(bp);
    return p;
  }();
  return *in;
}

void BM_Fresnel(benchmark::State& s) {
  for (auto _ : s) benchmark::DoNotOptimize(probes::FresnelProbe(Inputs()));
}
void BM_Highlight(benchmark::State& s) {
  for (auto _ : s) benchmark::DoNotOptimize(probes::HighlightProbe(Inputs()));
}
void BM_Energy(benchmark::State& s) {
  for (auto _ : s) benchmark::DoNotOptimize(probes::EnergyProbe(Inputs()));
}
void BM_Portability(benchmark::State& s) {
  for (auto _ : s) benchmark::DoNotOptimize(probes::PortabilityProbe(Inputs()));
}
BENCHMARK(BM_Fresnel)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Highlight)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Energy)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_Portability)->Unit(benchmark::kMillisecond);

}  // namespace
