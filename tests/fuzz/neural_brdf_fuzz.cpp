// libFuzzer harness: the Neural-BRDF reader (reference_images/src/neural_brdf.cpp). The input is
// the Keras model config (.json); the weights (.h5) are a valid network of the published shape
// (6 -> 21 -> 21 -> 3, layers dense_1..dense_3), written once with the HDF5 C API, so that every
// config the parser accepts is checked against real datasets. A network that loads must
// evaluate to finite, non-negative values.
//
// The .h5 bytes themselves are not fuzzed: they are parsed by libhdf5, which is not built with
// the sanitizers or coverage here; its own fuzzing is upstream's (docs/inputs.md).
#include <hdf5.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "fuzz_util.h"
#include "shadefit/reference_images/measured_brdf.h"
#include "shadefit/base/error.h"

namespace {

std::string MakeWeights() {
  const std::string path = (shadefit::fuzz::ScratchDir() / "net.h5").string();
  const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  const hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
  H5Pset_create_intermediate_group(lcpl, 1);
  const hsize_t width[4] = {6, 21, 21, 3};
  for (int l = 0; l < 3; ++l) {
    const std::string name = "dense_" + std::to_string(l + 1);
    for (int bias = 0; bias < 2; ++bias) {
      std::vector<hsize_t> shape =
          bias ? std::vector<hsize_t>{width[l + 1]} : std::vector<hsize_t>{width[l], width[l + 1]};
      std::vector<float> values(bias ? width[l + 1] : width[l] * width[l + 1]);
      for (std::size_t i = 0; i < values.size(); ++i) values[i] = 0.01f * ((i * 7) % 13) - 0.05f;
      const std::string set_path = "/" + name + "/" + name + (bias ? "/bias:0" : "/kernel:0");
      const hid_t space = H5Screate_simple(static_cast<int>(shape.size()), shape.data(), nullptr);
      const hid_t set =
          H5Dcreate2(file, set_path.c_str(), H5T_IEEE_F32LE, space, lcpl, H5P_DEFAULT, H5P_DEFAULT);
      H5Dwrite(set, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data());
      H5Dclose(set);
      H5Sclose(space);
    }
  }
  H5Pclose(lcpl);
  H5Fclose(file);
  return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string h5 = MakeWeights();
  const std::string json = shadefit::fuzz::WriteFile("net.json", data, size);
  try {
    const shadefit::reference_images::NeuralBrdf brdf(h5, json);
    for (double th : {0.0, 0.5, 1.5}) {
      for (double td : {0.0, 0.5, 1.5}) {
        const shadefit::Vec3d v = brdf.EvalAngles(th, td, 0.25);
        for (int c = 0; c < 3; ++c) {
          if (!std::isfinite(v[c]) || v[c] < 0) std::abort();
        }
      }
    }
  } catch (const shadefit::Error&) {
  }
  return 0;
}
