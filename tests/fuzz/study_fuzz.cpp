// libFuzzer harness: the study file parser (studies/runner/src/study.cpp), with and without
// --quick. The input is written as a study file into a scratch folder that holds what a small
// study names (two references with sidecars, a scene, a measured-BRDF folder), so that the
// parser gets past the globs into the [fit], [probes], [verdicts] and [quick] checks. Any input
// either loads or is rejected with shadefit::Error.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

#include "fuzz_util.h"
#include "shadefit/base/error.h"
#include "shadefit/render/image.h"
#include "shadefit/studies/study.h"

namespace {

void MakeFixtures() {
  namespace fz = shadefit::fuzz;
  const std::string scene =
      "[camera]\nposition = [0.0, -6.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\nresolution = [4, 4]\n"
      "[[objects]]\ntype = \"sphere\"\n[[lights]]\ntype = \"point\"\nposition = [4.0, -4.0, 3.0]\n"
      "power = 1000.0\n";
  fz::WriteFile("scene-key.toml", scene);
  fz::WriteFile("scene-rim.toml", scene);
  for (const char* name : {"gold-key", "gold-rim", "red-key"}) {
    shadefit::WriteExr((fz::ScratchDir() / (std::string(name) + ".exr")).string(),
                       shadefit::Image(4, 4, 4, 0.5f));
    fz::WriteFile(std::string(name) + ".json", R"({"scene_file": "scene-key.toml"})");
  }
  std::filesystem::create_directories(fz::ScratchDir() / "brdfs");
  fz::WriteFile("brdfs/alum.binary", "");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool ready = (MakeFixtures(), true);
  (void)ready;
  const std::string path = shadefit::fuzz::WriteFile("study.toml", data, size);
  for (bool quick : {false, true}) {
    try {
      const shadefit::studies::StudySpec spec = shadefit::studies::LoadStudy(path, quick);
      (void)spec.ToJson().dump();
    } catch (const shadefit::Error&) {
    }
  }
  return 0;
}
