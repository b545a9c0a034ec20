// libFuzzer harness: the MERL .binary reader (reference_images/src/merl_brdf.cpp). A valid table
// is 34,992,012 bytes, far beyond what a fuzzer mutates, so the first input byte picks how the
// rest becomes a file: odd, the bytes as they are (header and size checks); even, the bytes
// (header included) laid over a table of the exact size filled with a value the input picks,
// which reaches the data checks and the lookups. A file that loads must give finite,
// non-negative values everywhere.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "fuzz_util.h"
#include "shadefit/base/error.h"
#include "shadefit/reference_images/measured_brdf.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace reference_images = shadefit::reference_images;
  if (size < 1) return 0;
  std::string path;
  if (data[0] & 1) {
    path = shadefit::fuzz::WriteFile("t.binary", data + 1, size - 1);
  } else {
    constexpr std::size_t kBytes = 12 + 3 * reference_images::kMerlCells * sizeof(double);
    static std::vector<std::uint8_t> table(kBytes);
    double fill = 1.0;
    if (size >= 9) std::memcpy(&fill, data + 1, sizeof fill);
    // The cells start at byte 12, not 8-aligned: copy, never cast.
    for (std::size_t i = 0; i < 3 * reference_images::kMerlCells; ++i) {
      std::memcpy(table.data() + 12 + i * sizeof fill, &fill, sizeof fill);
    }
    const std::int32_t dims[3] = {reference_images::kMerlThetaH, reference_images::kMerlThetaD,
                                  reference_images::kMerlPhiD};
    std::memcpy(table.data(), dims, sizeof dims);
    if (size > 9) std::memcpy(table.data(), data + 9, std::min(size - 9, kBytes));
    path = shadefit::fuzz::WriteFile("t.binary", table.data(), table.size());
  }
  for (reference_images::MerlLookup lookup :
       {reference_images::MerlLookup::kTrilinear, reference_images::MerlLookup::kTruncate}) {
    try {
      const reference_images::MerlBrdf brdf(path, lookup);
      for (double th : {0.0, 0.3, 1.5707963}) {
        for (double td : {0.0, 0.7, 1.5707963}) {
          for (double pd : {-3.0, 0.0, 1.0, 3.14159265}) {
            const shadefit::Vec3d v = brdf.EvalAngles(th, td, pd);
            for (int c = 0; c < 3; ++c) {
              if (!std::isfinite(v[c]) || v[c] < 0) std::abort();
            }
          }
        }
      }
    } catch (const shadefit::Error&) {
    }
  }
  return 0;
}
