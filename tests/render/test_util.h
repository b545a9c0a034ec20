// Shared helpers for render tests: one GL context per test process, test-output paths.
#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include "shadefit/render/gl_context.h"
#include "shadefit/render/renderer.h"
#include "shadefit/render/scene.h"

namespace shadefit::testing {

// Created once; the context stays current on the main thread (gtest runs tests there).
inline Renderer& SharedRenderer() {
  static GlContext* context = new GlContext();
  static Renderer* renderer = new Renderer(*context);
  return *renderer;
}

inline std::string TestOutputDir(const std::string& sub) {
  const std::filesystem::path dir = std::filesystem::path(SHADEFIT_TEST_OUTPUT) / sub;
  std::filesystem::create_directories(dir);
  return dir.string();
}

// A unit sphere at the origin seen from -Y (world +Z up), w x h pixels.
inline std::string SphereSceneToml(int w, int h, const std::string& lights) {
  return "[camera]\nposition = [0.0, -6.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\n"
         "up = [0.0, 0.0, 1.0]\nfov_y = 22.0\nresolution = [" +
         std::to_string(w) + ", " + std::to_string(h) +
         "]\n[[objects]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n" + lights;
}

}  // namespace shadefit::testing
