#include "shadefit/reference_images/sidecar.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "shadefit/render/models.h"
#include "sidecar_fields.h"

namespace shadefit::reference_images {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// The sidecar's JSON, or nullopt when it cannot be opened or parsed.
std::optional<json> ReadSidecar(const std::string& path) {
  std::ifstream in(path);
  if (!in) return std::nullopt;
  try {
    return json::parse(in);
  } catch (const json::exception&) {
    return std::nullopt;
  }
}

std::optional<SidecarTruth> NoTruth(std::string* why_not, std::string why) {
  if (why_not != nullptr) *why_not = std::move(why);
  return std::nullopt;
}

}  // namespace

std::string SidecarPathFor(const std::string& image_path) {
  return fs::path(image_path).replace_extension(".json").string();
}

std::string SceneOfSidecar(const std::string& sidecar_path) {
  if (sidecar_path.empty()) return "";
  const std::optional<json> j = ReadSidecar(sidecar_path);
  if (!j) return "";
  const std::string scene = internal::SceneFieldOf(*j);
  if (scene.empty()) return "";
  return (fs::path(sidecar_path).parent_path() / scene).lexically_normal().string();
}

std::optional<SidecarTruth> TruthOfSidecar(const std::string& sidecar_path,
                                           std::string* why_not) {
  if (sidecar_path.empty()) return NoTruth(why_not, "no sidecar");
  const std::optional<json> j = ReadSidecar(sidecar_path);
  if (!j) return NoTruth(why_not, "cannot read the sidecar as JSON");
  if (!j->contains("material") || !(*j)["material"].is_object()) {
    return NoTruth(why_not, "no material");
  }
  const json& m = (*j)["material"];
  try {
    const std::string type = m.value("type", "");
    const auto truth = [&](const char* model) {
      SidecarTruth t;
      t.model = FindModel(model);
      t.params = DefaultParams(*t.model);
      return t;
    };
    const auto set = [&](SidecarTruth* t, const char* name, std::vector<double> values) {
      SetParam(*t->model, name, values, sidecar_path, &t->params);
    };
    if (type == "principled") {
      const std::string distribution = m.value("distribution", "GGX");
      if (distribution != "GGX") {
        return NoTruth(why_not, fmt::format("principled with the {} distribution has no "
                                            "single-scattering twin (GGX has)",
                                            distribution));
      }
      SidecarTruth t = truth("cycles-principled");
      set(&t, "base_color", m.at("base_color").get<std::vector<double>>());
      set(&t, "metallic", {m.value("metallic", 0.0)});
      set(&t, "specular", {m.value("specular", 0.5)});
      set(&t, "roughness", {std::max(0.01, m.value("roughness", 0.5))});
      return t;
    }
    if (type == "diffuse") {
      if (m.value("roughness", 0.0) != 0.0) {
        return NoTruth(why_not, "diffuse with roughness > 0 is Oren-Nayar, not lambert");
      }
      SidecarTruth t = truth("lambert");
      set(&t, "kd", m.at("base_color").get<std::vector<double>>());
      return t;
    }
    return NoTruth(why_not, fmt::format("material type '{}' has no equivalent model "
                                        "(principled and diffuse do)",
                                        type));
  } catch (const json::exception& e) {
    return NoTruth(why_not, fmt::format("material: {}", e.what()));
  }
}

}  // namespace shadefit::reference_images
