// libFuzzer harness: image import (reference_images/src/import.cpp, LoadImageForImport) and the
// reader behind every reference and mask (render/src/image.cpp, ReadImage). The first byte picks
// the file name's extension, and so OpenImageIO's reader; the rest is the file. Small images
// that load also go through the sphere finder of `refs import --auto-sphere`. Any input either
// loads or is rejected with shadefit::Error.
//
// The decoders (OpenImageIO, OpenEXR, libpng, libjpeg, libtiff) are Debian's builds, without
// coverage or sanitizers: the fuzzer steers by our code only and finds their bugs only where
// they crash outright.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_util.h"
#include "shadefit/base/error.h"
#include "shadefit/reference_images/import.h"
#include "shadefit/render/image.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const char* kExtensions[] = {".exr", ".png", ".jpg", ".tga", ".tif", ".hdr"};
  if (size < 1) return 0;
  const std::string path = shadefit::fuzz::WriteFile(
      std::string("image") + kExtensions[data[0] % 6], data + 1, size - 1);
  try {
    const shadefit::reference_images::LoadedImage loaded =
        shadefit::reference_images::LoadImageForImport(path);
    if (loaded.rgb.width <= 128 && loaded.rgb.height <= 128) {
      try {
        shadefit::reference_images::DetectSphere(loaded.rgb, 1.0, path);
      } catch (const shadefit::Error&) {
      }
    }
  } catch (const shadefit::Error&) {
  }
  try {
    (void)shadefit::ReadImage(path);
  } catch (const shadefit::Error&) {
  }
  return 0;
}
