// A study's [fit] table and the checks of what it names: models, their settings and `fixed`
// values, training lightings, and the [study] comparisons between models (docs/studies.md).
#include "shadefit/render/models.h"
#include "study_file.h"

namespace shadefit::studies::internal {
namespace {

// One table's fit settings, read over `s` (the defaults, or the settings it overrides) and
// checked.
void ReadFitSettings(const Reader& r, const toml::table& t, const std::string& prefix,
                     FitSettings* s) {
  s->loss = r.String(t, prefix, "loss", s->loss);
  s->loss_scale = r.Number(t, prefix, "loss_scale", s->loss_scale, 0.0);
  // Bounds say what a fit can use: more starts than 10000 or iterations than 100000 per start is
  // a typo, not a plan, and would run for days.
  s->starts = static_cast<int>(r.Integer(t, prefix, "starts", s->starts, 1, 10000));
  s->seed = static_cast<std::uint64_t>(
      r.Integer(t, prefix, "seed", s->seed, 0, std::numeric_limits<std::int64_t>::max()));
  s->exposure = r.String(t, prefix, "exposure", s->exposure);
  s->path = r.String(t, prefix, "path", s->path);
  s->max_iterations =
      static_cast<int>(r.Integer(t, prefix, "max_iterations", s->max_iterations, 1, 100000));
  s->pixel_stride = static_cast<int>(r.Integer(t, prefix, "pixel_stride", s->pixel_stride, 1));
  s->environment_samples =
      static_cast<int>(r.Integer(t, prefix, "environment_samples", s->environment_samples, 0));
  if (t.contains("fixed")) s->fixed = r.Strings(t, prefix, "fixed");
  s->encoding = r.String(t, prefix, "encoding", s->encoding);
  s->start = r.String(t, prefix, "start", s->start);
  const std::set<std::string> losses = {"l2", "log", "cuberoot", "huber", "cauchy"};
  if (!losses.contains(s->loss)) {
    r.Fail(t.get("loss"), prefix + "loss",
           "unknown loss '" + s->loss + "'" + DidYouMean(s->loss, {losses.begin(), losses.end()}) +
               " (l2, log, cuberoot, huber, cauchy)");
  }
  if (s->exposure != "fixed" && s->exposure != "free") {
    r.Fail(t.get("exposure"), prefix + "exposure", "expected \"fixed\" or \"free\"");
  }
  if (s->path != "auto" && s->path != "gbuffer" && s->path != "gl") {
    r.Fail(t.get("path"), prefix + "path", "expected \"auto\", \"gbuffer\" or \"gl\"");
  }
  if (s->encoding != "as-imported" && s->encoding != "fit") {
    r.Fail(t.get("encoding"), prefix + "encoding", "expected \"as-imported\" or \"fit\"");
  }
  if (s->start != "default" && s->start != "brdf") {
    r.Fail(t.get("start"), prefix + "start", "expected \"default\" or \"brdf\"");
  }
  if (s->encoding == "fit" && s->exposure != "free") {
    r.Fail(t.get("encoding"), prefix + "encoding",
           "\"fit\" needs exposure = \"free\" (the exposure of a photograph is unknown too)");
  }
}

// A model's `fixed` values, checked against its parameter table when the file is loaded (the
// fitter would reject them only when the job runs, after the other models' fits). `key` and
// `array` say where the list came from: fit.fixed (every model), fit.override.<model>.fixed or
// quick.fixed. A name the model lacks, written for every model, is answered with the way to
// write it for some: [fit.override.<model>] (docs/studies.md, "Fit").
void CheckFixed(const Reader& r, const std::string& model_name, const FitSettings& s,
                const std::string& key, const toml::node* array) {
  const ModelInfo& model = FindModel(model_name);
  const toml::array* a = array != nullptr ? array->as_array() : nullptr;
  for (std::size_t i = 0; i < s.fixed.size(); ++i) {
    const std::string& assignment = s.fixed[i];
    const toml::node* where = a != nullptr && i < a->size() ? a->get(i) : array;
    const std::string name = assignment.substr(0, assignment.find('='));
    if (model.Find(name) == nullptr) {
      std::vector<std::string> names;
      std::string having;
      for (const ParamSpec& p : model.params) names.push_back(p.name);
      for (const ModelInfo& m : AllModels()) {
        if (m.Find(name) != nullptr) having += (having.empty() ? "" : ", ") + m.name;
      }
      const bool for_every_model = key.rfind("fit.override.", 0) != 0;
      // A parameter of other models is no typo: no "did you mean" for it.
      std::string advice = having.empty() ? DidYouMean(name, names) : "";
      if (for_every_model) {
        advice += " (write it under [fit.override.<model>]" +
                  (having.empty() ? std::string() : "; models that have it: " + having) + ")";
      }
      r.Fail(where, key,
             fmt::format("'{}' is not a parameter of model '{}'{}", name, model.name, advice));
    }
    try {
      std::vector<double> params = DefaultParams(model);
      SetParamFromString(model, assignment, "", &params);
    } catch (const Error& e) {
      r.Fail(where, key, fmt::format("model '{}': {}", model.name, e.what()));
    }
  }
}

// [fit] models and their settings: the defaults, [fit.override.<model>], then [quick].
void ReadFitModels(const Reader& r, const toml::table& fit, const QuickFilter& q, StudySpec* spec) {
  const toml::table* qt = q.table;
  spec->models = r.Strings(fit, "fit.", "models");
  if (qt != nullptr && qt->contains("models")) spec->models = r.Strings(*qt, "quick.", "models");
  if (spec->models.empty()) r.Fail(fit.get("models"), "fit.models", "missing or empty");
  for (const std::string& m : spec->models) {
    try {
      FindModel(m);
    } catch (const Error& e) {
      r.Fail(fit.get("models"), "fit.models", e.what());
    }
  }
  FitSettings defaults;
  ReadFitSettings(r, fit, "fit.", &defaults);
  const toml::table* overrides = r.Table(fit, "fit.", "override");
  if (overrides != nullptr) {
    for (const auto& [key, node] : *overrides) {
      const std::string model(key.str());
      if (std::find(spec->models.begin(), spec->models.end(), model) == spec->models.end() &&
          qt == nullptr) {
        r.Fail(&node, "fit.override." + model, "not one of fit.models");
      }
      if (!node.is_table()) r.Fail(&node, "fit.override." + model, "expected a table");
      r.CheckKeys(*node.as_table(), "fit.override." + model + ".", kFitKeys);
    }
  }
  for (const std::string& m : spec->models) {
    FitSettings s = defaults;
    // Where this model's `fixed` list comes from: the last table that sets it.
    std::string fixed_key = "fit.fixed";
    const toml::node* fixed_node = fit.get("fixed");
    if (overrides != nullptr) {
      if (const toml::table* o = r.Table(*overrides, "fit.override.", m)) {
        ReadFitSettings(r, *o, "fit.override." + m + ".", &s);
        if (o->contains("fixed")) {
          fixed_key = "fit.override." + m + ".fixed";
          fixed_node = o->get("fixed");
        }
      }
    }
    if (qt != nullptr) {
      ReadFitSettings(r, *qt, "quick.", &s);
      if (qt->contains("fixed")) {
        fixed_key = "quick.fixed";
        fixed_node = qt->get("fixed");
      }
    }
    CheckFixed(r, m, s, fixed_key, fixed_node);
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
      if (s.loss != "l2" || s.exposure != "fixed" || s.encoding != "as-imported") {
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

}  // namespace

// [fit]
void ReadFit(const Reader& r, const toml::table& root, const QuickFilter& q, StudySpec* spec) {
  const toml::table* fit = r.Table(root, "", "fit");
  if (fit == nullptr) r.Fail(nullptr, "fit", "missing [fit] table");
  {
    std::set<std::string> allowed = kFitKeys;
    for (const char* k : {"models", "train", "test", "override"}) allowed.insert(k);
    r.CheckKeys(*fit, "fit.", allowed);
  }
  ReadFitModels(r, *fit, q, spec);
  spec->training_sets = ReadTrainingSets(r, *fit, "fit.");
  if (q.table != nullptr && q.table->contains("training_sets")) {
    spec->training_sets = ReadTrainingSets(r, *q.table, "quick.");
  }
  if (spec->training_sets.empty()) r.Fail(fit->get("train"), "fit.train", "missing or empty");
  spec->test_lightings = r.Strings(*fit, "fit.", "test");
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
    return std::find(spec->models.begin(), spec->models.end(), m) != spec->models.end();
  };
  spec->baseline = spec->models.front();
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
