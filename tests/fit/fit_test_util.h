// Shared helpers for the fit tests: one GL context per process, synthetic references rendered by
// our own renderer, test-output paths.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "shadefit/fit/fitter.h"
#include "shadefit/render/gl_context.h"
#include "shadefit/render/models.h"
#include "shadefit/render/renderer.h"
#include "shadefit/render/scene.h"
#include "../render/test_util.h"  // SharedRenderer(), TestOutputDir().

namespace shadefit::testing {

inline std::string CameraToml(const std::string& position, double fov, int size) {
  return "[camera]\nposition = " + position +
         "\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nfov_y = " + std::to_string(fov) +
         "\nresolution = [" + std::to_string(size) + ", " + std::to_string(size) + "]\n";
}

constexpr const char* kSphere =
    "[[objects]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n";

// Three lightings of one material: a unit sphere with a key light, the same sphere with a side
// light plus a directional fill, and a square plane seen at 60 degrees with the point light at
// the mirror position (a highlight spread over many pixels: sharp lobes stay well sampled).
inline std::vector<Scene> SyntheticScenes(int size) {
  std::vector<Scene> scenes;
  scenes.push_back(ParseScene(CameraToml("[0.0, -6.0, 0.0]", 22.0, size) + kSphere +
                                  "[[lights]]\ntype = \"point\"\nposition = [2.5, -3.5, 2.5]\n"
                                  "power = 600.0\n",
                              "key.toml"));
  scenes.push_back(ParseScene(
      CameraToml("[0.0, -6.0, 0.0]", 22.0, size) + kSphere +
          "[[lights]]\ntype = \"point\"\nposition = [4.9, -1.0, 0.9]\npower = 600.0\n"
          "[[lights]]\ntype = \"directional\"\ndirection = [0.3, 0.5, -1.0]\n"
          "irradiance = [0.6, 0.5, 0.4]\n[[lights]]\ntype = \"ambient\"\nradiance = 0.1\n",
      "side.toml"));
  scenes.push_back(ParseScene(
      CameraToml("[0.0, -4.3301270, 2.5]", 30.0, size) +
          "[[objects]]\ntype = \"plane\"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n"
          "half_size = [2.0, 2.0]\n"
          "[[lights]]\ntype = \"point\"\nposition = [0.3, 4.3301270, 2.5]\npower = 1000.0\n",
      "plane.toml"));
  return scenes;
}

// Renders `model` with `params` under each scene: in-memory references.
inline std::vector<fit::FitReference> SyntheticReferences(const std::string& model,
                                                          const std::vector<double>& params,
                                                          const std::vector<Scene>& scenes) {
  std::vector<fit::FitReference> refs;
  const ModelInfo& m = FindModel(model);
  int i = 0;
  for (const Scene& scene : scenes) {
    fit::FitReference ref;
    ref.name = "synthetic" + std::to_string(i++);
    ref.scene = scene;
    ref.image = SharedRenderer().Render(scene, m.id, params);
    refs.push_back(std::move(ref));
  }
  return refs;
}

}  // namespace shadefit::testing
