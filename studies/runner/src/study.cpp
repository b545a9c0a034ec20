// Study files (docs/studies.md): LoadStudy reads the tables in order, the small ones ([study],
// [metrics], [probes], [verdicts], [outputs]) here; the study's JSON. The file, [[measured]] and
// [[group]], and [fit] are read in study_file.cpp, study_materials.cpp and study_fit.cpp.
#include "shadefit/studies/study.h"

#include <optional>

#include "job_graph.h"
#include "metric_columns.h"
#include "study_file.h"

namespace shadefit::studies {
namespace fs = std::filesystem;
using internal::QuickFilter;
using internal::Reader;

nlohmann::json FitSettings::ToJson() const {
  nlohmann::json j = {{"loss", fit::LossName(loss)},
                      {"loss_scale", loss_scale},
                      {"starts", starts},
                      {"seed", seed},
                      {"exposure", fit::ExposureName(exposure)},
                      {"path", fit::PathName(path)},
                      {"max_iterations", max_iterations},
                      {"pixel_stride", pixel_stride},
                      {"environment_samples", environment_samples},
                      {"fixed", FixedTexts(fixed)}};
  // Only when not the default, so that the settings (and job hashes) of studies that predate
  // the key are unchanged.
  if (encoding != fit::EncodingMode::kAsImported) j["encoding"] = fit::EncodingModeName(encoding);
  if (start != StartFrom::kDefault) j["start"] = "brdf";
  return j;
}

fit::FitOptions FitSettings::Options() const {
  fit::FitOptions o;
  o.loss = loss;
  o.loss_scale = loss_scale;
  o.starts = starts;
  o.seed = seed;
  o.exposure = exposure;
  o.path = path;
  o.max_iterations = max_iterations;
  o.environment_samples = environment_samples;
  return o;
}

std::string StudySpec::Label(const std::string& model,
                             const std::vector<std::string>& train) const {
  if (training_sets.size() <= 1) return model;
  if (RoleOf(train) == FitRole::kFloor) return model + "@floor";
  std::string out = model + "@";
  for (std::size_t i = 0; i < train.size(); ++i) out += (i ? "+" : "") + train[i];
  return out;
}

std::string StudySpec::Label(const std::string& model, const std::vector<std::string>& train,
                             fit::Loss loss) const {
  std::string out = Label(model, train);
  if (losses.size() > 1 && RoleOf(train) != FitRole::kBrdf)
    out += fmt::format(":{}", fit::LossName(loss));
  return out;
}

FitRole StudySpec::RoleOf(const std::vector<std::string>& train) const {
  if (TrainsInBrdfSpace(train)) return FitRole::kBrdf;
  if (!floor_lightings.empty() && train == floor_lightings) return FitRole::kFloor;
  return FitRole::kTrain;
}

const char* FitRoleName(FitRole role) {
  switch (role) {
    case FitRole::kTrain:
      return "train";
    case FitRole::kFloor:
      return "floor";
    case FitRole::kBrdf:
      return "brdf";
  }
  return "train";
}

FitSettings StudySpec::SettingsOf(ModelRef model, fit::Loss loss) const {
  FitSettings s = SettingsOf(model);
  s.loss = loss;
  return s;
}

std::vector<FitSpec> StudySpec::Fits() const {
  std::vector<FitSpec> out;
  for (const auto& train : training_sets) {
    const FitRole role = RoleOf(train);
    for (ModelRef m : models) {
      // The BRDF-space fit has one objective, Ngan's l2 (fit/brdf_space.h), whatever the image
      // losses.
      std::vector<fit::Loss> of_model = losses;
      if (of_model.empty()) of_model = {SettingsOf(m).loss};
      if (role == FitRole::kBrdf) of_model = {fit::Loss::kL2};
      for (fit::Loss loss : of_model) {
        out.push_back({m, train, loss, role, Label(m->name, train, loss)});
      }
    }
  }
  return out;
}

bool StudySpec::IsTest(const std::string& lighting, const std::vector<std::string>& train) const {
  if (std::find(train.begin(), train.end(), lighting) != train.end()) return false;
  return test_lightings.empty() ||
         std::find(test_lightings.begin(), test_lightings.end(), lighting) != test_lightings.end();
}

namespace {
nlohmann::json ProbeNamesJson(const std::vector<probes::ProbeKind>& kinds) {
  nlohmann::json names = nlohmann::json::array();
  for (probes::ProbeKind kind : kinds) names.push_back(probes::ProbeName(kind));
  return names;
}
}  // namespace

nlohmann::json StudySpec::ToJson() const {
  nlohmann::json groups_json = nlohmann::json::array();
  for (const ReferenceGroup& g : groups) {
    nlohmann::json refs = nlohmann::json::array();
    for (const ReferenceSpec& r : g.references) {
      refs.push_back({{"name", r.name},
                      {"lighting", r.lighting},
                      {"image", r.image_path},
                      {"sidecar", r.sidecar_path}});
    }
    nlohmann::json group = {{"material", g.material}, {"references", refs}};
    if (!g.object.empty()) group["object"] = g.object;  // Sphere studies' study.json unchanged.
    groups_json.push_back(group);
  }
  nlohmann::json settings = nlohmann::json::object();
  for (const auto& [model, s] : model_settings) settings[model] = s.ToJson();
  nlohmann::json labels = nlohmann::json::array();
  nlohmann::json model_names = nlohmann::json::array();
  for (ModelRef m : models) model_names.push_back(m->name);
  for (const FitSpec& f : Fits()) {
    labels.push_back({{"label", f.label},
                      {"model", f.model->name},
                      {"train", f.train},
                      {"loss", fit::LossName(f.loss)},
                      {"role", FitRoleName(f.role)}});
  }
  nlohmann::json loss_names = nlohmann::json::array();
  for (fit::Loss l : losses) loss_names.push_back(fit::LossName(l));
  return {{"schema", "shadefit.study/2"},
          {"name", name},
          {"description", description},
          {"path", path},
          {"quick", quick},
          {"groups", groups_json},
          {"measured",
           [&] {
             nlohmann::json m = nlohmann::json::array();
             for (const MeasuredSource& src : measured) {
               m.push_back({{"folder", src.folder},
                            {"present", src.present},
                            {"materials", src.materials},
                            {"lightings", src.lightings},
                            {"scenes", src.scenes},
                            {"samples", src.samples}});
               if (!src.object.empty()) m.back()["object"] = src.object;  // Else unchanged.
             }
             return m;
           }()},
          {"models", model_names},
          {"fits", labels},
          {"fit_settings", settings},
          {"training_sets", training_sets},
          {"test_lightings", test_lightings},
          {"losses", loss_names},
          {"floor", floor_lightings},
          {"judging", judging.has_value() ? nlohmann::json(*judging) : nlohmann::json()},
          {"metrics", {{"exposure_stops", metrics_exposure_stops}, {"ppd", metrics_ppd}}},
          {"probes", ProbeNamesJson(probes)},
          {"verdicts", verdicts},
          {"baseline", baseline},
          {"compare", comparisons},
          {"outputs",
           {{"previews", previews},
            {"report", report},
            {"floor", floor.has_value() ? nlohmann::json(*floor) : nlohmann::json()}}}};
}

namespace {

// [study]
void ReadStudyTable(const Reader& r, const toml::table& root, StudySpec* spec) {
  const toml::table* study = r.Table(root, "", "study");
  if (study == nullptr) r.Fail(nullptr, "study", "missing [study] table");
  r.CheckKeys(*study, "study.", {"name", "description", "baseline", "compare"});
  spec->name = r.String(*study, "study.", "name", fs::path(spec->path).stem().string());
  spec->description = r.String(*study, "study.", "description", "");
  if (spec->name.empty() || spec->name.find_first_of("/\\ ") != std::string::npos) {
    r.Fail(study->get("name"), "study.name", "must be a non-empty name without '/' or spaces");
  }
}
// [metrics]
void ReadMetrics(const Reader& r, const toml::table& root, StudySpec* spec) {
  if (const toml::table* m = r.Table(root, "", "metrics")) {
    r.CheckKeys(*m, "metrics.", {"exposure_stops", "ppd"});
    spec->metrics_exposure_stops =
        static_cast<float>(r.Number(*m, "metrics.", "exposure_stops", 0.0, -64.0, 64.0));
    spec->metrics_ppd = r.Number(*m, "metrics.", "ppd", 67.0, 1e-3, 1e6);
  }
}

// [probes]: names parsed into kinds here, once.
void ReadProbes(const Reader& r, const toml::table& root, const QuickFilter& q, StudySpec* spec) {
  const toml::table* qt = q.table;
  std::vector<std::string> names;
  if (const toml::table* p = r.Table(root, "", "probes")) {
    r.CheckKeys(*p, "probes.", {"run", "plots"});
    names = r.Strings(*p, "probes.", "run");
    spec->probe_plots = r.Bool(*p, "probes.", "plots", false);
  }
  const bool from_quick = qt != nullptr && qt->contains("probes");
  if (from_quick) names = r.Strings(*qt, "quick.", "probes");
  for (const std::string& p : names) {
    const std::optional<probes::ProbeKind> kind = probes::ParseProbeKind(p);
    if (!kind) {
      const toml::table* probes_table = r.Table(root, "", "probes");
      const toml::node* where = from_quick     ? qt->get("probes")
                                : probes_table ? probes_table->get("run")
                                               : nullptr;
      r.Fail(where, from_quick ? "quick.probes" : "probes.run",
             "unknown probe '" + p + "'" + DidYouMean(p, probes::ProbeNames()) +
                 " (fresnel, highlight, energy, portability, brdf)");
    }
    spec->probes.push_back(*kind);
  }
}

// One [verdicts.<name>] table: checked here, applied by the report.
nlohmann::json ReadVerdict(const Reader& r, const std::string& name, const toml::node& node) {
  const std::string prefix = "verdicts." + name + ".";
  if (!node.is_table()) r.Fail(&node, "verdicts." + name, "expected a table");
  const toml::table& t = *node.as_table();
  r.CheckKeys(t, prefix,
              {"question", "source", "kind", "tolerance", "floor", "keys", "metric", "split"});
  nlohmann::json j;
  j["question"] = r.String(t, prefix, "question", name);
  j["source"] = r.String(t, prefix, "source", "");
  j["kind"] = r.String(t, prefix, "kind", "relative");
  if (!t.contains("tolerance")) r.Fail(&node, prefix + "tolerance", "missing");
  j["tolerance"] = r.Number(t, prefix, "tolerance", 0.0, 0.0);
  j["floor"] = r.Number(t, prefix, "floor", 0.0, 0.0);
  j["keys"] = r.Strings(t, prefix, "keys");
  j["metric"] = r.String(t, prefix, "metric", "");
  j["split"] = r.String(t, prefix, "split", "test");
  const std::string source = j["source"];
  if (source != "metrics" && !probes::ParseProbeKind(source)) {
    r.Fail(t.get("source"), prefix + "source",
           "expected \"metrics\" or a probe name (fresnel, highlight, energy, portability, brdf)");
  }
  if (j["kind"] != "relative" && j["kind"] != "max" && j["kind"] != "absolute") {
    r.Fail(t.get("kind"), prefix + "kind", "expected \"relative\", \"absolute\" or \"max\"");
  }
  if (source == "metrics" && j["metric"] == "") {
    r.Fail(&node, prefix + "metric", "required when source = \"metrics\"");
  }
  if (j["split"] != "train" && j["split"] != "test") {
    r.Fail(t.get("split"), prefix + "split", "expected \"train\" or \"test\"");
  }
  return j;
}

// [verdicts] judging = ["relative_rmse", ...]: the image metrics every image question is answered
// under, instead of the report's default judging set (docs/studies.md, "Comparative answers").
std::vector<std::string> ReadJudging(const Reader& r, const toml::node& node) {
  const toml::array* a = node.as_array();
  if (a == nullptr || a->empty()) r.Fail(&node, "verdicts.judging", "expected metric names");
  std::vector<std::string> out;
  for (const toml::node& e : *a) {
    if (!e.is_string()) r.Fail(&e, "verdicts.judging", "expected metric names");
    const std::string m = *e.value<std::string>();
    if (std::find(internal::kMetricColumns.begin(), internal::kMetricColumns.end(), m) ==
        internal::kMetricColumns.end()) {
      r.Fail(&e, "verdicts.judging",
             "unknown metric '" + m + "'" + DidYouMean(m, internal::kMetricColumns));
    }
    if (std::find(out.begin(), out.end(), m) != out.end()) {
      r.Fail(&e, "verdicts.judging", "'" + m + "' listed twice");
    }
    out.push_back(m);
  }
  return out;
}

// [verdicts.<phenomenon>]
void ReadVerdicts(const Reader& r, const toml::table& root, StudySpec* spec) {
  spec->verdicts = nlohmann::json::object();
  if (const toml::table* v = r.Table(root, "", "verdicts")) {
    for (const auto& [key, node] : *v) {
      const std::string name(key.str());
      if (name == "judging") {
        spec->judging = ReadJudging(r, node);
        continue;
      }
      spec->verdicts[name] = ReadVerdict(r, name, node);
    }
  }
}

// [outputs]
void ReadOutputs(const Reader& r, const toml::table& root, StudySpec* spec) {
  if (const toml::table* o = r.Table(root, "", "outputs")) {
    r.CheckKeys(*o, "outputs.", {"previews", "report", "floor"});
    spec->previews = r.Bool(*o, "outputs.", "previews", true);
    spec->report = r.Bool(*o, "outputs.", "report", true);
    if (o->contains("floor")) spec->floor = r.Bool(*o, "outputs.", "floor", false);
  }
}

}  // namespace

StudySpec LoadStudy(const std::string& path, bool quick) {
  StudySpec spec;
  spec.quick = quick;
  const Reader r(path);
  const toml::table root = internal::ParseStudyFile(path, r, &spec);
  ReadStudyTable(r, root, &spec);
  const QuickFilter q = internal::ReadQuick(r, root, quick);
  const fs::path base = fs::path(spec.path).parent_path();
  internal::ReadMeasured(r, root, base, q, &spec);
  internal::ReadGroups(r, root, base, q, &spec);
  internal::ReadFit(r, root, q, &spec);
  internal::ReadComparisons(r, root, *r.Table(root, "", "fit"), &spec);
  ReadMetrics(r, root, &spec);
  ReadProbes(r, root, q, &spec);
  ReadVerdicts(r, root, &spec);
  ReadOutputs(r, root, &spec);
  internal::CheckJobIds(spec);
  return spec;
}

}  // namespace shadefit::studies
