// The scene a reference's sidecar names, for the runner's input hashes and the parameter charts.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

namespace shadefit::studies {

// The scene path a sidecar names ("scene_file", else "scene" when it is a string), resolved
// relative to the sidecar as fit::LoadReference resolves it; "" when there is none.
inline std::string SceneOfSidecar(const std::string& sidecar) {
  if (sidecar.empty()) return "";
  std::ifstream in(sidecar);
  try {
    const nlohmann::json j = nlohmann::json::parse(in);
    std::string s;
    if (j.contains("scene_file") && j["scene_file"].is_string()) s = j["scene_file"];
    else if (j.contains("scene") && j["scene"].is_string()) s = j["scene"];
    if (s.empty()) return "";
    return (std::filesystem::path(sidecar).parent_path() / s).lexically_normal().string();
  } catch (const nlohmann::json::exception&) {
    return "";
  }
}

}  // namespace shadefit::studies
