// libFuzzer harness: the scene TOML parser (render/src/scene.cpp). Any input either parses or is
// rejected with shadefit::Error; anything else escaping (another exception type, a crash, a
// sanitizer report) is a bug. A parsed scene must also be usable: a camera ray through every
// corner must be finite.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "shadefit/base/error.h"
#include "shadefit/render/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const shadefit::Scene scene = shadefit::ParseScene(text, "fuzz/scene.toml");
    const shadefit::Camera& c = scene.camera;
    for (double px : {0.0, static_cast<double>(c.width)}) {
      for (double py : {0.0, static_cast<double>(c.height_px)}) {
        const shadefit::Ray ray = shadefit::CameraRay(c, px, py);
        for (int i = 0; i < 3; ++i) {
          if (!std::isfinite(ray.origin[i]) || !std::isfinite(ray.direction[i])) std::abort();
        }
        shadefit::Hit hit;
        shadefit::Intersect(scene, ray, 1e-6, 1e30, &hit);
      }
    }
  } catch (const shadefit::Error&) {
  }
  return 0;
}
