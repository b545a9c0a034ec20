// Study files: which references, which models, how to fit them, what to measure and the
// tolerances the verdicts use (format in docs/studies.md).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "shadefit/fit/defaults.h"
#include "shadefit/fit/encoding_search.h"
#include "shadefit/fit/encoding_search.h"
#include "shadefit/fit/fit_types.h"
#include "shadefit/probes/probe_kind.h"

namespace shadefit::studies {

// One reference image of a group, with the names the runner and report use.
struct ReferenceSpec {
  std::string name;          // Image stem: "red-plastic-key".
  std::string material;      // The group's material: "red-plastic".
  std::string lighting;      // "key": the stem after "<material>-", else the sidecar's scene stem.
  std::string image_path;    // Absolute.
  std::string sidecar_path;  // Absolute; "" when the image has none.
};

// One material under several lightings.
struct ReferenceGroup {
  std::string material;
  // What the material is on, when a study compares objects ("suzanne"; a photo set's object):
  // results.csv's object column, the report's unit of per-object answers. "" for spheres and
  // planes (docs/studies.md, "Objects").
  std::string object;
  std::vector<ReferenceSpec> references;  // Sorted by lighting name.
};

// Where an image fit of a [[measured]] material starts: "default" (the table defaults, then
// Halton points) or "brdf", also from the material's BRDF-space fit (Ngan et al. 2005's
// objective, fit/brdf_space.h) of the same model; fits of other groups start as by default
// (docs/studies.md, "Fits").
enum class StartFrom { kDefault, kBrdf };

// The fitter settings a study fixes for one model, typed and checked when the file is loaded
// (by the rules `shadefit fit` uses too: fit/option_checks.h). Per-model overrides may change any
// of them.
struct FitSettings {
  fit::Loss loss = fit::Loss::kCubeRoot;
  double loss_scale = 0.0;
  int starts = fit::kDefaultStarts;  // The CLI's default (shadefit/fit/defaults.h).
  std::uint64_t seed = 1;
  fit::Exposure exposure = fit::Exposure::kFixed;
  fit::DerivativePath path = fit::DerivativePath::kAuto;
  int max_iterations = fit::kDefaultMaxIterations;
  // Fit on every stride-th pixel in x and y (1 = all): cost falls as stride^2 while metrics are
  // still computed on every pixel. The subsample is a mask, so the images are never resampled.
  int pixel_stride = 1;
  int environment_samples = 0;  // GL path: override the scenes' environment samples (0 = keep).
  // Held constant, made for this model (checked against its table when the file is loaded):
  // [fit] fixed applies to every model, so it may name only parameters every listed model has; a
  // parameter some models lack goes under [fit.override.<model>].
  std::vector<FixedValue> fixed;
  // kAsImported (the references' own decoding) | kFit: choose sRGB, linear or a fitted gamma on
  // the training references (fit/encoding_search.h) and decode every reference with it.
  fit::EncodingMode encoding = fit::EncodingMode::kAsImported;
  StartFrom start = StartFrom::kDefault;

  // The fitter's options these settings give (the rest at their defaults).
  fit::FitOptions Options() const;
  nlohmann::json ToJson() const;
};

// [measured]: materials given as measured BRDF files (MERL .binary, or Neural-BRDF .h5 with its
// .json), rendered by the study itself under each of `scenes` (MaterialiseMeasuredReferences)
// before any fit; their references then form one group per material like any other.
struct MeasuredSource {
  std::string folder;                 // Absolute.
  bool present = false;               // false: the folder is absent; the part is skipped.
  std::vector<std::string> brdfs;     // Absolute paths of the BRDF files, sorted.
  std::vector<std::string> materials; // Their stems, in the same order.
  std::vector<std::string> scenes;    // Absolute scene paths, one per lighting.
  std::vector<std::string> lightings; // "key" for ".../sphere-key.toml", in the same order.
  int samples = 0;                    // Environment samples per technique (0 = the scene's).
  // The object the scenes show (a mesh's or a normal map's), where several [[measured]] tables
  // render the same BRDFs on different objects: materials are then "<object>-<stem>", grouped
  // under that object for the report's per-object answers. Empty: the stems, no object.
  std::string object;
};

// The training set that fits a [[measured]] material's BRDF itself, in BRDF space (Ngan et al.
// 2005's objective, fit/brdf_space.h), rather than images of it: fit.train = [["brdf"]]. Every
// lighting is then a test.
inline constexpr const char* kBrdfSpaceTraining = "brdf";
inline bool TrainsInBrdfSpace(const std::vector<std::string>& train) {
  return train.size() == 1 && train[0] == kBrdfSpaceTraining;
}

// What a fit's training set is for (docs/studies.md, "Losses and floors"): an ordinary training
// set of [fit] train, the floor (a joint fit to every lighting of [fit] floor: the best the model
// does on these views, against which one image's fit is judged), or the BRDF-space fit.
enum class FitRole { kTrain, kFloor, kBrdf };
const char* FitRoleName(FitRole role);  // "train", "floor", "brdf"

// One fit of a study, for every material: a model, a training set and a loss, and its label.
struct FitSpec {
  ModelRef model;
  std::vector<std::string> train;
  fit::Loss loss = fit::Loss::kL2;
  FitRole role = FitRole::kTrain;
  std::string label;
};

struct StudySpec {
  std::string name;         // [study] name; names the output folder.
  std::string description;
  std::string path;         // Absolute path of the study file.
  std::string text;         // Its bytes, for provenance and the job hashes' context.
  bool quick = false;       // The [quick] overrides were applied.

  std::vector<ReferenceGroup> groups;
  std::vector<MeasuredSource> measured;  // [[measured]] tables (groups added when rendered).
  std::vector<ModelRef> models;          // Resolved when the file is loaded.
  std::map<std::string, FitSettings> model_settings;  // Every model, overrides applied.
  const FitSettings& SettingsOf(ModelRef model) const { return model_settings.at(model->name); }
  // The model's settings with the loss of one of its fits.
  FitSettings SettingsOf(ModelRef model, fit::Loss loss) const;
  std::vector<std::vector<std::string>> training_sets;  // Lighting names per set, the floor last.
  // [fit] loss given as a list: every model is fitted under each loss, a fit per loss like a
  // training set (the BRDF-space fit has its own objective: once). Empty: each model's `loss`.
  std::vector<fit::Loss> losses;
  // [fit] floor: the lightings of the floor fit (also the last of training_sets); empty: none.
  std::vector<std::string> floor_lightings;
  // [verdicts] judging: the image metrics the report answers each image question under; unset:
  // the report's default judging set (report/report_judging.py).
  std::optional<std::vector<std::string>> judging;
  std::vector<std::string> test_lightings;  // Empty: every lighting not in the training set.

  float metrics_exposure_stops = 0.0f;
  double metrics_ppd = 67.0;
  std::vector<probes::ProbeKind> probes;  // [probes] run, in the file's order.
  // [probes] plots: also draw probes/<material>/<probe>.png (matplotlib, one Python process per
  // probe and material). Off by default: the report draws every probe figure from the JSON.
  bool probe_plots = false;
  nlohmann::json verdicts;          // [verdicts] as JSON, read by the report.
  // [study] baseline: the model every other fit is compared with in the report's comparative
  // answers (per training set); [study] compare: more pairs of models to compare.
  std::string baseline;
  std::vector<std::array<std::string, 2>> comparisons;
  bool previews = true;             // Reference / fit / error PNGs per reference and fit.
  bool report = true;               // `study run` makes the report at the end.
  // [outputs] floor: write geometry/ for the report's data floor (studies/runner/src/
  // geometry_outputs.h). Unset: on when any fit has a free exposure (photographs).
  std::optional<bool> floor;

  // Label of a fit in outputs: the model name when the study has one training set, else
  // "<model>@<lighting>+<lighting>" ("<model>@floor" for the floor); ":<loss>" appended when the
  // study lists several losses (never to the BRDF-space fit, which has one objective).
  std::string Label(const std::string& model, const std::vector<std::string>& train) const;
  std::string Label(const std::string& model, const std::vector<std::string>& train,
                    fit::Loss loss) const;
  FitRole RoleOf(const std::vector<std::string>& train) const;
  // Every fit of a material, in the order jobs and tables list them: per training set, per
  // model, per loss.
  std::vector<FitSpec> Fits() const;
  // Whether `lighting` is tested for a fit trained on `train`.
  bool IsTest(const std::string& lighting, const std::vector<std::string>& train) const;

  nlohmann::json ToJson() const;  // Everything above except the text, for study.json.
};

// Reads and checks a study file. `quick`: apply its [quick] table. Throws shadefit::Error
// "<file>:<line>: <key>: <problem>" on unknown keys, wrong types, unknown models or probes, a
// `fixed` value a model lacks or holds out of range, globs that match nothing and training
// lightings a group lacks.
StudySpec LoadStudy(const std::string& path, bool quick = false);

// The measured BRDF file of a [[measured]] material; "" for a material of a [[group]].
std::string MeasuredBrdfPath(const StudySpec& spec, const std::string& material);

// Why a [[measured]] source contributes nothing ("" when every source is present): one line
// for the user, naming the folder and where the data comes from.
std::string MeasuredSkipReason(const StudySpec& spec);

}  // namespace shadefit::studies
