// A study's materials: [[measured]] BRDF files with their scenes, and [[group]]s of reference
// images (docs/studies.md).
#include <fnmatch.h>

#include <fstream>

#include "shadefit/base/files.h"
#include "study_file.h"

namespace shadefit::studies {
namespace internal {
namespace {

// A reference's lighting: its stem after "<material>-", else its sidecar's scene stem after the
// first '-', else its stem.
std::string LightingOf(const std::string& stem, const std::string& material,
                       const fs::path& sidecar) {
  if (stem.size() > material.size() + 1 && stem.rfind(material + "-", 0) == 0) {
    return stem.substr(material.size() + 1);
  }
  if (PathExists(sidecar)) {
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

// [[measured]] scenes: one per lighting ("sphere-key.toml" -> "key").
void ReadMeasuredScenes(const Reader& r, const toml::table& t, const fs::path& base,
                        const std::vector<std::string>& exclude, const QuickFilter& q,
                        MeasuredSource* src) {
  const std::vector<std::string> scenes = r.Strings(t, "measured.", "scenes");
  if (scenes.empty()) r.Fail(&t, "measured.scenes", "missing or empty");
  for (const std::string& pattern : scenes) {
    const std::vector<fs::path> matches = Glob(r, t.get("scenes"), "measured.scenes", base, pattern);
    if (matches.empty()) {
      r.Fail(t.get("scenes"), "measured.scenes", "'" + pattern + "' matches no file");
    }
    for (const fs::path& m : matches) {
      if (Excluded(exclude, m.filename().string())) continue;
      // "sphere-key.toml" -> "key": the lighting names of the shipped Cycles scenes; with an
      // object, the stem after "<object>-" ("torus-knot-key.toml" of "torus-knot" -> "key").
      std::string lighting = m.stem().string();
      if (!src->object.empty() && lighting.rfind(src->object + "-", 0) == 0) {
        lighting = lighting.substr(src->object.size() + 1);
      } else if (const auto dash = lighting.find('-'); dash != std::string::npos) {
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
  std::error_code ec;
  for (fs::directory_iterator it(src->folder, ec), end; !ec && it != end; it.increment(ec)) {
    const fs::path& f = it->path();
    const std::string ext = f.extension().string();
    if (Excluded(exclude, f.filename().string())) continue;
    if (ext == ".binary") files.push_back(f);
    std::error_code json_ec;
    if (ext == ".h5" && fs::exists(fs::path(f).replace_extension(".json"), json_ec)) {
      files.push_back(f);
    }
  }
  if (ec) {
    r.Fail(t.get("folder"), "measured.folder",
           fmt::format("{}: cannot be listed: {}", src->folder, ec.message()));
  }
  std::sort(files.begin(), files.end());
  for (const fs::path& f : files) {
    const std::string material =
        src->object.empty() ? f.stem().string() : src->object + "-" + f.stem().string();
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

}  // namespace

// [[measured]]
void ReadMeasured(const Reader& r, const toml::table& root, const fs::path& base,
                  const QuickFilter& q, StudySpec* spec) {
  const toml::node* mn = root.get("measured");
  if (mn == nullptr) return;
  if (!mn->is_array_of_tables()) r.Fail(mn, "measured", "expected [[measured]] tables");
  for (const toml::node& e : *mn->as_array()) {
    const toml::table& t = *e.as_table();
    r.CheckKeys(t, "measured.", {"folder", "scenes", "exclude", "samples", "object"});
    MeasuredSource src;
    src.object = r.String(t, "measured.", "object", "");  // Before the scenes: names lightings.
    const std::string folder = r.String(t, "measured.", "folder", "");
    if (folder.empty()) r.Fail(&e, "measured.folder", "missing");
    src.folder = (base / folder).lexically_normal().string();
    src.samples = static_cast<int>(r.Integer(t, "measured.", "samples", 0, 0, 65536));
    const std::vector<std::string> exclude = r.Strings(t, "measured.", "exclude");
    ReadMeasuredScenes(r, t, base, exclude, q, &src);
    try {
      src.present = KindOfPath(src.folder) == PathKind::kDirectory;
    } catch (const Error& e) {
      r.Fail(t.get("folder"), "measured.folder", e.what());
    }
    if (src.present) ReadMeasuredBrdfs(r, t, exclude, q, &src);
    // Materials name results' rows: the same BRDF under two tables needs an object apart.
    for (const MeasuredSource& other : spec->measured) {
      for (const std::string& m : src.materials) {
        if (std::find(other.materials.begin(), other.materials.end(), m) !=
            other.materials.end()) {
          r.Fail(&e, "measured.object",
                 "material '" + m + "' comes from two [[measured]] tables: give each its object "
                 "(object = \"torus\" names its materials \"torus-<brdf>\")");
        }
      }
    }
    spec->measured.push_back(std::move(src));
  }
}

namespace {

// One [[group]]'s references, sorted by lighting; false when --quick leaves its material out.
bool ReadGroup(const Reader& r, const toml::node& gn, const fs::path& base, const QuickFilter& q,
               ReferenceGroup* group) {
  const toml::table& g = *gn.as_table();
  r.CheckKeys(g, "group.", {"material", "object", "images", "exclude", "lightings"});
  group->material = r.String(g, "group.", "material", "");
  group->object = r.String(g, "group.", "object", "");
  if (group->material.empty()) r.Fail(&gn, "group.material", "missing");
  if (!q.KeepsMaterial(group->material)) return false;
  const std::vector<std::string> images = r.Strings(g, "group.", "images");
  if (images.empty()) r.Fail(&gn, "group.images", "missing or empty");
  const std::vector<std::string> exclude = r.Strings(g, "group.", "exclude");
  const std::vector<std::string> lightings = r.Strings(g, "group.", "lightings");
  std::set<std::string> seen;
  for (const std::string& pattern : images) {
    const std::vector<fs::path> matches = Glob(r, g.get("images"), "group.images", base, pattern);
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
      ref.sidecar_path = PathExists(sidecar) ? sidecar.string() : "";
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

}  // namespace

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

}  // namespace internal

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
