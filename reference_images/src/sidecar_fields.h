// Field readers of the sidecar schema (reference_images/sidecar.h), shared by LoadReference and the
// sidecar functions so that each field is read in one place.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace shadefit::reference_images::internal {

// The scene a sidecar names, as written: "scene_file", else "scene" when it is a string; ""
// when neither is.
inline std::string SceneFieldOf(const nlohmann::json& sidecar) {
  if (sidecar.contains("scene_file") && sidecar["scene_file"].is_string()) {
    return sidecar["scene_file"].get<std::string>();
  }
  if (sidecar.contains("scene") && sidecar["scene"].is_string()) {
    return sidecar["scene"].get<std::string>();
  }
  return "";
}

}  // namespace shadefit::reference_images::internal
