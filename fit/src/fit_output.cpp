// Output: a FitResult as JSON, and the files of one fit (JSON, fitted renders, error images).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <list>
#include <map>

#include "shadefit/base/files.h"
#include "shadefit/fit/fitter.h"
#include "shadefit/render/image.h"
#include "shadefit/render/models.h"
#include "shadefit/version.h"
#include "shadefit/base/statistics.h"

namespace shadefit::fit {
namespace fs = std::filesystem;

namespace {
using nlohmann::json;

// A finite number, or null.
json Num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

// Every parameter's estimate, its standard error and the spread of the starts that reached
// the best.
json ParametersJson(const FitResult& r) {
  json params = json::array();
  for (std::size_t i = 0; i < r.parameters.size(); ++i) {
    const ParameterEstimate& p = r.parameters[i];
    json e{{"name", p.name},
           {"value", Num(p.value)},
           {"std_error", Num(p.std_error)},
           {"fixed", p.fixed},
           {"fixed_by", p.fixed_by},
           {"undetermined", p.undetermined},
           {"at_bound", p.at_bound},
           {"spread",
            {{"min", Num(p.spread_min)}, {"max", Num(p.spread_max)}, {"std", Num(p.spread_std)}}}};
    params.push_back(e);
  }
  return params;
}

// The fitted values by parameter name: a number, or an array for a colour.
json ValuesJson(const FitResult& r) {
  json values = json::object();
  const ModelInfo& model = *r.model;
  int offset = 0;
  for (const ParamSpec& spec : model.params) {
    if (spec.size == 1) {
      values[spec.name] = Num(r.values[offset]);
    } else {
      values[spec.name] = json::array();
      for (int c = 0; c < spec.size; ++c) values[spec.name].push_back(Num(r.values[offset + c]));
    }
    offset += spec.size;
  }
  return values;
}

// The starts: how many, how chosen, each one's outcome and the best other basin.
json StartsJson(const FitResult& r) {
  json starts = json::array();
  for (const auto& s : r.start_results) {
    starts.push_back({{"start", s.start},
                      {"params", s.params},
                      {"exposure", Num(s.exposure)},
                      {"initial_cost", Num(s.initial_cost)},
                      {"final_cost", Num(s.final_cost)},
                      {"iterations", s.iterations},
                      {"termination", TerminationName(s.termination)},
                      {"converged", s.converged},
                      {"coarse_cost", Num(s.coarse_cost)},
                      {"polished", s.polished},
                      {"reached_best", s.reached_best}});
  }
  json j = {
      {"count", r.starts},
      {"seed", r.seed},
      {"reached_best", r.starts_reached_best},
      {"tolerance", "final_cost <= best + 1e-6 best + 1e-12 * cost of a black prediction"},
      {"method",
       std::string("start 0 = table defaults; others Halton, Cranley-Patterson shift from seed; "
                   "starts 2 and 3 take the lobe width from the broad and middle strata") +
           (r.given_starts > 0
                ? fmt::format("; the last {} given (a study's start = \"brdf\": the material's "
                              "BRDF-space fit of the model)",
                              r.given_starts)
                : std::string())},
      {"coarse_to_fine", r.coarse_to_fine},
      {"results", starts}};
  // The best other basin: a start that ended above the best cost (on every pixel), with its cost
  // relative to the best, so that a study can flag an optimum that is not clearly separated.
  if (r.second_basin_start >= 0) {
    const StartResult& s = r.start_results[r.second_basin_start];
    j["second_basin"] = {{"start", r.second_basin_start},
                         {"cost", Num(r.second_basin_cost)},
                         {"cost_ratio", Num(r.second_basin_cost / r.final_cost)},
                         {"params", s.params}};
  } else {
    j["second_basin"] = nullptr;
  }
  return j;
}

}  // namespace

nlohmann::json FitResultToJson(const FitResult& r) {
  json j;
  j["shadefit_version"] = SHADEFIT_VERSION_STRING;
  j["model"] = r.model->name;
  j["derivative_path"] = PathName(r.path);
  j["parameters"] = ParametersJson(r);
  j["values"] = ValuesJson(r);
  j["exposure"] = {{"mode", ExposureName(r.exposure_free ? Exposure::kFree : Exposure::kFixed)},
                   {"value", Num(r.exposure)},
                   {"std_error", Num(r.exposure_std_error)}};
  if (r.exposure_free) j["exposure"]["pinned"] = r.exposure_pin.text;
  if (!r.held.empty()) j["held"] = r.held;
  j["loss"] = {{"name", LossName(r.loss)},
               {"scale", r.loss_scale > 0 ? json(r.loss_scale) : json(nullptr)}};
  j["cost"] = {{"initial", Num(r.initial_cost)}, {"final", Num(r.final_cost)}};
  json per_ref = json::array();
  for (const auto& ref : r.references) {
    per_ref.push_back({{"name", ref.name}, {"rmse", Num(ref.rmse)}, {"pixels", ref.pixels}});
  }
  j["rmse"] = {{"overall", Num(r.rmse)},
               {"per_reference", per_ref},
               {"units", "linear radiance, valid pixels, RGB channels"}};
  j["solver"] = {{"iterations", r.iterations},      {"termination", TerminationName(r.termination)},
                 {"converged", r.converged},        {"message", r.solver_message},
                 {"method", r.solver_name},         {"seconds", r.seconds},
                 {"solve_seconds", r.solve_seconds}};
  j["converged"] = r.converged;
  j["starts"] = StartsJson(r);
  j["covariance"] = {{"status", r.CovarianceStatusText()}, {"method", r.covariance_method}};
  j["evaluations"] = {{"model_renders", r.renders},
                      {"gbuffer_renders", r.gbuffer_renders},
                      {"residual_evaluations", r.residual_evaluations},
                      {"jacobian_evaluations", r.jacobian_evaluations}};
  j["inputs"] = r.inputs;
  return j;
}

namespace {

// Preview: |error| / p99(|error|) per channel over valid pixels (alpha > 0), white = p99 or more.
Image ErrorPreview(const Image& abs_error) {
  std::vector<float> errors;
  for (std::size_t p = 0; p < abs_error.PixelCount(); ++p) {
    if (abs_error.data[4 * p + 3] > 0) {
      for (int c = 0; c < 3; ++c) errors.push_back(abs_error.data[4 * p + c]);
    }
  }
  float scale = 1.0f;
  if (!errors.empty()) {
    const float p99 = Percentile(errors, 0.99);
    if (p99 > 0) scale = 1.0f / p99;
  }
  Image preview(abs_error.width, abs_error.height, 3);
  for (std::size_t p = 0; p < abs_error.PixelCount(); ++p) {
    for (int c = 0; c < 3; ++c) {
      preview.data[3 * p + c] = std::min(1.0f, SrgbOetf(abs_error.data[4 * p + c] * scale));
    }
  }
  return preview;
}

}  // namespace

std::vector<std::string> WriteFitOutputs(const FitResult& result, const std::string& json_path,
                                         const nlohmann::json& extra) {
  std::vector<std::string> written;
  const fs::path json(json_path);
  const fs::path dir = json.has_parent_path() ? json.parent_path() : fs::path(".");
  const std::string stem = json.stem().string();
  fs::create_directories(dir);
  nlohmann::json j = FitResultToJson(result);
  if (extra.is_object()) j.update(extra);
  j["outputs"] = nlohmann::json::array();
  std::map<std::string, int> seen;
  // Every file is prepared first and written by WriteAllOrNothing, the JSON last: a failure
  // (a full disk, a folder in the way) leaves none of this fit's files behind.
  std::vector<OutputWrite> writes;
  std::list<Image> previews;  // stable addresses for the writers below
  for (const ReferenceResult& ref : result.references) {
    if (ref.prediction.empty()) continue;
    std::string name = ref.name;
    if (seen[name]++ > 0) name += fmt::format("-{}", seen[name]);
    const std::string base = (dir / (stem + "." + name)).string();
    ImageMetadata meta{{"shadefit:model", result.model->name},
                       {"shadefit:version", SHADEFIT_VERSION_STRING},
                       {"shadefit:fit", json.filename().string()}};
    writes.push_back({base + ".fit.exr",
                      [&ref, meta, base] { WriteExr(base + ".fit.exr", ref.prediction, meta); }});
    writes.push_back({base + ".error.exr",
                      [&ref, meta, base] { WriteExr(base + ".error.exr", ref.abs_error, meta); }});
    const Image& preview = previews.emplace_back(ErrorPreview(ref.abs_error));
    writes.push_back(
        {base + ".error.png", [&preview, base] { WritePng8(base + ".error.png", preview); }});
    for (const char* suffix : {".fit.exr", ".error.exr", ".error.png"}) {
      written.push_back(base + suffix);
      j["outputs"].push_back({{"reference", ref.name}, {"path", base + suffix}});
    }
  }
  const std::string text = j.dump(1) + "\n";
  writes.push_back({json_path, [&] { WriteTextAtomic(json_path, text); }});
  WriteAllOrNothing(writes);
  written.push_back(json_path);
  return written;
}

}  // namespace shadefit::fit
