#include "fit_result.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <utility>

#include "shadefit/base/files.h"

namespace shadefit::fit::internal {
namespace {

double Mean(const std::vector<double>& v) {
  return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / v.size();
}

// Sum of squared linear errors and the number of pixels, over the reference's valid pixels.
struct SquaredError {
  double sum = 0;
  long pixels = 0;
};

SquaredError ReferenceError(const ModelInfo& model, bool gl, const FitResult& result,
                            Renderer* renderer, PreparedReference& r) {
  SquaredError e;
  if (gl || r.environment) {
    // A GL render over every valid pixel (the environment twin fitted a subsample).
    Image env_render;
    if (r.environment) env_render = renderer->Render(r.scene, model.id, result.values);
    const Image& image = gl ? r.cache->Get(result.values) : env_render;
    const std::vector<int>& pixels = r.environment ? r.all_pixels : r.pixels;
    const std::vector<double>& linear = r.environment ? r.all_linear : r.linear;
    for (std::size_t k = 0; k < pixels.size(); ++k) {
      for (int c = 0; c < 3; ++c) {
        const double x = image.data[static_cast<std::size_t>(pixels[k]) * image.channels + c];
        const double d = result.exposure * x - linear[3 * k + c];
        e.sum += d * d;
      }
    }
    e.pixels = static_cast<long>(pixels.size());
    return e;
  }
  for (std::size_t k = 0; k < r.points.size(); ++k) {
    double rgb[3];
    ShadePoint(model.id, result.values.data(), r.points[k], rgb);
    for (int c = 0; c < 3; ++c) {
      const double d = result.exposure * rgb[c] - r.linear[3 * k + c];
      e.sum += d * d;
    }
  }
  e.pixels = static_cast<long>(r.points.size());
  return e;
}

// The GL render of the fit times the exposure, and |prediction - reference| with alpha =
// validity.
void RenderOutputs(const ModelInfo& model, const FitResult& result, Renderer& renderer,
                   const PreparedReference& r, ReferenceResult* rr) {
  const Image render = renderer.Render(r.scene, model.id, result.values);
  const Image& ref = r.source->image;
  rr->prediction = render;
  rr->abs_error = Image(render.width, render.height, 4, 0.0f);
  for (std::size_t p = 0; p < render.PixelCount(); ++p) {
    for (int c = 0; c < 3; ++c) rr->prediction.data[4 * p + c] *= result.exposure;
  }
  for (int k : r.environment ? r.all_pixels : r.pixels) {
    for (int c = 0; c < 3; ++c) {
      rr->abs_error.data[4 * k + c] =
          std::abs(rr->prediction.data[4 * k + c] - ref.data[k * ref.channels + c]);
    }
    rr->abs_error.data[4 * k + 3] = 1.0f;
  }
}

}  // namespace

void RecordStarts(const Parametrization& param, const CeresProblems& problems,
                  MultiStartResult multistart, FitResult* result) {
  result->start_results = std::move(multistart.starts);
  result->residual_evaluations += multistart.residual_evaluations;
  result->jacobian_evaluations += multistart.jacobian_evaluations;
  const StartResult& winner = result->start_results[multistart.best];
  result->values = winner.params;
  result->exposure = winner.exposure;
  result->initial_cost = winner.initial_cost;
  result->final_cost = winner.final_cost;
  result->iterations = winner.iterations;
  result->termination = winner.termination;
  result->converged = winner.converged && std::isfinite(winner.final_cost);
  result->solver_message = multistart.solver_message;
  const std::string solver(NameOf(kSolverNames, problems.Native() ? Solver::kBoundedLm
                                                                   : Solver::kCeres));
  result->solver_name =
      problems.Native() && ProjectionApplies(problems.native_full.loss, problems.exposure_free)
          ? solver + " (variable projection)"
          : solver;

  // Starts that reached the best cost: relative 1e-6, plus an absolute floor of 1e-12 times the
  // cost of predicting black (exact synthetic fits end at costs ~1e-25 that differ relatively).
  const double tolerance = 1e-6 * winner.final_cost + 1e-12 * problems.cost_scale;
  std::vector<int> reached;
  result->coarse_to_fine = problems.coarse;
  for (int s = 0; s < static_cast<int>(result->start_results.size()); ++s) {
    StartResult& sr = result->start_results[s];
    sr.reached_best =
        std::isfinite(sr.final_cost) && sr.final_cost <= winner.final_cost + tolerance;
    if (sr.reached_best) reached.push_back(s);
  }
  result->starts_reached_best = static_cast<int>(reached.size());
  for (int s = 0; s < static_cast<int>(result->start_results.size()); ++s) {
    const StartResult& sr = result->start_results[s];
    if (sr.reached_best || !std::isfinite(sr.final_cost)) continue;
    if (result->second_basin_start < 0 || sr.final_cost < result->second_basin_cost) {
      result->second_basin_start = s;
      result->second_basin_cost = sr.final_cost;
    }
  }

  const int n = param.size();
  result->parameters.resize(n);
  for (int i = 0; i < n; ++i) {
    ParameterEstimate& pe = result->parameters[i];
    pe.name = param.entry(i).name;
    pe.value = result->values[i];
    pe.fixed = param.entry(i).fixed;
    // On a bound: |sin u| = 1 to 1e-9, i.e. y within ~1e-9 of the box's end.
    pe.at_bound = !pe.fixed && std::abs(std::sin(problems.u[i])) > 1.0 - 1e-9;
    std::vector<double> v;
    for (int s : reached) v.push_back(result->start_results[s].params[i]);
    pe.spread_min = *std::min_element(v.begin(), v.end());
    pe.spread_max = *std::max_element(v.begin(), v.end());
    const double mean = Mean(v);
    double var = 0;
    for (double x : v) var += (x - mean) * (x - mean);
    pe.spread_std = std::sqrt(var / v.size());
  }
}

void RecordReferences(const ModelInfo& model, bool gl, const FitOptions& options,
                      Renderer* renderer, std::vector<PreparedReference>& refs, FitResult* result) {
  double total_sq = 0;
  long total_n = 0;
  for (auto& r : refs) {
    ReferenceResult rr;
    rr.name = r.source->name;
    const SquaredError e = ReferenceError(model, gl, *result, renderer, r);
    rr.pixels = static_cast<int>(e.pixels);
    rr.rmse = std::sqrt(e.sum / (3.0 * e.pixels));
    total_sq += e.sum;
    total_n += 3 * e.pixels;
    if (options.render_outputs) RenderOutputs(model, *result, *renderer, r, &rr);
    result->references.push_back(std::move(rr));
  }
  result->rmse = std::sqrt(total_sq / std::max<long>(1, total_n));
  if (gl) {
    for (auto& r : refs) result->renders += r.cache->renders();
  }
}

nlohmann::json Provenance(const FitProblem& problem, const FitOptions& options,
                          const std::vector<PreparedReference>& refs) {
  nlohmann::json inputs = nlohmann::json::object();
  inputs["hash"] = "sha256";
  inputs["references"] = nlohmann::json::array();
  for (std::size_t i = 0; i < refs.size(); ++i) {
    const FitReference& ref = problem.references[i];
    nlohmann::json j;
    j["name"] = ref.name;
    j["pixels"] = refs[i].environment ? refs[i].all_pixels.size() : refs[i].points.size();
    if (refs[i].environment) {
      j["environment_quadrature"] = {{"fitted_pixels", refs[i].points.size()},
                                     {"samples_per_technique", options.environment_twin_samples},
                                     {"rounds", options.environment_rounds}};
    }
    auto file = [&](const std::string& role, const std::string& p) {
      if (p.empty()) return;
      nlohmann::json f{{"path", p}};
      if (ref.sha256.count(role)) f["sha256"] = ref.sha256.at(role);
      j[role] = f;
    };
    file("image", ref.image_path);
    file("sidecar", ref.sidecar_path);
    file("scene", ref.scene_path);
    file("mask", ref.mask_path);
    if (!ref.scene.source_text.empty())
      j["scene_text_sha256"] = Sha256String(ref.scene.source_text);
    if (std::isfinite(ref.clip_level)) j["clip_level"] = ref.clip_level;
    if (options.environment_samples > 0 && !TwinSupportsScene(ref.scene)) {
      j["environment_samples"] = options.environment_samples;
    }
    inputs["references"].push_back(j);
  }
  inputs["fixed"] = FixedTexts(problem.fixed);
  return inputs;
}

}  // namespace shadefit::fit::internal
