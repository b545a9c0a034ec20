// A study's [fit] table and the checks of what it names: models, their settings and `fixed`
// values, training lightings, and the [study] comparisons between models (docs/studies.md).
#include <optional>

#include "shadefit/fit/option_checks.h"
#include "shadefit/render/models.h"
#include "study_file.h"

namespace shadefit::studies::internal {
namespace {

// A study's key for a fit setting: the command-line flag's words joined by '_'
// ("max_iterations"), except the GL path's environment samples, spelled out.
std::string StudyKey(fit::FitField field) {
  if (field == fit::FitField::kEnvironmentSamples) return "environment_samples";
  return fit::FitKeyword(field);
}

// Where a model's `fixed` list comes from: the text of the last table that sets it, its key
// (fit.fixed, fit.override.<model>.fixed or quick.fixed) and its node.
struct FixedSource {
  std::vector<std::string> text;
  std::string key = "fit.fixed";
  const toml::node* node = nullptr;
};

// One table's fit settings, read over `s` (the defaults, or the settings it overrides) and
// checked, as merged so far, by the rules `shadefit fit` uses (fit/option_checks.h).
void ReadFitSettings(const Reader& r, const toml::table& t, const std::string& prefix,
                     FitSettings* s, FixedSource* fixed) {
  auto choice = [&](const char* key, auto parse, auto* out) {
    if (!t.contains(key)) return;
    try {
      *out = parse(r.String(t, prefix, key, ""));
    } catch (const fit::FitOptionError& e) {
      r.Fail(t.get(key), prefix + key, e.problem);
    }
  };
  if (!(t.contains("loss") && t.get("loss")->is_array())) choice("loss", fit::ParseLoss, &s->loss);
  choice("exposure", fit::ParseExposure, &s->exposure);
  choice("path", fit::ParsePath, &s->path);
  choice("encoding", fit::ParseEncodingMode, &s->encoding);
  constexpr std::int64_t kLowest = std::numeric_limits<int>::min();
  s->loss_scale = r.Number(t, prefix, "loss_scale", s->loss_scale);
  s->starts = static_cast<int>(r.Integer(t, prefix, "starts", s->starts, kLowest));
  s->seed = static_cast<std::uint64_t>(
      r.Integer(t, prefix, "seed", s->seed, 0, std::numeric_limits<std::int64_t>::max()));
  s->max_iterations =
      static_cast<int>(r.Integer(t, prefix, "max_iterations", s->max_iterations, kLowest));
  s->environment_samples = static_cast<int>(
      r.Integer(t, prefix, "environment_samples", s->environment_samples, kLowest));
  s->pixel_stride = static_cast<int>(r.Integer(t, prefix, "pixel_stride", s->pixel_stride, 1));
  if (t.contains("fixed")) {
    fixed->text = r.Strings(t, prefix, "fixed");
    fixed->key = prefix + "fixed";
    fixed->node = t.get("fixed");
  }
  const std::string start =
      r.String(t, prefix, "start", s->start == StartFrom::kBrdf ? "brdf" : "default");
  if (start != "default" && start != "brdf") {
    r.Fail(t.get("start"), prefix + "start", "expected \"default\" or \"brdf\"");
  }
  s->start = start == "brdf" ? StartFrom::kBrdf : StartFrom::kDefault;
  try {
    fit::CheckFitOptions(s->Options(), s->encoding);
  } catch (const fit::FitOptionError& e) {
    const std::string key = StudyKey(e.field);
    r.Fail(t.get(key), prefix + key, e.problem);
  }
}

// A model's `fixed` values, made for it from their text and checked against its parameter table
// when the file is loaded (the fitter would reject them only when the job runs, after the other
// models' fits). A name the model lacks, written for every model, is answered with the way to
// write it for some: [fit.override.<model>] (docs/studies.md, "Fit").
std::vector<FixedValue> FixedFor(const Reader& r, const ModelInfo& model,
                                 const FixedSource& source) {
  const toml::array* a = source.node != nullptr ? source.node->as_array() : nullptr;
  std::vector<FixedValue> out;
  for (std::size_t i = 0; i < source.text.size(); ++i) {
    const std::string& assignment = source.text[i];
    const toml::node* where = a != nullptr && i < a->size() ? a->get(i) : source.node;
    const std::string name = assignment.substr(0, assignment.find('='));
    if (model.Find(name) == nullptr) {
      std::vector<std::string> names;
      std::string having;
      for (const ParamSpec& p : model.params) names.push_back(p.name);
      for (const ModelInfo& m : AllModels()) {
        if (m.Find(name) != nullptr) having += (having.empty() ? "" : ", ") + m.name;
      }
      const bool for_every_model = source.key.rfind("fit.override.", 0) != 0;
      // A parameter of other models is no typo: no "did you mean" for it.
      std::string advice = having.empty() ? DidYouMean(name, names) : "";
      if (for_every_model) {
        advice += " (write it under [fit.override.<model>]" +
                  (having.empty() ? std::string() : "; models that have it: " + having) + ")";
      }
      r.Fail(where, source.key,
             fmt::format("'{}' is not a parameter of model '{}'{}", name, model.name, advice));
    }
    try {
      out.push_back(ParseFixedValue(model, assignment, ""));
    } catch (const Error& e) {
      r.Fail(where, source.key, fmt::format("model '{}': {}", model.name, e.what()));
    }
  }
  return out;
}

// `loss` given as a list in `t` ([fit] or [quick]): every model is fitted under each, a fit per
// loss (docs/studies.md, "Losses and floors"); nothing when it is a single name.
std::optional<std::vector<fit::Loss>> ReadLosses(const Reader& r, const toml::table& t,
                                                 const std::string& prefix) {
  const toml::node* n = t.get("loss");
  if (n == nullptr || !n->is_array()) return std::nullopt;
  std::vector<fit::Loss> out;
  for (const toml::node& e : *n->as_array()) {
    if (!e.is_string()) r.Fail(&e, prefix + "loss", "expected loss names");
    try {
      const fit::Loss loss = fit::ParseLoss(*e.value<std::string>());
      if (std::find(out.begin(), out.end(), loss) != out.end()) {
        r.Fail(&e, prefix + "loss", "'" + fit::LossName(loss) + "' listed twice");
      }
      out.push_back(loss);
    } catch (const fit::FitOptionError& err) {
      r.Fail(&e, prefix + "loss", err.problem);
    }
  }
  if (out.empty()) r.Fail(n, prefix + "loss", "empty list of losses");
  return out;
}

// [fit] models, resolved here once, and their settings: the defaults, [fit.override.<model>],
// then [quick].
void ReadFitModels(const Reader& r, const toml::table& fit, const QuickFilter& q, StudySpec* spec) {
  const toml::table* qt = q.table;
  std::vector<std::string> names = r.Strings(fit, "fit.", "models");
  if (qt != nullptr && qt->contains("models")) names = r.Strings(*qt, "quick.", "models");
  if (names.empty()) r.Fail(fit.get("models"), "fit.models", "missing or empty");
  spec->models.clear();
  for (const std::string& m : names) {
    try {
      spec->models.push_back(FindModel(m));
    } catch (const Error& e) {
      r.Fail(fit.get("models"), "fit.models", e.what());
    }
  }
  FitSettings defaults;
  FixedSource default_fixed;
  spec->losses = ReadLosses(r, fit, "fit.").value_or(std::vector<fit::Loss>{});
  if (qt != nullptr && qt->contains("loss")) {
    spec->losses = ReadLosses(r, *qt, "quick.").value_or(std::vector<fit::Loss>{});
  }
  if (!spec->losses.empty()) defaults.loss = spec->losses.front();
  ReadFitSettings(r, fit, "fit.", &defaults, &default_fixed);
  const toml::table* overrides = r.Table(fit, "fit.", "override");
  if (overrides != nullptr) {
    for (const auto& [key, node] : *overrides) {
      const std::string model(key.str());
      if (std::find(names.begin(), names.end(), model) == names.end() && qt == nullptr) {
        r.Fail(&node, "fit.override." + model, "not one of fit.models");
      }
      if (!node.is_table()) r.Fail(&node, "fit.override." + model, "expected a table");
      r.CheckKeys(*node.as_table(), "fit.override." + model + ".", kFitKeys);
      if (!spec->losses.empty() && node.as_table()->contains("loss")) {
        r.Fail(node.as_table()->get("loss"), "fit.override." + model + ".loss",
               "fit.loss lists the losses every model is fitted under; remove it here");
      }
      if (node.as_table()->contains("loss") && node.as_table()->get("loss")->is_array()) {
        r.Fail(node.as_table()->get("loss"), "fit.override." + model + ".loss",
               "a list of losses goes under [fit] loss");
      }
    }
  }
  for (ModelRef model : spec->models) {
    const std::string& m = model->name;
    FitSettings s = defaults;
    FixedSource fixed = default_fixed;
    if (overrides != nullptr) {
      if (const toml::table* o = r.Table(*overrides, "fit.override.", m)) {
        ReadFitSettings(r, *o, "fit.override." + m + ".", &s, &fixed);
      }
    }
    if (qt != nullptr) ReadFitSettings(r, *qt, "quick.", &s, &fixed);
    s.fixed = FixedFor(r, *model, fixed);
    spec->model_settings[m] = s;
  }
}

// fit.train (or quick.training_sets): lighting names, or arrays of them.
std::vector<std::vector<std::string>> ReadTrainingSets(const Reader& r, const toml::table& t,
                                                       const std::string& prefix) {
  std::vector<std::vector<std::string>> sets;
  const toml::node* n = t.get("train");
  if (prefix == "quick.") n = t.get("training_sets");
  if (n == nullptr) return sets;
  const toml::array* a = n->as_array();
  if (a == nullptr) r.Fail(n, prefix + "train", "expected an array of arrays of lighting names");
  for (const toml::node& e : *a) {
    std::vector<std::string> set;
    if (e.is_string()) {
      set.push_back(*e.value<std::string>());
    } else if (const toml::array* inner = e.as_array()) {
      for (const toml::node& x : *inner) {
        if (!x.is_string()) r.Fail(&x, prefix + "train", "expected lighting names");
        set.push_back(*x.value<std::string>());
      }
    } else {
      r.Fail(&e, prefix + "train", "expected a lighting name or an array of them");
    }
    if (set.empty()) r.Fail(&e, prefix + "train", "empty training set");
    sets.push_back(set);
  }
  return sets;
}

// Every training lighting exists for every material, measured or not. The BRDF-space set
// (kBrdfSpaceTraining) stands alone, needs a [[measured]] material and an l2 fit with a fixed
// exposure (fit/brdf_space.h).
void CheckTrainingLightings(const Reader& r, const toml::table& fit, const StudySpec& spec) {
  for (const auto& set : spec.training_sets) {
    if (std::find(set.begin(), set.end(), kBrdfSpaceTraining) == set.end()) continue;
    if (set.size() != 1) {
      r.Fail(fit.get("train"), "fit.train",
             fmt::format("'{}' (a fit in BRDF space) is a training set of its own, not a "
                         "lighting to combine with others",
                         kBrdfSpaceTraining));
    }
    for (const auto& [model, s] : spec.model_settings) {
      // With a list of losses the BRDF-space fit is made once, under its own L2 objective.
      const bool loss_ok = s.loss == fit::Loss::kL2 || !spec.losses.empty();
      if (!loss_ok || s.exposure != fit::Exposure::kFixed ||
          s.encoding != fit::EncodingMode::kAsImported) {
        r.Fail(fit.get("train"), "fit.train",
               fmt::format("'{}' fits the cosine-weighted BRDF in L2 with no scale: model '{}' "
                           "needs loss = \"l2\", exposure = \"fixed\" and no encoding search",
                           kBrdfSpaceTraining, model));
      }
    }
  }
  for (const MeasuredSource& m : spec.measured) {
    for (const auto& set : spec.training_sets) {
      for (const std::string& l : set) {
        if (l == kBrdfSpaceTraining) continue;
        if (std::find(m.lightings.begin(), m.lightings.end(), l) == m.lightings.end()) {
          r.Fail(fit.get("train"), "fit.train",
                 fmt::format("[[measured]] {} has no scene under lighting '{}'", m.folder, l));
        }
      }
    }
  }
  for (const ReferenceGroup& g : spec.groups) {
    for (const auto& set : spec.training_sets) {
      for (const std::string& l : set) {
        if (l == kBrdfSpaceTraining) {
          r.Fail(fit.get("train"), "fit.train",
                 fmt::format("'{}' fits the measured BRDF itself; material '{}' is a [[group]] of "
                             "images with no BRDF file ([[measured]] materials have one)",
                             kBrdfSpaceTraining, g.material));
        }
        const bool has = std::any_of(g.references.begin(), g.references.end(),
                                     [&](const ReferenceSpec& x) { return x.lighting == l; });
        if (!has) {
          r.Fail(fit.get("train"), "fit.train",
                 fmt::format("material '{}' has no reference under lighting '{}'", g.material, l));
        }
      }
    }
  }
}

// [fit] floor: the lightings of each model's floor fit, appended to the training sets. Under
// --quick only the floor lightings [quick] keeps (none left: no floor).
void ReadFloor(const Reader& r, const toml::table& fit, const QuickFilter& q, StudySpec* spec) {
  std::vector<std::string> floor = r.Strings(fit, "fit.", "floor");
  if (!fit.contains("floor")) return;
  if (floor.empty()) r.Fail(fit.get("floor"), "fit.floor", "empty: list the floor's lightings");
  std::set<std::string> seen;
  for (const std::string& l : floor) {
    if (l == kBrdfSpaceTraining) {
      r.Fail(fit.get("floor"), "fit.floor", "the floor is a fit to images; 'brdf' is a training set");
    }
    if (!seen.insert(l).second) r.Fail(fit.get("floor"), "fit.floor", "'" + l + "' listed twice");
  }
  if (q.table != nullptr) {
    std::erase_if(floor, [&](const std::string& l) { return !q.KeepsLighting(l); });
    if (floor.size() < 2) return;
  }
  for (const auto& set : spec->training_sets) {
    if (set == floor) {
      r.Fail(fit.get("floor"), "fit.floor",
             "the floor equals a training set of fit.train; a floor is fitted anyway");
    }
  }
  spec->floor_lightings = floor;
  spec->training_sets.push_back(floor);
}

}  // namespace

// [fit]
void ReadFit(const Reader& r, const toml::table& root, const QuickFilter& q, StudySpec* spec) {
  const toml::table* fit = r.Table(root, "", "fit");
  if (fit == nullptr) r.Fail(nullptr, "fit", "missing [fit] table");
  {
    std::set<std::string> allowed = kFitKeys;
    for (const char* k : {"models", "train", "test", "override", "floor"}) allowed.insert(k);
    r.CheckKeys(*fit, "fit.", allowed);
  }
  ReadFitModels(r, *fit, q, spec);
  spec->training_sets = ReadTrainingSets(r, *fit, "fit.");
  if (q.table != nullptr && q.table->contains("training_sets")) {
    spec->training_sets = ReadTrainingSets(r, *q.table, "quick.");
  }
  if (spec->training_sets.empty()) r.Fail(fit->get("train"), "fit.train", "missing or empty");
  spec->test_lightings = r.Strings(*fit, "fit.", "test");
  ReadFloor(r, *fit, q, spec);
  CheckTrainingLightings(r, *fit, *spec);
}

// [study] baseline and compare, after the models are known: the fit every other is compared
// with (default: the first model), and further pairs of models to compare (docs/studies.md,
// "Comparative answers"). Each name must be one of the file's fit.models; under --quick a name
// that [quick] dropped falls back to the first model (baseline) or drops its pair (compare).
void ReadComparisons(const Reader& r, const toml::table& root, const toml::table& fit,
                     StudySpec* spec) {
  const toml::table& study = *r.Table(root, "", "study");
  const std::vector<std::string> file_models = r.Strings(fit, "fit.", "models");
  const auto known = [&](const std::string& m) {
    return std::find(file_models.begin(), file_models.end(), m) != file_models.end();
  };
  const auto kept = [&](const std::string& m) {
    return std::any_of(spec->models.begin(), spec->models.end(),
                       [&](ModelRef kept_model) { return kept_model->name == m; });
  };
  spec->baseline = spec->models.front()->name;
  if (study.contains("baseline")) {
    const std::string b = r.String(study, "study.", "baseline", "");
    if (!known(b))
      r.Fail(study.get("baseline"), "study.baseline", "'" + b + "' is not one of fit.models");
    if (kept(b)) spec->baseline = b;
  }
  const toml::node* n = study.get("compare");
  if (n == nullptr) return;
  const toml::array* pairs = n->as_array();
  if (pairs == nullptr) r.Fail(n, "study.compare", "expected an array of [model, model] pairs");
  for (const toml::node& e : *pairs) {
    const toml::array* pair = e.as_array();
    if (pair == nullptr || pair->size() != 2 || !(*pair)[0].is_string() ||
        !(*pair)[1].is_string()) {
      r.Fail(&e, "study.compare", "expected a pair of model names, [\"ggx\", \"beckmann\"]");
    }
    const std::string a = *(*pair)[0].value<std::string>(), b = *(*pair)[1].value<std::string>();
    for (const std::string& m : {a, b}) {
      if (!known(m)) r.Fail(&e, "study.compare", "'" + m + "' is not one of fit.models");
    }
    if (a == b) r.Fail(&e, "study.compare", "a model compared with itself");
    if (kept(a) && kept(b)) spec->comparisons.push_back({a, b});
  }
}

}  // namespace shadefit::studies::internal
