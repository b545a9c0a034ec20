// A fit job: the fit on the training references, then its evaluation under every lighting of
// the material (metrics and previews), then the job JSON, last.
#include <fmt/core.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>

#include "job_kinds.h"
#include "job_records.h"
#include "metric_columns.h"
#include "outputs.h"
#include "region_errors.h"
#include "stage_clock.h"
#include "shadefit/base/error.h"
#include "shadefit/fit/encoding_search.h"
#include "shadefit/fit/fitter.h"
#include "shadefit/fit/training_pixels.h"
#include "shadefit/metrics/false_color.h"
#include "shadefit/metrics/report.h"
#include "shadefit/metrics/ssim.h"
#include "shadefit/reference_images/reference.h"
#include "shadefit/render/gl_context.h"
#include "shadefit/render/image.h"
#include "shadefit/base/statistics.h"
#include "test_hooks.h"

namespace shadefit::studies::internal {
namespace {
using json = nlohmann::json;
using SharedReference = LoadedReferences::Shared;  // What the run hands a job.

json Num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

bool Trains(const Job& job, const std::string& lighting) {
  return std::find(job.train.begin(), job.train.end(), lighting) != job.train.end();
}

// The fields every fit job record has, whatever its outcome.
FitJobRecord FitRecordHeader(const RunContext& context, const Job& job, FitStatus status) {
  FitJobRecord r;
  r.id = job.id;
  r.hash = job.hash;
  r.shadefit_version = ShadefitVersion();
  r.material = context.spec.groups[job.group].material;
  r.model = job.model->name;
  r.label = job.label;
  r.train = job.train;
  r.status = status;
  return r;
}

// The training references, each narrowed to the pixels a fit trains on at the study's
// pixel_stride (fit::TrainingPixels: measured pixels only, every stride-th; the rule `shadefit
// fit` and shadefit.fit() apply too).
fit::FitProblem FitProblemOf(const Job& job, const FitSettings& s, const ReferenceGroup& g,
                             const std::vector<SharedReference>& references) {
  fit::FitProblem problem;
  problem.model = job.model;
  problem.fixed = s.fixed;
  for (std::size_t i = 0; i < references.size(); ++i) {
    if (!Trains(job, g.references[i].lighting)) continue;
    problem.references.push_back(fit::TrainingPixels(*references[i], s.pixel_stride));
  }
  return problem;
}

fit::FitOptions FitOptionsOf(const FitSettings& s, Renderer& renderer) {
  fit::FitOptions fo = s.Options();
  fo.num_threads = kCeresThreadsPerFit;
  fo.render_outputs = false;  // The evaluation renders every lighting, training ones too.
  fo.renderer = &renderer;
  // fo.solver stays Solver::kAuto, the CLI's default: the bounded LM for l2 fits with a fixed
  // exposure (the measured study), the staged Ceres solve for the rest (the Cycles study's
  // cube-root fits, free-exposure photo sets).
  return fo;
}

// The material's BRDF-space fit of the job's model with `options` (l2, fixed exposure, no start
// points), from the run's BrdfSpaceFits, which makes each such fit once; `solved_here`: its
// seconds when this job made it, else 0 (BrdfSpaceFits::Get).
fit::FitResult BrdfSpaceFitOf(const RunContext& context, const Job& job, const FitSettings& s,
                              const std::string& path, const fit::FitOptions& options,
                              double* solved_here) {
  FitSettings key = s;  // Everything the options come from; the loss is Ngan's l2.
  key.loss = fit::Loss::kL2;
  return context.brdf_fits->Get(path, *job.model, s.fixed, options, key.ToJson().dump(),
                                solved_here);
}

// [fit] start = "brdf": the material's BRDF-space fit of the same model (l2 on MERL's cells,
// fixed exposure: fit/brdf_space.h) as one more start of its image fit; nothing for a group that
// is not a [[measured]] material. Logged with its cost, so that a reader of study.log sees it.
// Returns the seconds of that fit when this job made it (a solve of the job's), else 0.
double AddBrdfSpaceStart(const RunContext& context, const Job& job, const FitSettings& s,
                         const std::string& material, fit::FitOptions* fo) {
  const std::string path = MeasuredBrdfPath(context.spec, material);
  if (path.empty()) return 0.0;
  fit::FitOptions brdf_options = *fo;
  brdf_options.loss = fit::Loss::kL2;
  brdf_options.exposure = fit::Exposure::kFixed;
  brdf_options.start_points.clear();
  double solved_here = 0.0;
  const fit::FitResult start = BrdfSpaceFitOf(context, job, s, path, brdf_options, &solved_here);
  fo->start_points.push_back(start.values);
  context.log->Line(fmt::format("{}: BRDF-space start (cost {:.6g}) added", job.id,
                                start.final_cost));
  return solved_here;
}

// A quarter of the reference's 99th-percentile radiance (mean RGB over covered, lit pixels): one
// scale per reference, shared by every model's error map so they compare by eye. Only lit
// pixels count: under a rim light most of the sphere is black, and a percentile over all of it
// gave a range near 0 that saturated every map.
double ErrorScale(const reference_images::Reference& ref) {
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
  return std::max(1e-6, 0.25 * static_cast<double>(Percentile(v, 0.99)));
}

Image CoverageMask(const Image& image) {
  Image mask(image.width, image.height, 1, 1.0f);
  if (image.channels < 4) return mask;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) mask.at(x, y, 0) = image.at(x, y, 3) > 0.5f ? 1.f : 0.f;
  }
  return mask;
}

// The covered pixels that lie in the reference's measured domain (all of them without one).
Image MeasuredMask(const reference_images::Reference& ref, const Image& covered) {
  Image mask = covered;
  for (int y = 0; y < mask.height; ++y) {
    for (int x = 0; x < mask.width; ++x) {
      if (!reference_images::IsMeasuredPixel(ref, x, y)) mask.at(x, y, 0) = 0.f;
    }
  }
  return mask;
}

// The reference as the measured pass sees it: its covered pixels outside the measured domain
// take the prediction's values. The mask leaves them out of every pooled number, but FLIP's
// filters and feature detectors read the neighbourhood of each pixel they score, so the
// extrapolated values would still reach measured pixels near the boundary; with the prediction
// there, no number of the pass depends on extrapolated data.
Image PatchedReference(const Image& ref_rgb, const Image& fit_rgb, const Image& covered,
                       const Image& measured) {
  Image out = ref_rgb;
  for (int y = 0; y < out.height; ++y) {
    for (int x = 0; x < out.width; ++x) {
      if (covered.at(x, y, 0) > 0.5f && !(measured.at(x, y, 0) > 0.5f)) {
        for (int c = 0; c < 3; ++c) out.at(x, y, c) = fit_rgb.at(x, y, c);
      }
    }
  }
  return out;
}

std::size_t CountSet(const Image& mask) {
  return static_cast<std::size_t>(
      std::count_if(mask.data.begin(), mask.data.end(), [](float v) { return v > 0.5f; }));
}

// The pixels of `mask` where the reference has any radiance: under a rim light every lit pixel
// can be extrapolated while the unlit rest, 0 in every model too, is measured.
std::size_t CountLit(const Image& mask, const Image& image) {
  std::size_t n = 0;
  for (int y = 0; y < mask.height; ++y) {
    for (int x = 0; x < mask.width; ++x) {
      if (mask.at(x, y, 0) > 0.5f &&
          (image.at(x, y, 0) > 0 || image.at(x, y, 1) > 0 || image.at(x, y, 2) > 0)) {
        ++n;
      }
    }
  }
  return n;
}

// The metrics of one mask: the report, or none with the reason (no pixel, or no SSIM window).
struct MetricsPass {
  std::optional<metrics::MetricsReport> report;
  bool masked = true;  // false: taken over the whole frame (the coverage pass's fallback)
  std::string why_none;
};

// Every metric of kMetrics by its name.
json MetricsSummary(const metrics::MetricsReport& m) {
  json j = json::object();
  for (const MetricColumn& c : kMetrics) j[c.name] = Num(c.value(m));
  return j;
}

// The same keys as MetricsSummary, every value null: a pass without numbers.
json NullMetricsSummary() {
  json j = MetricsSummary(metrics::MetricsReport{});
  for (auto& [key, value] : j.items()) value = nullptr;
  return j;
}

// The reference's preview with its extrapolated pixels (outside the measured domain) tinted
// magenta, 60 % over the display value, so the viewer shows which pixels the metrics leave out.
void WriteDomainPreview(const std::string& path, const reference_images::Reference& ref,
                        const Image& covered, float exposure_stops) {
  const float scale = std::exp2(exposure_stops);
  Image display(ref.image.width, ref.image.height, 3);
  for (int y = 0; y < display.height; ++y) {
    for (int x = 0; x < display.width; ++x) {
      const bool tint = covered.at(x, y, 0) > 0.5f && !reference_images::IsMeasuredPixel(ref, x, y);
      for (int c = 0; c < 3; ++c) {
        const float v = std::clamp(SrgbOetf(ref.image.at(x, y, c) * scale), 0.0f, 1.0f);
        const float magenta = c == 1 ? 0.0f : 1.0f;
        display.at(x, y, c) = tint ? 0.4f * v + 0.6f * magenta : v;
      }
    }
  }
  WritePng8(path, display);
}

// The reference's preview, the fit's and the error map (images/), named in `e` and `outputs`;
// for a measured reference also its domain preview (images/<reference>.domain.png).
void WritePreviews(const RunContext& context, const Job& job, const ReferenceSpec& rs,
                   const reference_images::Reference& ref, const Image& prediction,
                   const Image& covered, const metrics::MetricsMaps& maps, json* e, json* outputs) {
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
  (*e)["images"] = {
      {"reference", ref_png}, {"fit", fit_png}, {"error", err_png}, {"error_scale", fc.max}};
  outputs->push_back(ref_png);
  outputs->push_back(fit_png);
  outputs->push_back(err_png);
  if (ref.extrapolated_share.empty()) return;
  const std::string domain_png = fmt::format("images/{}.domain.png", rs.name);
  if (context.reference_previews == nullptr || context.reference_previews->First(domain_png)) {
    WriteDomainPreview((dir / domain_png).string(), ref, covered, spec.metrics_exposure_stops);
  }
  (*e)["images"]["domain"] = domain_png;
  outputs->push_back(domain_png);
}

// Every metric over `mask`. The covered pass (fallback_to_frame) keeps the runner's old rule:
// MS-SSIM's coarsest scale can leave no window inside a small object's mask; then every metric
// of this reference is taken over the whole frame (background is 0 in both) and the evaluation
// says so; the mask is the reference's, so all fits of it are alike. The measured pass has no
// such fallback (the frame holds the extrapolated pixels it leaves out): it has no numbers then.
MetricsPass RunMetrics(const Image& ref_rgb, const Image& fit_rgb, const Image& mask,
                       const metrics::MetricsParameters& mp, bool fallback_to_frame,
                       metrics::MetricsMaps* maps) {
  MetricsPass pass;
  if (!fallback_to_frame && CountSet(mask) == 0) {
    pass.why_none = "no covered pixel is measured";
    return pass;
  }
  try {
    pass.report = metrics::ComputeMetrics(ref_rgb, fit_rgb, &mask, mp, maps);
  } catch (const metrics::NoSsimWindowInMaskError&) {
    if (!fallback_to_frame) {
      pass.why_none =
          "the measured pixels hold no whole SSIM/MS-SSIM window (too few or too scattered)";
      return pass;
    }
    pass.masked = false;
    pass.report = metrics::ComputeMetrics(ref_rgb, fit_rgb, nullptr, mp, maps);
  }
  return pass;
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
          throw NonFiniteRenderError(name, "render",
                                     fmt::format("the fit renders {} at ({}, {}) channel {}",
                                                 prediction.at(x, y, c), x, y, c));
        }
      }
    }
  }
}

// The reference's pixel regions (region_errors.h): the run's map of it when `ref` is the run's
// reference of that path (not a copy the encoding search redecoded), else found here.
std::shared_ptr<const std::vector<signed char>> RegionsOf(const RunContext& context,
                                                          const ReferenceSpec& rs,
                                                          const reference_images::Reference& ref,
                                                          bool run_reference, const Image& ref_rgb,
                                                          const Image& measured,
                                                          Renderer& renderer) {
  const auto make = [&] {
    return PixelRegions(ref_rgb, measured, renderer.RenderGBuffer(ref.scene));
  };
  if (!run_reference || context.reference_regions == nullptr) {
    return std::make_shared<const std::vector<signed char>>(make());
  }
  return context.reference_regions->Get(rs.image_path, make);
}

// The fit rendered under one reference's lighting and compared with it. `run_reference`: `ref`
// is the run's reference at rs.image_path as read (not redecoded).
EvaluationRecord Evaluate(const RunContext& context, const Job& job, const ReferenceSpec& rs,
              const reference_images::Reference& ref, bool run_reference,
              const fit::FitResult& result, Renderer& renderer, json* outputs, StageClock* clock) {
  const StudySpec& spec = context.spec;
  Image prediction;
  const double rmse = fit::EvaluateModelOnReference(ref, *job.model, result.values, result.exposure,
                                                    &renderer, &prediction);
  if (FaultArmed("inf-render"))
    prediction.at(prediction.width / 2, prediction.height / 2, 0) =
        std::numeric_limits<float>::infinity();
  CheckFinite(prediction, ref.image, rs.name);
  clock->Lap("render");
  // Two masks: every covered pixel, and those of them in the reference's measured domain (the
  // same without a domain). "metrics" are the measured pixels', "metrics_all" every covered
  // pixel's; the second pass runs only when the masks differ (metrics are costly).
  const Image covered = CoverageMask(ref.image);
  const Image measured = MeasuredMask(ref, covered);
  const std::size_t covered_pixels = CountSet(covered), measured_pixels = CountSet(measured);
  metrics::MetricsParameters mp;
  mp.exposure_stops = spec.metrics_exposure_stops;
  mp.ppd = spec.metrics_ppd;
  mp.reference_cache = context.reference_cache;
  mp.names = {rs.image_path, job.label + " fit", ""};
  mp.maps_wanted = metrics::kAbsoluteErrorMap;  // The previews' error map; no other is read.
  const std::size_t lit_pixels = CountLit(covered, ref.image),
                    measured_lit_pixels = CountLit(measured, ref.image);
  // Only unlit pixels measured (the rim light: every lit pixel is seen beyond the limit): they
  // compare 0 with 0, which says nothing about the material; that pass has no numbers.
  const bool only_unlit_measured = lit_pixels > 0 && measured_lit_pixels == 0;
  // With a measured pass to follow, the covered pass keeps its per-pixel terms: that pass pools
  // them where its own are the same numbers (the reference it compares with equals this one
  // there) instead of computing them again (metrics::KeptTerms).
  metrics::KeptTerms kept;
  if (measured_pixels != covered_pixels && measured_pixels > 0 && !only_unlit_measured) {
    mp.keep = &kept;
  }
  metrics::MetricsSeconds metric_seconds;
  mp.seconds = &metric_seconds;
  metrics::MetricsMaps maps;  // Of the covered pass: the error map shows every covered pixel.
  const Image ref_rgb = ref.image.Channels(0, 3), fit_rgb = prediction.Channels(0, 3);
  const MetricsPass all = RunMetrics(ref_rgb, fit_rgb, covered, mp, true, &maps);
  MetricsPass main;
  if (measured_pixels == covered_pixels) {
    main = all;
  } else if (only_unlit_measured) {
    main.why_none = "no lit pixel is measured (every lit pixel depends on extrapolated data)";
  } else {
    // The patched reference holds this fit's values where it is not measured: no other
    // evaluation compares with it, so its halves are not kept (they would only push the
    // references' own out of the cache).
    metrics::MetricsParameters measured_mp = mp;
    measured_mp.reference_cache = nullptr;
    measured_mp.keep = nullptr;
    measured_mp.kept = &kept;
    main = RunMetrics(PatchedReference(ref_rgb, fit_rgb, covered, measured), fit_rgb, measured,
                      measured_mp, false, nullptr);
  }
  clock->Lap("metrics");
  for (const auto& [stage, seconds] :
       {std::pair{"metric_pixel", metric_seconds.pixel}, {"metric_ssim", metric_seconds.ssim},
        {"metric_ciede2000", metric_seconds.ciede2000}, {"metric_itp", metric_seconds.delta_e_itp},
        {"metric_flip_ldr", metric_seconds.flip_ldr}, {"metric_flip_hdr", metric_seconds.flip_hdr},
        {"metric_maps", metric_seconds.maps}}) {
    clock->Move("metrics", stage, seconds);
  }
  EvaluationRecord record;
  record.reference = rs.name;
  record.lighting = rs.lighting;
  record.split = SplitOf(spec, rs.lighting, job.train);
  record.measured_fraction =
      covered_pixels > 0 ? static_cast<double>(measured_pixels) / covered_pixels : 1.0;
  record.metrics = main.report ? MetricsSummary(*main.report) : NullMetricsSummary();
  record.metrics_all = all.report ? MetricsSummary(*all.report) : NullMetricsSummary();
  json& e = record.details;
  e = {{"rmse_fitter", rmse},
            {"metrics_pixels", ref.extrapolated_share.empty() && ref.shadow_edge.empty() &&
                                       ref.interreflection.empty()
                                   ? "covered"
                                   : "covered and measured"},
            {"covered_pixels", covered_pixels},
            {"measured_pixels", measured_pixels},
            {"lit_pixels", lit_pixels},
            {"measured_lit_pixels", measured_lit_pixels},
            {"metrics_masked", main.report ? json(main.masked) : json(nullptr)},
            {"metrics_all_masked", all.report ? json(all.masked) : json(nullptr)},
            {"metrics_full", main.report ? metrics::MetricsToJson(*main.report) : json(nullptr)}};
  // Covered pixels left out of the measured domain for a reason of the object's (none on
  // spheres and planes: their records are unchanged): a shadow's edge, strong interreflection.
  if (!ref.shadow_edge.empty() || !ref.interreflection.empty()) {
    std::size_t edge = 0, bounce = 0;
    for (int y = 0; y < covered.height; ++y) {
      for (int x = 0; x < covered.width; ++x) {
        if (!(covered.at(x, y, 0) > 0.5f)) continue;
        edge += !ref.shadow_edge.empty() && ref.shadow_edge.at(x, y, 0) > 0.5f;
        bounce += !ref.interreflection.empty() && ref.interreflection.at(x, y, 0) > 0.5f;
      }
    }
    e["excluded_pixels"] = {{"shadow_edge", edge}, {"interreflection", bounce}};
  }
  if (!main.report) e["metrics_none"] = main.why_none;
  // Where the error lies, over the same pixels as "metrics": none where that pass has none.
  e["regions"] = main.report ? RegionErrors(ref_rgb, fit_rgb,
                                            *RegionsOf(context, rs, ref, run_reference, ref_rgb,
                                                       measured, renderer))
                             : json(nullptr);
  if (!all.report) e["metrics_all_none"] = all.why_none;
  clock->Lap("regions");
  if (spec.previews) {
    WritePreviews(context, job, rs, ref, prediction, covered, maps, &e, outputs);
  }
  clock->Lap("previews");
  return record;
}

json ParametersJson(const fit::FitResult& result) {
  json params = json::array();
  for (const fit::ParameterEstimate& p : result.parameters) {
    params.push_back({{"name", p.name},
                      {"value", Num(p.value)},
                      {"std_error", Num(p.std_error)},
                      {"fixed", p.fixed},
                      {"fixed_by", p.fixed_by},
                      {"undetermined", p.undetermined},
                      {"at_bound", p.at_bound}});
  }
  return params;
}

// Solves the fit the job's training set asks for: in BRDF space, with the encoding search (then
// `references` are redecoded and `encoding` is the search's record), or on the images.
// `solved_here`: the seconds of the fit when this job solved it (a BRDF-space fit another job
// made: 0).
fit::FitResult SolveFitJob(const RunContext& context, const Job& job, const FitSettings& s,
                           const std::string& material, const fit::FitProblem& problem,
                           const fit::FitOptions& fo, std::vector<SharedReference>* references,
                           json* encoding, double* solved_here) {
  if (TrainsInBrdfSpace(job.train)) {
    // The measured BRDF itself, on MERL's cells (fit/brdf_space.h); LoadStudy checked that
    // the exposure is fixed, and the job's loss is l2 (StudySpec::Fits).
    return BrdfSpaceFitOf(context, job, s, MeasuredBrdfPath(context.spec, material), fo,
                          solved_here);
  }
  if (s.encoding == fit::EncodingMode::kFit) {
    fit::EncodingSearchResult search = fit::FitWithEncodingSearch(problem, fo);
    *encoding = fit::EncodingSearchToJson(search);
    // Every lighting, trained on or not, is evaluated in the chosen decoding.
    for (SharedReference& r : *references) {
      r = std::make_shared<const reference_images::Reference>(fit::Redecode(*r, search.chosen));
    }
    context.log->Line(fmt::format("{}: encoding {} chosen (stored-value RMSE {:.6g})", job.id,
                                  search.chosen.Name(), (*encoding)["stored_rmse"].get<double>()));
    *solved_here = search.fit.seconds;
    return std::move(search.fit);
  }
  fit::FitResult fit = fit::Fit(problem, fo);
  *solved_here = fit.seconds;
  return fit;
}

// Removes the fit's previews of the references evaluated before a failure: a failed fit leaves
// no image of its own (the reference previews are every fit's of the material, and stay).
void RemoveFitPreviews(const RunContext& context, const json& outputs) {
  for (const json& o : outputs) {
    const std::string& name = o.get_ref<const std::string&>();
    if (name.ends_with(".reference.png") || name.ends_with(".domain.png")) continue;
    std::error_code ec;
    std::filesystem::remove(context.paths.dir / o.get<std::string>(), ec);
  }
}

// The record of a fit that ran to the end, converged or not.
FitJobRecord FitRecord(const RunContext& context, const Job& job, const FitSettings& s,
                       const fit::FitResult& result, std::vector<EvaluationRecord> evaluations,
                       const json& outputs, const json& encoding) {
  FitJobRecord r =
      FitRecordHeader(context, job, result.converged ? FitStatus::kOk : FitStatus::kNotConverged);
  r.settings = s.ToJson();
  r.converged = result.converged;
  r.termination = fit::TerminationName(result.termination);
  r.values = result.values;
  r.exposure = result.exposure;
  r.parameters = ParametersJson(result);
  r.fit = fit::FitResultToJson(result);
  // Wall-clock times are not results: they go to the job's timing file, so that the job JSON
  // is the same bytes on every run.
  r.fit["solver"].erase("seconds");
  r.fit["solver"].erase("solve_seconds");
  r.evaluations = std::move(evaluations);
  r.outputs = outputs.get<std::vector<std::string>>();
  r.encoding = encoding;
  return r;
}

}  // namespace

void RunFitJob(const RunContext& context, const Job& job, Renderer& renderer) {
  const ReferenceGroup& g = context.spec.groups[job.group];
  const FitSettings s = context.spec.SettingsOf(job.model, job.loss);
  StageClock clock;

  // The run's references, shared with its other jobs (a 96-light set is gigabytes): the encoding
  // search replaces them with its redecoded copies.
  std::vector<std::string> paths;
  for (const ReferenceSpec& r : g.references) paths.push_back(r.image_path);
  std::vector<SharedReference> references = context.References(paths);
  const fit::FitProblem problem = FitProblemOf(job, s, g, references);
  fit::FitOptions fo = FitOptionsOf(s, renderer);
  clock.Lap("read");
  // The seconds of the fits this job solved (its timing's solver_seconds): a BRDF-space start it
  // made, and its own fit unless another job made it (a BRDF-space training set's).
  double solver_seconds = 0.0;
  if (s.start == StartFrom::kBrdf && !TrainsInBrdfSpace(job.train)) {
    solver_seconds += AddBrdfSpaceStart(context, job, s, g.material, &fo);
  }
  clock.Lap("brdf_start");
  if (FaultArmed("gl-lost")) throw GlContextLostError("", "GL", "context lost (simulated)");
  fit::FitResult result;
  json encoding;  // The encoding search's record (encoding = "fit"), else null.
  try {
    double solved_here = 0.0;
    result = SolveFitJob(context, job, s, g.material, problem, fo, &references, &encoding,
                         &solved_here);
    solver_seconds += solved_here;
  } catch (const fit::DegenerateReferenceError& e) {
    WriteFailedFit(context, job, FitStatus::kDegenerateReference, e.what());
    return;
  }
  clock.Lap("fit");
  KillPoint("fit");
  if (FaultArmed("nan-residuals")) {
    result.final_cost = std::numeric_limits<double>::quiet_NaN();
    for (double& v : result.values) v = std::numeric_limits<double>::quiet_NaN();
  }
  if (!std::isfinite(result.final_cost)) {
    WriteFailedFit(context, job, FitStatus::kNanResiduals,
                   fmt::format("the solve ended with a non-finite cost ({})",
                               fit::TerminationName(result.termination)));
    return;
  }
  if (!result.converged) {
    context.log->Line(
        fmt::format("{}: fit did not converge ({}); recorded as such", job.id,
                    fit::TerminationName(result.termination)));
  }

  std::vector<EvaluationRecord> evaluations;
  json outputs = json::array();
  try {
    for (std::size_t i = 0; i < references.size(); ++i) {
      evaluations.push_back(Evaluate(context, job, g.references[i], *references[i],
                                     encoding.is_null(), result, renderer, &outputs, &clock));
    }
  } catch (const NonFiniteRenderError& e) {
    RemoveFitPreviews(context, outputs);
    WriteFailedFit(context, job, FitStatus::kNonFiniteRender, e.what());
    return;
  }
  const FitJobRecord record =
      FitRecord(context, job, s, result, std::move(evaluations), outputs, encoding);
  const std::string text = ToJson(record).dump(1) + "\n";
  clock.Lap("write");
  WriteTiming(context, job, clock, solver_seconds);
  WriteJobJson(context.paths.JobJson(job), text);
}

void WriteFailedFit(const RunContext& context, const Job& job, FitStatus status,
                    const std::string& error) {
  context.log->Say(
      fmt::format("{}: {}: {}; recorded, the study goes on", job.id, FitStatusName(status), error));
  FitJobRecord record = FitRecordHeader(context, job, status);
  record.error = error;
  WriteTiming(context, job, StageClock(), -1.0);
  WriteJobJson(context.paths.JobJson(job), ToJson(record).dump(1) + "\n");
}

}  // namespace shadefit::studies::internal
