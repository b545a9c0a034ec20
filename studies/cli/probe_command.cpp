// `shadefit probe <fresnel|highlight|energy|portability> --ref a.exr [--ref ...]
//      [--model M --set name=v ...] [--fit fit.json ...] [--truth-from-sidecar] -o DIR`:
// the phenomenon probes (docs/probes.md). References load with their sidecar scene
// (shadefit::reference_images::LoadReference); their G-buffers are rendered here.
// `shadefit probe brdf --brdf x.binary|x.h5 [--model M --set ...] [--fit fit.json ...] -o DIR`:
// the BRDF-space probes of a measured BRDF (probes/brdf_space.h); no references, no GL.
//
// Links: shadefit::probes, shadefit::reference_images (references and sidecars), CLI11::CLI11, fmt::fmt,
// nlohmann_json.
#include <fmt/core.h>

#include <CLI/CLI.hpp>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "commands.h"
#include "shadefit/base/error.h"
#include "shadefit/base/files.h"
#include "shadefit/probes/brdf_space.h"
#include "shadefit/probes/probes.h"
#include "shadefit/reference_images/measured_brdf.h"
#include "shadefit/reference_images/reference.h"
#include "shadefit/reference_images/sidecar.h"
#include "shadefit/render/gl_context.h"
#include "shadefit/render/renderer.h"

namespace shadefit::cli {
namespace {

namespace fs = std::filesystem;

struct ProbeCliOptions {
  std::string probe;
  std::vector<std::string> refs;
  std::string brdf;
  std::string model;
  std::string label;
  std::vector<std::string> sets;
  std::vector<std::string> trained_on;
  std::vector<std::string> fits;
  bool truth_from_sidecar = false;
  std::string output;
};

nlohmann::json ReadJson(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw Error(path, "", "cannot open file");
  try {
    return nlohmann::json::parse(f);
  } catch (const nlohmann::json::exception& e) {
    throw Error(path, "json", "malformed JSON: " + OneLine(e.what()));
  }
}

// A fit result (fit/src/fitter.cpp FitResultToJson): model, values by name, exposure.value and
// the references it was fitted to (inputs.references[].name).
probes::ModelUnderTest ModelFromFit(const std::string& path) {
  const nlohmann::json j = ReadJson(path);
  probes::ModelUnderTest m;
  if (!j.contains("model") || !j["model"].is_string()) throw Error(path, "model", "missing");
  try {
    m.model = FindModel(j["model"].get<std::string>());
  } catch (const Error& e) {
    throw Error(path, "", e.what());  // "<fit.json>: model: unknown model ..."
  }
  const ModelInfo& info = *m.model;
  m.label = fs::path(path).stem().string();
  m.params = DefaultParams(info);
  if (!j.contains("values") || !j["values"].is_object()) throw Error(path, "values", "missing");
  for (const auto& spec : info.params) {
    if (!j["values"].contains(spec.name)) throw Error(path, "values." + spec.name, "missing");
    const auto& v = j["values"][spec.name];
    std::vector<double> values;
    if (v.is_array()) {
      for (const auto& x : v) {
        if (!x.is_number()) throw Error(path, "values." + spec.name, "not a number");
        values.push_back(x.get<double>());
      }
    } else if (v.is_number()) {
      values.push_back(v.get<double>());
    } else {
      throw Error(path, "values." + spec.name, "not a number");
    }
    SetParam(info, spec.name, values, path, &m.params);
  }
  if (j.contains("exposure") && j["exposure"].is_object() && j["exposure"].contains("value") &&
      j["exposure"]["value"].is_number()) {
    m.exposure = j["exposure"]["value"].get<double>();
  }
  if (j.contains("inputs") && j["inputs"].contains("references")) {
    for (const auto& r : j["inputs"]["references"]) {
      if (r.contains("name") && r["name"].is_string()) m.trained_on.push_back(r["name"]);
    }
  }
  return m;
}

// The first reference's Cycles material as one of our models (probes::TruthOfReference, as the
// study's probe job and the Python module take it); an error naming the sidecar when it has no
// exact twin.
probes::ModelUnderTest TruthFromSidecar(const std::string& image_path) {
  const std::string sidecar = reference_images::SidecarPathFor(image_path);
  std::string why_not;
  std::optional<probes::ModelUnderTest> truth = probes::TruthOfReference(sidecar, &why_not);
  if (!truth) throw Error(sidecar, "material", why_not + " (needed by --truth-from-sidecar)");
  return *std::move(truth);
}

// --model (with --set) and every --fit, in that order.
std::vector<probes::ModelUnderTest> ModelsOf(const ProbeCliOptions& o) {
  std::vector<probes::ModelUnderTest> models;
  if (!o.model.empty()) {
    const ModelInfo& info = FindModel(o.model);
    probes::ModelUnderTest m;
    m.model = info;
    m.label = o.label.empty() ? o.model : o.label;
    m.params = DefaultParams(info);
    for (const auto& s : o.sets) SetParamFromString(info, s, "--set", &m.params);
    m.trained_on = o.trained_on;
    models.push_back(m);
  } else if (!o.sets.empty()) {
    throw Error("", "--set", "needs --model");
  }
  for (const std::string& f : o.fits) models.push_back(ModelFromFit(f));
  return models;
}

void RunBrdf(const ProbeCliOptions& o) {
  if (o.brdf.empty()) throw Error("", "--brdf", "the brdf probe needs a measured BRDF file");
  if (!o.refs.empty()) throw Error("", "--ref", "not read by the brdf probe (it reads --brdf)");
  if (o.truth_from_sidecar) throw Error("", "--truth-from-sidecar", "not used by the brdf probe");
  const std::unique_ptr<reference_images::MeasuredBrdf> brdf =
      reference_images::LoadMeasuredBrdf(o.brdf);
  const std::vector<probes::ModelUnderTest> models = ModelsOf(o);
  const probes::ProbeResult result = probes::BrdfSpaceProbe(*brdf, models);
  probes::WriteProbeOutputs(result, o.output);
  fmt::print("brdf probe: {} ({}), {} model(s) -> {}/brdf.json, {}/brdf.png\n", o.brdf,
             brdf->Format(), models.size(), o.output, o.output);
}

void Run(const ProbeCliOptions& o) {
  // CLI11 has checked the name against ProbeNames().
  const probes::ProbeKind kind = *probes::ParseProbeKind(o.probe);
  if (kind == probes::ProbeKind::kBrdf) return RunBrdf(o);
  if (!o.brdf.empty()) throw Error("", "--brdf", "only the brdf probe reads a measured BRDF");
  if (o.refs.empty() && kind != probes::ProbeKind::kEnergy) {
    throw Error("", "--ref", "at least one reference");
  }
  GlContext context;
  Renderer renderer(context);
  probes::ProbeInputs in;
  in.renderer = &renderer;
  for (const std::string& path : o.refs) {
    in.references.push_back(probes::LoadProbeReference(path, renderer));
  }
  in.models = ModelsOf(o);
  if (o.truth_from_sidecar) {
    if (o.refs.empty()) throw Error("", "--truth-from-sidecar", "needs --ref");
    in.truth = TruthFromSidecar(o.refs.front());
  }
  const probes::ProbeResult result = probes::RunProbe(kind, in);
  probes::WriteProbeOutputs(result, o.output);
  fmt::print("{} probe: {} reference(s), {} model(s){} -> {}/{}.json, {}/{}.png\n", o.probe,
             in.references.size(), in.models.size(), in.truth ? " + truth" : "", o.output, o.probe,
             o.output, o.probe);
}

}  // namespace

void RegisterProbeCommand(CLI::App& app) {
  auto opt = std::make_shared<ProbeCliOptions>();
  auto* cmd = app.add_subcommand("probe",
                                 "Phenomenon probes: fresnel, highlight, energy, "
                                 "portability; brdf reads a measured BRDF (docs/probes.md)");
  cmd->add_option("probe", opt->probe, "Which probe")
      ->required()
      ->check(CLI::IsMember(probes::ProbeNames()));
  cmd->add_option("--ref", opt->refs, "Reference EXR with its sidecar JSON (repeatable)");
  cmd->add_option("--brdf", opt->brdf,
                  "Measured BRDF for the brdf probe: MERL .binary or Neural-BRDF .h5");
  cmd->add_option("--model", opt->model, "A model under test (see `shadefit models`)");
  cmd->add_option("--label", opt->label, "Label of --model in the outputs (default: its name)");
  cmd->add_option("--set", opt->sets, "Parameter of --model, name=value or name=r,g,b");
  cmd->add_option("--trained-on", opt->trained_on,
                  "Reference names --model was fitted to (portability)");
  cmd->add_option("--fit", opt->fits, "A fit result JSON from `shadefit fit` (repeatable)");
  cmd->add_flag("--truth-from-sidecar", opt->truth_from_sidecar,
                "Truth = the first reference's Cycles material (principled/diffuse)");
  cmd->add_option("-o,--output", opt->output, "Output directory")->required();
  cmd->callback([opt] { Run(*opt); });
}

}  // namespace shadefit::cli
