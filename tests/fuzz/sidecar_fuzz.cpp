// libFuzzer harness: the sidecar reader of reference_images::LoadReference
// (reference_images/src/reference.cpp), which finds a reference's scene through <image>.json. The
// input is the sidecar; the image, the scene it names in the seeds and a mask are fixtures. Any
// input either loads or is rejected with shadefit::Error.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_util.h"
#include "shadefit/base/error.h"
#include "shadefit/fit/fitter.h"
#include "shadefit/render/image.h"

namespace {

std::string MakeFixtures() {
  namespace fz = shadefit::fuzz;
  fz::WriteFile("scene.toml",
                "[camera]\nposition = [0.0, -6.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\n"
                "resolution = [4, 4]\n[[objects]]\ntype = \"sphere\"\n[[lights]]\n"
                "type = \"point\"\nposition = [4.0, -4.0, 3.0]\npower = 1000.0\n");
  fz::WriteFile("wide.toml",
                "[camera]\nposition = [0.0, -6.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\n"
                "resolution = [8, 4]\n[[objects]]\ntype = \"sphere\"\n");
  const std::string image = (fz::ScratchDir() / "ref.exr").string();
  shadefit::WriteExr(image, shadefit::Image(4, 4, 4, 0.25f));
  return image;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string image = MakeFixtures();
  shadefit::fuzz::WriteFile("ref.json", data, size);
  try {
    const shadefit::fit::FitReference ref = shadefit::fit::LoadReference(image, "", "");
    (void)ref;
  } catch (const shadefit::Error&) {
  }
  return 0;
}
