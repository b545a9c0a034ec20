// Study file parsing and checking (docs/studies.md).
#include "shadefit/studies/study.h"

#include <fmt/core.h>
#include <fnmatch.h>
#include <toml++/toml.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <set>
#include <sstream>

#include "shadefit/base/error.h"
#include "shadefit/render/models.h"

namespace shadefit::studies {
namespace fs = std::filesystem;
namespace {

// Reading helpers: every key is checked; an unknown key or a wrong type is an error naming the
// file, the line and the key.
class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void Fail(const toml::node* node, const std::string& key,
                         const std::string& problem) const {
    std::string where = file_;
    if (node != nullptr && node->source().begin.line > 0) {
      where += fmt::format(":{}", node->source().begin.line);
    }
    throw Error(where, key, problem);
  }

  void CheckKeys(const toml::table& table, const std::string& prefix,
                 const std::set<std::string>& allowed) const {
    for (const auto& [key, node] : table) {
      if (!allowed.contains(std::string(key.str()))) {
        Fail(&node, prefix + std::string(key.str()),
             "unknown key" + DidYouMean(key.str(), {allowed.begin(), allowed.end()}));
      }
    }
  }

  std::string String(const toml::table& t, const std::string& prefix, const std::string& key,
                     const std::string& fallback) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    if (!n->is_string()) Fail(n, prefix + key, "expected a string");
    return *n->value<std::string>();
  }
  // A finite number in [min, max] (TOML allows nan and inf; no setting here means them).
  double Number(const toml::table& t, const std::string& prefix, const std::string& key,
                double fallback, double min = -1e300, double max = 1e300) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    if (!n->is_number()) Fail(n, prefix + key, "expected a number");
    const double v = *n->value<double>();
    if (!(v >= min && v <= max)) {
      Fail(n, prefix + key, fmt::format("value {} outside [{}, {}]", v, min, max));
    }
    return v;
  }
  // An integer in [min, max]; the default max keeps every value inside the int it is stored in.
  std::int64_t Integer(const toml::table& t, const std::string& prefix, const std::string& key,
                       std::int64_t fallback, std::int64_t min,
                       std::int64_t max = std::numeric_limits<int>::max()) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    if (!n->is_integer()) Fail(n, prefix + key, "expected an integer");
    const std::int64_t v = n->as_integer()->get();
    if (v < min) Fail(n, prefix + key, fmt::format("value {} below the minimum {}", v, min));
    if (v > max) Fail(n, prefix + key, fmt::format("value {} above the maximum {}", v, max));
    return v;
  }
  bool Bool(const toml::table& t, const std::string& prefix, const std::string& key,
            bool fallback) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    if (!n->is_boolean()) Fail(n, prefix + key, "expected true or false");
    return *n->value<bool>();
  }
  std::vector<std::string> Strings(const toml::table& t, const std::string& prefix,
                                   const std::string& key) const {
    std::vector<std::string> out;
    const toml::node* n = t.get(key);
    if (n == nullptr) return out;
    const toml::array* a = n->as_array();
    if (a == nullptr) Fail(n, prefix + key, "expected an array of strings");
    for (const toml::node& e : *a) {
      if (!e.is_string()) Fail(&e, prefix + key, "expected an array of strings");
      out.push_back(*e.value<std::string>());
    }
    return out;
  }
  const toml::table* Table(const toml::table& t, const std::string& prefix,
                           const std::string& key) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return nullptr;
    if (!n->is_table()) Fail(n, prefix + key, "expected a table");
    return n->as_table();
  }

  const std::string& file() const { return file_; }

 private:
  std::string file_;
};

const std::set<std::string> kFitKeys = {"loss",           "loss_scale",   "starts",
                                        "seed",           "exposure",     "path",
                                        "max_iterations", "pixel_stride", "environment_samples",
                                        "fixed",          "encoding",     "start"};

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

// Expands one pattern relative to `base`: wildcards are allowed in the last path component only.
std::vector<fs::path> Glob(const fs::path& base, const std::string& pattern) {
  const fs::path full = (base / pattern).lexically_normal();
  const fs::path dir = full.parent_path();
  const std::string leaf = full.filename().string();
  std::vector<fs::path> out;
  if (leaf.find_first_of("*?[") == std::string::npos) {
    if (fs::exists(full)) out.push_back(full);
    return out;
  }
  if (!fs::is_directory(dir)) return out;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.is_regular_file() && fnmatch(leaf.c_str(), entry.path().filename().c_str(), 0) == 0) {
      out.push_back(entry.path());
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::string LightingOf(const std::string& stem, const std::string& material,
                       const fs::path& sidecar) {
  if (stem.size() > material.size() + 1 && stem.rfind(material + "-", 0) == 0) {
    return stem.substr(material.size() + 1);
  }
  if (fs::exists(sidecar)) {
    std::ifstream in(sidecar);
    try {
      const nlohmann::json j = nlohmann::json::parse(in);
      if (j.contains("scene_file") && j["scene_file"].is_string()) {
        std::string s = fs::path(j["scene_file"].get<std::string>()).stem().string();
        const auto dash = s.find('-');
        return dash == std::string::npos ? s : s.substr(dash + 1);
      }
    } catch (const nlohmann::json::exception&) {
    }
  }
  return stem;
}

}  // namespace

nlohmann::json FitSettings::ToJson() const {
  nlohmann::json j = {{"loss", loss},
                      {"loss_scale", loss_scale},
                      {"starts", starts},
                      {"seed", seed},
                      {"exposure", exposure},
                      {"path", path},
                      {"max_iterations", max_iterations},
                      {"pixel_stride", pixel_stride},
                      {"environment_samples", environment_samples},
                      {"fixed", fixed}};
  // Only when not the default, so that the settings (and job hashes) of studies that predate
  // the key are unchanged.
  if (encoding != "as-imported") j["encoding"] = encoding;
  if (start != "default") j["start"] = start;
  return j;
}

std::string StudySpec::Label(const std::string& model,
                             const std::vector<std::string>& train) const {
  if (training_sets.size() <= 1) return model;
  std::string out = model + "@";
  for (std::size_t i = 0; i < train.size(); ++i) out += (i ? "+" : "") + train[i];
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
    groups_json.push_back({{"material", g.material}, {"references", refs}});
  }
  nlohmann::json settings = nlohmann::json::object();
  for (const auto& [model, s] : model_settings) settings[model] = s.ToJson();
  nlohmann::json labels = nlohmann::json::array();
  for (const auto& train : training_sets) {
    for (const std::string& m : models) {
      labels.push_back({{"label", Label(m, train)}, {"model", m}, {"train", train}});
    }
  }
  return {{"schema", "shadefit.study/1"},
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
             }
             return m;
           }()},
          {"models", models},
          {"fits", labels},
          {"fit_settings", settings},
          {"training_sets", training_sets},
          {"test_lightings", test_lightings},
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

// The [quick] filter of materials and lightings (empty: no filter), and its table when applied.
struct QuickFilter {
  const toml::table* table = nullptr;  // Set only when --quick applies it.
  std::vector<std::string> materials, lightings;

  bool KeepsMaterial(const std::string& m) const { return Keeps(materials, m); }
  bool KeepsLighting(const std::string& l) const { return Keeps(lightings, l); }

 private:
  static bool Keeps(const std::vector<std::string>& list, const std::string& x) {
    return list.empty() || std::find(list.begin(), list.end(), x) != list.end();
  }
};

bool Excluded(const std::vector<std::string>& exclude, const std::string& leaf) {
  return std::any_of(exclude.begin(), exclude.end(), [&](const std::string& x) {
    return fnmatch(x.c_str(), leaf.c_str(), 0) == 0;
  });
}

// The study file's bytes and its TOML.
toml::table ParseStudyFile(const std::string& path, const Reader& r, StudySpec* spec) {
  const fs::path file = fs::absolute(path).lexically_normal();
  if (!fs::exists(file)) throw Error(path, "", "study file not found");
  if (!fs::is_regular_file(file)) throw Error(path, "", "study file is not a regular file");
  {
    std::ifstream in(file, std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    spec->text = ss.str();
  }
  spec->path = file.string();
  toml::table root;
  try {
    root = toml::parse(spec->text, spec->path);
  } catch (const toml::parse_error& e) {
    throw Error(fmt::format("{}:{}", path, e.source().begin.line), "",
                "malformed TOML: " + std::string(e.description()));
  }
  r.CheckKeys(
      root, "",
      {"study", "group", "measured", "fit", "metrics", "probes", "verdicts", "outputs", "quick"});
  return root;
}

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

// [quick], read first: it filters what follows. Its keys are checked with or without --quick.
QuickFilter ReadQuick(const Reader& r, const toml::table& root, bool quick) {
  QuickFilter q;
  if (const toml::table* qt = r.Table(root, "", "quick")) {
    std::set<std::string> allowed = kFitKeys;
    for (const char* k : {"materials", "lightings", "models", "probes", "training_sets"})
      allowed.insert(k);
    r.CheckKeys(*qt, "quick.", allowed);
  }
  q.table = quick ? r.Table(root, "", "quick") : nullptr;
  if (q.table != nullptr) {
    q.materials = r.Strings(*q.table, "quick.", "materials");
    q.lightings = r.Strings(*q.table, "quick.", "lightings");
  }
  return q;
}

// [[measured]] scenes: one per lighting ("sphere-key.toml" -> "key").
void ReadMeasuredScenes(const Reader& r, const toml::table& t, const fs::path& base,
                        const std::vector<std::string>& exclude, const QuickFilter& q,
                        MeasuredSource* src) {
  const std::vector<std::string> scenes = r.Strings(t, "measured.", "scenes");
  if (scenes.empty()) r.Fail(&t, "measured.scenes", "missing or empty");
  for (const std::string& pattern : scenes) {
    const std::vector<fs::path> matches = Glob(base, pattern);
    if (matches.empty()) {
      r.Fail(t.get("scenes"), "measured.scenes", "'" + pattern + "' matches no file");
    }
    for (const fs::path& m : matches) {
      if (Excluded(exclude, m.filename().string())) continue;
      // "sphere-key.toml" -> "key": the lighting names of the shipped Cycles scenes.
      std::string lighting = m.stem().string();
      if (const auto dash = lighting.find('-'); dash != std::string::npos) {
        lighting = lighting.substr(dash + 1);
      }
      if (!q.KeepsLighting(lighting)) continue;
      if (std::find(src->lightings.begin(), src->lightings.end(), lighting) !=
          src->lightings.end()) {
        r.Fail(t.get("scenes"), "measured.scenes", "two scenes under lighting '" + lighting + "'");
      }
      src->scenes.push_back(m.string());
      src->lightings.push_back(lighting);
    }
  }
}

// [[measured]] BRDF files of a present folder, sorted: MERL .binary, or a Neural-BRDF network
// (its weights, .h5, with the Keras config, .json, beside it).
void ReadMeasuredBrdfs(const Reader& r, const toml::table& t,
                       const std::vector<std::string>& exclude, const QuickFilter& q,
                       MeasuredSource* src) {
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(src->folder)) {
    const fs::path& f = entry.path();
    const std::string ext = f.extension().string();
    if (Excluded(exclude, f.filename().string())) continue;
    if (ext == ".binary") files.push_back(f);
    if (ext == ".h5" && fs::exists(fs::path(f).replace_extension(".json"))) files.push_back(f);
  }
  std::sort(files.begin(), files.end());
  for (const fs::path& f : files) {
    const std::string material = f.stem().string();
    if (!q.KeepsMaterial(material)) continue;
    if (std::find(src->materials.begin(), src->materials.end(), material) != src->materials.end()) {
      r.Fail(&t, "measured.folder", "material '" + material + "' is there twice (.binary and .h5)");
    }
    src->brdfs.push_back(f.string());
    src->materials.push_back(material);
  }
  if (src->brdfs.empty()) {
    r.Fail(t.get("folder"), "measured.folder",
           src->folder + ": no MERL .binary or Neural-BRDF .h5 (+ .json) file in it");
  }
}

// [[measured]]
void ReadMeasured(const Reader& r, const toml::table& root, const fs::path& base,
                  const QuickFilter& q, StudySpec* spec) {
  const toml::node* mn = root.get("measured");
  if (mn == nullptr) return;
  if (!mn->is_array_of_tables()) r.Fail(mn, "measured", "expected [[measured]] tables");
  for (const toml::node& e : *mn->as_array()) {
    const toml::table& t = *e.as_table();
    r.CheckKeys(t, "measured.", {"folder", "scenes", "exclude", "samples"});
    MeasuredSource src;
    const std::string folder = r.String(t, "measured.", "folder", "");
    if (folder.empty()) r.Fail(&e, "measured.folder", "missing");
    src.folder = (base / folder).lexically_normal().string();
    src.samples = static_cast<int>(r.Integer(t, "measured.", "samples", 0, 0, 65536));
    const std::vector<std::string> exclude = r.Strings(t, "measured.", "exclude");
    ReadMeasuredScenes(r, t, base, exclude, q, &src);
    src.present = fs::is_directory(src.folder);
    if (src.present) ReadMeasuredBrdfs(r, t, exclude, q, &src);
    spec->measured.push_back(std::move(src));
  }
}

// One [[group]]'s references, sorted by lighting; false when --quick leaves its material out.
bool ReadGroup(const Reader& r, const toml::node& gn, const fs::path& base, const QuickFilter& q,
               ReferenceGroup* group) {
  const toml::table& g = *gn.as_table();
  r.CheckKeys(g, "group.", {"material", "images", "exclude", "lightings"});
  group->material = r.String(g, "group.", "material", "");
  if (group->material.empty()) r.Fail(&gn, "group.material", "missing");
  if (!q.KeepsMaterial(group->material)) return false;
  const std::vector<std::string> images = r.Strings(g, "group.", "images");
  if (images.empty()) r.Fail(&gn, "group.images", "missing or empty");
  const std::vector<std::string> exclude = r.Strings(g, "group.", "exclude");
  const std::vector<std::string> lightings = r.Strings(g, "group.", "lightings");
  std::set<std::string> seen;
  for (const std::string& pattern : images) {
    const std::vector<fs::path> matches = Glob(base, pattern);
    if (matches.empty()) {
      r.Fail(g.get("images"), "group.images", "'" + pattern + "' matches no file");
    }
    for (const fs::path& m : matches) {
      if (Excluded(exclude, m.filename().string())) continue;
      if (!seen.insert(m.string()).second) continue;
      ReferenceSpec ref;
      ref.name = m.stem().string();
      ref.material = group->material;
      ref.image_path = m.string();
      fs::path sidecar = m;
      sidecar.replace_extension(".json");
      ref.sidecar_path = fs::exists(sidecar) ? sidecar.string() : "";
      ref.lighting = LightingOf(ref.name, group->material, sidecar);
      if (!lightings.empty() &&
          std::find(lightings.begin(), lightings.end(), ref.lighting) == lightings.end()) {
        continue;
      }
      if (!q.KeepsLighting(ref.lighting)) continue;
      group->references.push_back(ref);
    }
  }
  std::sort(group->references.begin(), group->references.end(),
            [](const ReferenceSpec& a, const ReferenceSpec& b) { return a.lighting < b.lighting; });
  for (std::size_t i = 1; i < group->references.size(); ++i) {
    if (group->references[i].lighting == group->references[i - 1].lighting) {
      r.Fail(&gn, "group.images",
             fmt::format("material '{}' has two references under lighting '{}'", group->material,
                         group->references[i].lighting));
    }
  }
  if (group->references.empty()) {
    r.Fail(&gn, "group.images", "material '" + group->material + "': no reference left");
  }
  return true;
}

// [[group]]
void ReadGroups(const Reader& r, const toml::table& root, const fs::path& base,
                const QuickFilter& q, StudySpec* spec) {
  const toml::node* groups_node = root.get("group");
  if (groups_node != nullptr && !groups_node->is_array_of_tables()) {
    r.Fail(groups_node, "group", "expected [[group]] tables");
  }
  if (groups_node == nullptr && spec->measured.empty()) {
    r.Fail(nullptr, "group", "expected one or more [[group]] or [[measured]] tables");
  }
  const toml::array empty_groups;
  for (const toml::node& gn : groups_node ? *groups_node->as_array() : empty_groups) {
    ReferenceGroup group;
    if (!ReadGroup(r, gn, base, q, &group)) continue;
    for (const ReferenceGroup& other : spec->groups) {
      if (other.material == group.material) {
        r.Fail(&gn, "group.material", "material '" + group.material + "' listed twice");
      }
    }
    spec->groups.push_back(std::move(group));
  }
  bool any_measured = false;
  for (const MeasuredSource& m : spec->measured) any_measured = any_measured || !m.brdfs.empty();
  if (spec->groups.empty() && !any_measured && MeasuredSkipReason(*spec).empty()) {
    r.Fail(nullptr, "quick.materials", "no group left");
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

// [verdicts.<phenomenon>]
void ReadVerdicts(const Reader& r, const toml::table& root, StudySpec* spec) {
  spec->verdicts = nlohmann::json::object();
  if (const toml::table* v = r.Table(root, "", "verdicts")) {
    for (const auto& [key, node] : *v) {
      const std::string name(key.str());
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

}  // namespace

StudySpec LoadStudy(const std::string& path, bool quick) {
  StudySpec spec;
  spec.quick = quick;
  const Reader r(path);
  const toml::table root = ParseStudyFile(path, r, &spec);
  ReadStudyTable(r, root, &spec);
  const QuickFilter q = ReadQuick(r, root, quick);
  const fs::path base = fs::path(spec.path).parent_path();
  ReadMeasured(r, root, base, q, &spec);
  ReadGroups(r, root, base, q, &spec);
  ReadFit(r, root, q, &spec);
  ReadComparisons(r, root, *r.Table(root, "", "fit"), &spec);
  ReadMetrics(r, root, &spec);
  ReadProbes(r, root, q, &spec);
  ReadVerdicts(r, root, &spec);
  ReadOutputs(r, root, &spec);
  return spec;
}

std::string MeasuredBrdfPath(const StudySpec& spec, const std::string& material) {
  for (const MeasuredSource& src : spec.measured) {
    for (std::size_t m = 0; m < src.materials.size(); ++m) {
      if (src.materials[m] == material) return src.brdfs[m];
    }
  }
  return "";
}

std::string MeasuredSkipReason(const StudySpec& spec) {
  for (const MeasuredSource& m : spec.measured) {
    if (!m.present) {
      return m.folder +
             ": not found, so the measured materials are skipped (get MERL .binary files from "
             "MERL's BRDF database, or the Neural-BRDF networks of Sztrajman et al. 2021, and set "
             "[[measured]] folder; README, \"Measured materials\")";
    }
  }
  return "";
}

}  // namespace shadefit::studies
