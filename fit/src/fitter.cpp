// Fit(): the stages in order (docs/fitting.md). Each stage is a unit of its own:
//   prepared_reference.h  valid pixels, G-buffers, the environment subsample and quadrature;
//   problem.h             the Ceres problems: parametrisation, residual blocks, fixed entries;
//   multistart.h          start points, coarse and full solves, the staged working set;
//   uncertainty.h         covariance and standard errors;
//   fit_result.h          FitResult assembly; fit_output.cpp its JSON and files.
#include "shadefit/fit/fitter.h"
#include "shadefit/fit/option_checks.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "exposure_gauge.h"
#include "fit_result.h"
#include "model_structure.h"
#include "multistart.h"
#include "prepared_reference.h"
#include "problem.h"
#include "solve.h"
#include "shadefit/fit/residuals.h"
#include "shadefit/base/error.h"
#include "uncertainty.h"

namespace shadefit::fit {
using internal::CeresProblems;
using internal::PreparedReference;
using internal::RendererHolder;

std::string TerminationName(Termination termination) {
  return std::string(NameOf(kTerminationNames, termination));
}

std::string FitResult::CovarianceStatusText() const {
  switch (covariance_status) {
    case CovarianceStatus::kOk: return "ok";
    case CovarianceStatus::kRankDeficient: return "rank deficient";
    case CovarianceStatus::kFailed: return "failed: " + covariance_failure;
    case CovarianceStatus::kSkipped: return "skipped";
  }
  return "skipped";
}

std::string LossName(Loss loss) { return std::string(NameOf(kLossNames, loss)); }

std::string PathName(DerivativePath path) { return std::string(NameOf(kPathNames, path)); }

std::string ExposureName(Exposure exposure) {
  return std::string(NameOf(kExposureNames, exposure));
}

namespace {

// An entry only the ambient term reads (classic Blinn-Phong's ka) has no effect on any pixel
// when no reference has ambient light: left free it would end wherever its start was and be
// reported undetermined. It is held at 0, and the result says so.
std::vector<int> HoldWithoutAmbient(const FitProblem& problem, Parametrization* param,
                                    FitResult* result) {
  std::vector<int> held;
  for (const FitReference& ref : problem.references) {
    for (const Light& light : ref.scene.lights) {
      const Vec3d& v = light.value;
      if (light.type == Light::Type::kAmbient && (v.x > 0 || v.y > 0 || v.z > 0)) return held;
    }
  }
  const ModelInfo& model = param->model();
  const std::vector<bool> ambient_only = internal::AmbientOnlyEntries(model.id);
  for (int i = 0; i < param->size(); ++i) {
    if (!ambient_only[i] || param->entry(i).fixed) continue;
    param->Pin(i, 0.0);
    held.push_back(i);
    const std::string text =
        model.SpecOfEntry(i).name + " = 0: no reference has ambient light, so it has no effect";
    if (result->held.empty() || result->held.back() != text) result->held.push_back(text);
  }
  return held;
}

}  // namespace

namespace internal {

void SolvePrepared(const ModelInfo& model, const Parametrization& param, const FitOptions& options,
                   bool gl, bool environment, Renderer* renderer,
                   std::vector<PreparedReference>& refs, FitResult* result) {
  CeresProblems problems;
  BuildProblems(model, param, options, gl, renderer, refs, &problems);
  result->loss_scale = problems.loss_scale;
  const auto solve_start = std::chrono::steady_clock::now();
  MultiStartResult solved = RunMultiStart(model, param, options, environment, refs, &problems);
  result->solve_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - solve_start).count();
  if (problems.exposure_free && result->exposure_pin.kind == PinKind::kExposure) {
    MoveToExposureGauge(param, result->exposure_pin, &solved, &problems);
  }
  RecordStarts(param, problems, std::move(solved), result);

  // Uncertainty at the best start (the bounded LM's J^T J, or ceres::Covariance), scaled by the
  // residual variance.
  result->covariance_status = CovarianceStatus::kSkipped;
  if (options.compute_covariance && std::isfinite(result->final_cost)) {
    EstimateUncertainty(param, problems, result);
  }
  RecordReferences(model, gl, options, renderer, refs, result);
}

}  // namespace internal

FitResult Fit(const FitProblem& problem, const FitOptions& options) {
  return internal::FitSharingShading(problem, options, nullptr);
}

namespace internal {

FitResult FitSharingShading(const FitProblem& problem, const FitOptions& options,
                            std::vector<ShadedScene>* shaded) {
  const auto t0 = std::chrono::steady_clock::now();
  if (!problem.model) throw FitOptionError(FitField::kModel, "no model given");
  const ModelInfo& model = *problem.model;
  Parametrization param(model, problem.fixed);
  if (problem.references.empty()) throw FitOptionError(FitField::kReferences, "no reference given");
  if (options.starts < 1 && options.start_points.empty()) {
    throw FitOptionError(FitField::kStarts, "must be >= 1");  // Start points may stand alone.
  }
  FitResult result;
  const std::vector<int> held = HoldWithoutAmbient(problem, &param, &result);
  if (param.FreeCount() == 0 && options.exposure == Exposure::kFixed) {
    throw FitOptionError(FitField::kFixed,
                result.held.empty()
                    ? "every parameter is fixed (and the exposure): nothing to fit"
                    : "every parameter is fixed (and the exposure; " + result.held.front() +
                          "): nothing to fit");
  }
  // A free exposure and the reflectances share one scale: one value is pinned (exposure_pin.h).
  FitOptions pinned = options;
  if (options.exposure == Exposure::kFree) {
    result.exposure_pin = ExposurePinOf(model, problem.fixed);
    const ExposurePin& pin = result.exposure_pin;
    if (pin.kind == PinKind::kFresnel) {
      for (std::size_t k = 0; k < pin.entries.size(); ++k) param.Pin(pin.entries[k], pin.values[k]);
    }
    if (pin.kind == PinKind::kUnitExposure) pinned.exposure = Exposure::kFixed;
  }
  result.model = model;
  result.loss = options.loss;
  result.given_starts = static_cast<int>(options.start_points.size());
  result.starts = options.starts + result.given_starts;
  result.seed = options.seed;
  result.exposure_free = options.exposure == Exposure::kFree;

  // References: G-buffers, valid pixels, derivative path.
  RendererHolder holder(options.renderer);
  Renderer& renderer = *holder.renderer;
  std::vector<PreparedReference> refs;
  bool twin_ok = true;
  const bool reuse = shaded && shaded->size() == problem.references.size();
  if (shaded && !reuse) shaded->clear();
  for (std::size_t i = 0; i < problem.references.size(); ++i) {
    const FitReference& ref = problem.references[i];
    if (reuse) {
      refs.push_back(internal::PrepareFrom(ref, (*shaded)[i]));
    } else {
      ShadedScene s =
          internal::ShadeScene(ref, renderer, options.environment_samples, &result.gbuffer_renders);
      if (shaded) shaded->push_back(s);
      refs.push_back(internal::PrepareFrom(ref, std::move(s)));
    }
    twin_ok = twin_ok && TwinSupportsScene(ref.scene);
  }
  // The twin covers every scene: environment and uniform light through its quadrature.
  result.path = options.path == DerivativePath::kAuto ? DerivativePath::kGBuffer : options.path;
  const bool gl = result.path == DerivativePath::kGl;
  const bool environment = !gl && !twin_ok;
  if (environment) {
    for (PreparedReference& r : refs) {
      if (TwinSupportsScene(r.scene)) continue;
      r.environment = true;
      internal::SubsampleForEnvironment(&r, std::max(64, options.environment_pixels));
    }
    internal::AttachQuadrature(
        refs, internal::ProposalAlphas(model.id, param.ToNatural(param.DefaultInternal()), false),
        std::max(4, options.environment_twin_samples));
  }

  internal::SolvePrepared(model, param, pinned, gl, environment, &renderer, refs, &result);
  for (int i : held) result.parameters[i].fixed_by = "no ambient light";
  if (result.exposure_pin.kind == PinKind::kFresnel) {
    for (int i : result.exposure_pin.entries) result.parameters[i].fixed_by = "free exposure";
  }
  result.inputs = internal::Provenance(problem, options, refs);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace internal

double EvaluateModelOnReference(const FitReference& reference, const ModelInfo& model,
                                const std::vector<double>& params, double exposure, Renderer* given,
                                Image* prediction) {
  if (static_cast<int>(params.size()) != model.ParamCount()) {
    throw Error(
        "", model.name,
        fmt::format("expected {} parameter values, got {}", model.ParamCount(), params.size()));
  }
  RendererHolder holder(given);
  const internal::UsablePixelValues r = internal::UsablePixels(reference, *holder.renderer);
  Image render = holder.renderer->Render(reference.scene, model.id, params);
  double sq = 0;
  for (std::size_t k = 0; k < r.pixels.size(); ++k) {
    for (int c = 0; c < 3; ++c) {
      const double d =
          exposure * render.data[static_cast<std::size_t>(r.pixels[k]) * render.channels + c] -
          r.linear[3 * k + c];
      sq += d * d;
    }
  }
  if (prediction) {
    for (std::size_t p = 0; p < render.PixelCount(); ++p) {
      for (int c = 0; c < 3; ++c)
        render.data[render.channels * p + c] *= static_cast<float>(exposure);
    }
    *prediction = std::move(render);
  }
  return std::sqrt(sq / (3.0 * r.pixels.size()));
}

}  // namespace shadefit::fit
