// Fitting benchmarks (issue "fitting", acceptance 6): a GGX fit to one 256x256 reference (a unit
// sphere under a key light, rendered by our renderer with known parameters), from the table
// defaults, on both derivative paths; and 16 starts on the G-buffer path. Counters report what
// the fit consumed: GL model renders (GL path), Ceres residual and Jacobian evaluations, and the
// render floor (renders x the measured time of one render) for comparison.
//
// Targets on a 2-core machine with llvmpipe: single start <= 0.3 s, 16 starts <= 3 s.
#include <benchmark/benchmark.h>

#include <chrono>

#include "shadefit/fit/fitter.h"
#include "shadefit/render/gl_context.h"
#include "shadefit/render/renderer.h"

namespace shadefit {
namespace {

Renderer& SharedRenderer() {
  static GlContext* context = new GlContext();
  static Renderer* renderer = new Renderer(*context);
  return *renderer;
}

const char* kSceneToml = R"(
[camera]
position = [0.0, -6.0, 0.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 0.0, 1.0]
fov_y = 22.0
resolution = [256, 256]
[[objects]]
type = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0
[[lights]]
type = "point"
position = [2.5, -3.5355339, 2.5]
power = 600.0
)";

// kd (0.6, 0.3, 0.1), f0 0.04, roughness 0.3: a red plastic.
const std::vector<double> kTruth = {0.6, 0.3, 0.1, 0.04, 0.04, 0.04, 0.3};

fit::FitProblem Problem() {
  static const fit::FitReference ref = [] {
    fit::FitReference r;
    r.name = "bench";
    r.scene = ParseScene(kSceneToml, "bench.toml");
    r.image = SharedRenderer().Render(r.scene, FindModel("ggx").id, kTruth);
    return r;
  }();
  fit::FitProblem problem;
  problem.model = FindModel("ggx");
  problem.references = {ref};
  return problem;
}

double MsPerRender() {
  static const double ms = [] {
    const fit::FitProblem p = Problem();
    SharedRenderer().Render(p.references[0].scene, FindModel("ggx").id, kTruth);  // Warm up.
    const int n = 10;
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < n; ++i) {
      SharedRenderer().Render(p.references[0].scene, FindModel("ggx").id, kTruth);
    }
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
               .count() / n;
  }();
  return ms;
}

void RunFit(benchmark::State& state, fit::DerivativePath path, int starts) {
  const fit::FitProblem problem = Problem();
  fit::FitOptions options;
  options.renderer = &SharedRenderer();
  options.path = path;
  options.starts = starts;
  options.render_outputs = false;
  options.compute_covariance = false;
  fit::FitResult r;
  for (auto _ : state) {
    r = fit::Fit(problem, options);
    benchmark::DoNotOptimize(r.final_cost);
  }
  state.counters["model_renders"] = static_cast<double>(r.renders);
  state.counters["gbuffer_renders"] = static_cast<double>(r.gbuffer_renders);
  state.counters["residual_evals"] = static_cast<double>(r.residual_evaluations);
  state.counters["jacobian_evals"] = static_cast<double>(r.jacobian_evaluations);
  state.counters["iterations"] = r.iterations;
  state.counters["ms_per_render"] = MsPerRender();
  state.counters["render_floor_s"] = r.renders * MsPerRender() / 1000.0;
  state.counters["roughness_err"] = std::abs(r.values[6] - kTruth[6]) / kTruth[6];
  state.counters["converged"] = r.converged ? 1 : 0;
}

void BM_GgxSingleStartGBuffer(benchmark::State& state) {
  RunFit(state, fit::DerivativePath::kGBuffer, 1);
}
void BM_GgxSingleStartGl(benchmark::State& state) { RunFit(state, fit::DerivativePath::kGl, 1); }
void BM_Ggx16StartsGBuffer(benchmark::State& state) {
  RunFit(state, fit::DerivativePath::kGBuffer, 16);
}

BENCHMARK(BM_GgxSingleStartGBuffer)->Unit(benchmark::kMillisecond)->Iterations(5)->Repetitions(3);
BENCHMARK(BM_GgxSingleStartGl)->Unit(benchmark::kMillisecond)->Iterations(1)->Repetitions(3);
BENCHMARK(BM_Ggx16StartsGBuffer)->Unit(benchmark::kMillisecond)->Iterations(1)->Repetitions(3);

}  // namespace
}  // namespace shadefit
