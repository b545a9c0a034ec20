// A fit job: the fit on the training references, then its evaluation under every lighting of
// the material (metrics and previews), then the job JSON, last.
#include <fmt/core.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>

#include <nlohmann/json.hpp>

#include "job_kinds.h"
#include "outputs.h"
#include "shadefit/fit/brdf_space.h"
#include "shadefit/fit/encoding_search.h"
#include "shadefit/fit/fitter.h"
#include "shadefit/metrics/false_color.h"
#include "shadefit/metrics/report.h"
#include "shadefit/metrics/ssim.h"
#include "shadefit/refs/measured_brdf.h"
#include "shadefit/refs/reference.h"
#include "shadefit/render/error.h"
#include "shadefit/render/gl_context.h"
#include "shadefit/render/image.h"
#include "test_hooks.h"

namespace shadefit::studies::internal {
namespace {
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

json Num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

bool Trains(const Job& job, const std::string& lighting) {
  return std::find(job.train.begin(), job.train.end(), lighting) != job.train.end();
}

// The fields every fit job JSON starts with, whatever its outcome.
json FitJobHeader(const RunContext& context, const Job& job, FitStatus status) {
  return {{"schema", "shadefit.study.job/1"},
          {"id", job.id},
          {"kind", "fit"},
          {"hash", job.hash},
          {"shadefit_version", ShadefitVersion()},
          {"material", context.spec.groups[job.group].material},
          {"model", job.model},
          {"label", job.label},
          {"train", job.train},
          {"status", FitStatusName(status)}};
}

// The training references, each subsampled to every stride-th pixel by a mask (the images are
// never resampled; metrics still use every pixel).
fit::FitProblem FitProblemOf(const Job& job, const FitSettings& s, const ReferenceGroup& g,
                             const std::vector<refs::Reference>& references) {
  fit::FitProblem problem;
  problem.model = job.model;
  problem.fixed = s.fixed;
  for (std::size_t i = 0; i < references.size(); ++i) {
    if (!Trains(job, g.references[i].lighting)) continue;
    refs::Reference ref = references[i];
    if (s.pixel_stride > 1) {
      Image mask(ref.image.width, ref.image.height, 1, 0.0f);
      for (int y = 0; y < mask.height; y += s.pixel_stride) {
        for (int x = 0; x < mask.width; x += s.pixel_stride) {
          mask.at(x, y, 0) = ref.mask.empty() || ref.mask.at(x, y, 0) > 0.5f ? 1.f : 0.f;
        }
      }
      ref.mask = std::move(mask);
    }
    problem.references.push_back(std::move(ref));
  }
  return problem;
}

fit::FitOptions FitOptionsOf(const FitSettings& s, Renderer& renderer) {
  fit::FitOptions fo;
  fo.loss = fit::ParseLoss(s.loss);
  fo.loss_scale = s.loss_scale;
  fo.starts = s.starts;
  fo.seed = s.seed;
  fo.exposure = fit::ParseExposure(s.exposure);
  fo.path = fit::ParsePath(s.path);
  fo.max_iterations = s.max_iterations;
  fo.environment_samples = s.environment_samples;
  fo.num_threads = kCeresThreadsPerFit;
  fo.render_outputs = false;  // The evaluation renders every lighting, training ones too.
  fo.renderer = &renderer;
  // fo.solver stays Solver::kAuto, the CLI's default: the bounded LM for l2 fits with a fixed
  // exposure (the measured study), the staged Ceres solve for the rest (the Cycles study's
  // cube-root fits, free-exposure photo sets).
  return fo;
}

// A quarter of the reference's 99th-percentile radiance (mean RGB over covered, lit pixels): one
// scale per reference, shared by every model's error map so they compare by eye. Only lit
// pixels count: under a rim light most of the sphere is black, and a percentile over all of it
// gave a range near 0 that saturated every map.
double ErrorScale(const refs::Reference& ref) {
  std::vector<float> v;
  const Image& im = ref.image;
  for (int y = 0; y < im.height; ++y) {
    for (int x = 0; x < im.width; ++x) {
      if (im.channels >= 4 && im.at(x, y, 3) < 0.5f) continue;
      const float mean = (im.at(x, y, 0) + im.at(x, y, 1) + im.at(x, y, 2)) / 3.0f;
      if (mean > 0) v.push_back(mean);
    }
  }
  if (v.empty()) return 1.0;
  const std::size_t k = static_cast<std::size_t>(0.99 * (v.size() - 1));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return std::max(1e-6, 0.25 * v[k]);
}

Image CoverageMask(const Image& image) {
  Image mask(image.width, image.height, 1, 1.0f);
  if (image.channels < 4) return mask;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) mask.at(x, y, 0) = image.at(x, y, 3) > 0.5f ? 1.f : 0.f;
  }
  return mask;
}

json MetricsSummary(const metrics::MetricsReport& m) {
  return {{"rmse", Num(m.rmse)},
          {"relative_rmse", Num(m.relative_rmse)},
          {"log_rmse", Num(m.log_rmse)},
          {"mae", Num(m.mae)},
          {"psnr", Num(m.psnr)},
          {"ssim", Num(m.ssim_rgb.mean)},
          {"ms_ssim", Num(m.ms_ssim.value)},
          {"ciede2000_mean", Num(m.ciede2000.mean)},
          {"flip_ldr_mean", Num(m.flip_ldr.mean)},
          {"flip_hdr_mean", Num(m.flip_hdr.mean)}};
}

// The reference's preview, the fit's and the error map (images/), named in `e` and `outputs`.
void WritePreviews(const RunContext& context, const Job& job, const ReferenceSpec& rs,
                   const refs::Reference& ref, const Image& prediction,
                   const metrics::MetricsMaps& maps, json* e, json* outputs) {
  const StudySpec& spec = context.spec;
  const std::string ref_png = fmt::format("images/{}.reference.png", rs.name);
  const std::string fit_png = fmt::format("images/{}.{}.png", rs.name, FileSafe(job.label));
  const std::string err_png = fmt::format("images/{}.{}.error.png", rs.name, FileSafe(job.label));
  const auto& dir = context.paths.dir;
  if (context.reference_previews == nullptr || context.reference_previews->First(ref_png)) {
    WritePngPreview((dir / ref_png).string(), ref.image, spec.metrics_exposure_stops);
  }
  WritePngPreview((dir / fit_png).string(), prediction, spec.metrics_exposure_stops);
  metrics::FalseColorParameters fc;
  fc.min = 0.0;
  fc.max = ErrorScale(ref);
  metrics::WriteFalseColorPng((dir / err_png).string(), maps.absolute_error, fc);
  (*e)["images"] = {{"reference", ref_png}, {"fit", fit_png}, {"error", err_png},
                    {"error_scale", fc.max}};
  outputs->push_back(ref_png);
  outputs->push_back(fit_png);
  outputs->push_back(err_png);
}

// The fitted parameters render NaN or Inf under a reference's lighting (for example a lobe
// whose exponent overflows at a view the training lighting did not reach): the fit is recorded
// as non-finite-render and the study goes on.
class NonFiniteRenderError : public Error {
 public:
  using Error::Error;
};

// The first covered pixel of `prediction` with a non-finite channel; throws NonFiniteRenderError.
void CheckFinite(const Image& prediction, const Image& reference, const std::string& name) {
  for (int y = 0; y < prediction.height; ++y) {
    for (int x = 0; x < prediction.width; ++x) {
      if (reference.channels > 3 && !(reference.at(x, y, 3) > 0)) continue;
      for (int c = 0; c < 3; ++c) {
        if (!std::isfinite(prediction.at(x, y, c))) {
          throw NonFiniteRenderError(
              name, "render",
              fmt::format("the fit renders {} at ({}, {}) channel {}", prediction.at(x, y, c), x,
                          y, c));
        }
      }
    }
  }
}

// The fit rendered under one reference's lighting and compared with it.
json Evaluate(const RunContext& context, const Job& job, const ReferenceSpec& rs,
              const refs::Reference& ref, const fit::FitResult& result, Renderer& renderer,
              json* outputs) {
  const StudySpec& spec = context.spec;
  Image prediction;
  const double rmse = fit::EvaluateModelOnReference(ref, job.model, result.values,
                                                    result.exposure, &renderer, &prediction);
  if (FaultArmed("inf-render")) prediction.at(prediction.width / 2, prediction.height / 2, 0) =
      std::numeric_limits<float>::infinity();
  CheckFinite(prediction, ref.image, rs.name);
  const Image mask = CoverageMask(ref.image);
  metrics::MetricsParameters mp;
  mp.exposure_stops = spec.metrics_exposure_stops;
  mp.ppd = spec.metrics_ppd;
  mp.flip_reference_cache = context.flip_cache;
  mp.names = {rs.image_path, job.label + " fit", ""};
  metrics::MetricsMaps maps;
  metrics::MetricsReport m;
  bool masked = true;
  const Image ref_rgb = ref.image.Channels(0, 3), fit_rgb = prediction.Channels(0, 3);
  try {
    m = metrics::ComputeMetrics(ref_rgb, fit_rgb, &mask, mp, &maps);
  } catch (const metrics::NoSsimWindowInMaskError&) {
    // MS-SSIM's coarsest scale can leave no window inside a small object's mask; then every
    // metric of this reference is taken over the whole frame (background is 0 in both) and
    // the evaluation says so. The mask is the reference's, so all fits of it are alike.
    masked = false;
    m = metrics::ComputeMetrics(ref_rgb, fit_rgb, nullptr, mp, &maps);
  }
  json e = {{"reference", rs.name},
            {"lighting", rs.lighting},
            {"split", SplitOf(spec, rs.lighting, job.train)},
            {"rmse_fitter", rmse},
            {"metrics_masked", masked},
            {"metrics", MetricsSummary(m)},
            {"metrics_full", metrics::MetricsToJson(m)}};
  if (spec.previews) WritePreviews(context, job, rs, ref, prediction, maps, &e, outputs);
  return e;
}

json ParametersJson(const fit::FitResult& result) {
  json params = json::array();
  for (const fit::ParameterEstimate& p : result.parameters) {
    params.push_back({{"name", p.name}, {"value", Num(p.value)}, {"std_error", Num(p.std_error)},
                      {"fixed", p.fixed}, {"undetermined", p.undetermined},
                      {"at_bound", p.at_bound}});
  }
  return params;
}

}  // namespace

void RunFitJob(const RunContext& context, const Job& job, Renderer& renderer) {
  const ReferenceGroup& g = context.spec.groups[job.group];
  const FitSettings& s = context.spec.model_settings.at(job.model);
  const auto t0 = Clock::now();

  std::vector<refs::Reference> references;
  for (const ReferenceSpec& r : g.references) {
    references.push_back(refs::LoadReference(r.image_path));
  }
  const fit::FitProblem problem = FitProblemOf(job, s, g, references);
  const fit::FitOptions fo = FitOptionsOf(s, renderer);
  if (FaultArmed("gl-lost")) throw GlContextLostError("", "GL", "context lost (simulated)");
  fit::FitResult result;
  json encoding;  // The encoding search's record (encoding = "fit"), else null.
  try {
    if (TrainsInBrdfSpace(job.train)) {
      // The measured BRDF itself, on MERL's cells (fit/brdf_space.h); LoadStudy checked that
      // the settings are l2 with a fixed exposure.
      const std::unique_ptr<refs::MeasuredBrdf> brdf =
          refs::LoadMeasuredBrdf(MeasuredBrdfPath(context.spec, g.material));
      result = fit::FitBrdfSpace(job.model, s.fixed,
                                 fit::SampleBrdfSpace(*brdf, fit::BrdfSpaceSampling{}), fo);
    } else if (fit::ParseEncodingMode(s.encoding) == fit::EncodingMode::kFit) {
      fit::EncodingSearchResult search = fit::FitWithEncodingSearch(problem, fo);
      result = std::move(search.fit);
      encoding = fit::EncodingSearchToJson(search);
      // Every lighting, trained on or not, is evaluated in the chosen decoding.
      for (refs::Reference& r : references) r = fit::Redecode(r, search.chosen);
      context.log->Line(fmt::format("{}: encoding {} chosen (stored-value RMSE {:.6g})", job.id,
                                    search.chosen.Name(), encoding["stored_rmse"].get<double>()));
    } else {
      result = fit::Fit(problem, fo);
    }
  } catch (const fit::DegenerateReferenceError& e) {
    WriteFailedFit(context, job, FitStatus::kDegenerateReference, e.what());
    return;
  }
  KillPoint("fit");
  if (FaultArmed("nan-residuals")) {
    result.final_cost = std::numeric_limits<double>::quiet_NaN();
    for (double& v : result.values) v = std::numeric_limits<double>::quiet_NaN();
  }
  if (!std::isfinite(result.final_cost)) {
    WriteFailedFit(context, job, FitStatus::kNanResiduals,
                   fmt::format("the solve ended with a non-finite cost ({})", result.termination));
    return;
  }
  if (!result.converged) {
    context.log->Line(fmt::format("{}: fit did not converge ({}); recorded as such", job.id,
                                  result.termination));
  }

  json evaluations = json::array();
  json outputs = json::array();
  try {
    for (std::size_t i = 0; i < references.size(); ++i) {
      evaluations.push_back(
          Evaluate(context, job, g.references[i], references[i], result, renderer, &outputs));
    }
  } catch (const NonFiniteRenderError& e) {
    // The previews of the references evaluated before it go too: a failed fit leaves no image
    // of its own (the reference previews are every fit's of the material, and stay).
    for (const json& o : outputs) {
      if (o.get<std::string>().ends_with(".reference.png")) continue;
      std::error_code ec;
      std::filesystem::remove(context.paths.dir / o.get<std::string>(), ec);
    }
    WriteFailedFit(context, job, FitStatus::kNonFiniteRender, e.what());
    return;
  }
  json j = FitJobHeader(context, job,
                        result.converged ? FitStatus::kOk : FitStatus::kNotConverged);
  j.update({{"settings", s.ToJson()},
            {"converged", result.converged},
            {"termination", result.termination},
            {"values", result.values},
            {"exposure", result.exposure},
            {"parameters", ParametersJson(result)},
            {"fit", fit::FitResultToJson(result)},
            {"evaluations", evaluations},
            {"outputs", outputs}});
  // Wall-clock times are not results: they go to the job's timing file, so that the job JSON
  // is the same bytes on every run.
  j["fit"]["solver"].erase("seconds");
  j["fit"]["solver"].erase("solve_seconds");
  if (!encoding.is_null()) j["encoding"] = encoding;
  WriteTiming(context, job, std::chrono::duration<double>(Clock::now() - t0).count(),
              result.seconds);
  WriteJobJson(context.paths.JobJson(job), j.dump(1) + "\n");
}

void WriteFailedFit(const RunContext& context, const Job& job, FitStatus status,
                    const std::string& error) {
  context.log->Say(fmt::format("{}: {}: {}; recorded, the study goes on", job.id,
                               FitStatusName(status), error));
  json j = FitJobHeader(context, job, status);
  j.update({{"error", error},
            {"converged", false},
            {"parameters", json::array()},
            {"evaluations", json::array()},
            {"outputs", json::array()}});
  WriteTiming(context, job, 0.0, -1.0);
  WriteJobJson(context.paths.JobJson(job), j.dump(1) + "\n");
}

}  // namespace shadefit::studies::internal
