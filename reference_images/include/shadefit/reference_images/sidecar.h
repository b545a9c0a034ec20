// The sidecar JSON of a reference image (<image without extension>.json): written by the Cycles
// generator (reference_images/cycles/gen.py), the measured renderer and the importer; read here.
// The fields read: "scene_file" (or "scene" when it is a string), the scene TOML relative to the
// sidecar; "material", the Cycles material ({"type": "principled", "base_color", "metallic",
// "specular", "roughness", "distribution"} or {"type": "diffuse", "base_color", "roughness"}).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "shadefit/render/models.h"

namespace shadefit::reference_images {

// "<image path without extension>.json".
std::string SidecarPathFor(const std::string& image_path);

// The scene path a sidecar names ("scene_file", else "scene" when it is a string), resolved
// relative to the sidecar as LoadReference resolves it; "" when there is none or the sidecar
// cannot be read (the study runner hashes it when it exists).
std::string SceneOfSidecar(const std::string& sidecar_path);

// The sidecar's material as one of shadefit's models with its parameters: the ground truth the
// probes compare against.
struct SidecarTruth {
  ModelRef model;              // cycles-principled or lambert.
  std::vector<double> params;  // Flattened, natural units, in the model's parameter order.
};

// Principled BSDF with the GGX distribution -> cycles-principled (base_color, metallic (default
// 0), specular (0.5), roughness (0.5) raised to 0.01, the model's lower bound); Diffuse BSDF with
// roughness 0 -> lambert (kd = base_color). Anything else has no exact twin among the models
// (Multiscatter GGX, Oren-Nayar diffuse, other shaders): nullopt, with the reason in `why_not`
// (when given), as also for a sidecar that cannot be read or has no material. Throws
// shadefit::Error naming the sidecar when a value is outside its model's parameter table.
std::optional<SidecarTruth> TruthOfSidecar(const std::string& sidecar_path,
                                           std::string* why_not = nullptr);

}  // namespace shadefit::reference_images
