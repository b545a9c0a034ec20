// Neural-BRDF reader: the README's spot values, the forward pass through Eval, and a weights
// file with a dataset missing (written here with the HDF5 C API).
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "refs_test_util.h"
#include "shadefit/refs/measured_brdf.h"
#include "shadefit/render/error.h"

namespace shadefit::refs {
namespace {

namespace fs = std::filesystem;

std::string NbrdfDir() {
  const std::string data = testing::BrdfDataDir();
  return data.empty() ? std::string() : data + "/merl-nbrdf";
}

#define SKIP_WITHOUT_DATA()                                                           \
  if (NbrdfDir().empty() || !fs::exists(NbrdfDir() + "/chrome.h5"))                   \
  GTEST_SKIP() << "../shared/brdf-data absent (set SHADEFIT_BRDF_DATA), because the " \
                  "Neural-BRDF networks are data beside the project, never copied into it"

// ../shared/brdf-data/README.md, "Known behaviour": theta_h = 0, theta_d = 0.3 rad, phi_d = 0.
void ExpectSpotValue(const std::string& name, const Vec3d& expected) {
  const std::string base = NbrdfDir() + "/" + name;
  const NeuralBrdf brdf(base + ".h5", base + ".json");
  const Vec3d by_angles = brdf.EvalAngles(0.0, 0.3, 0.0);
  Vec3d wi, wo;
  FromHalfDiff(0.0, 0.3, 0.0, &wi, &wo);
  const Vec3d by_directions = brdf.Eval(wi, wo);
  const Vec3d swapped = brdf.Eval(wo, wi);
  std::printf(
      "%s: angles (%.6g, %.6g, %.6g) directions (%.6g, %.6g, %.6g) swapped (%.6g, "
      "%.6g, %.6g) README (%g, %g, %g)\n",
      name.c_str(), by_angles.x, by_angles.y, by_angles.z, by_directions.x, by_directions.y,
      by_directions.z, swapped.x, swapped.y, swapped.z, expected.x, expected.y, expected.z);
  // The README quotes 3 significant figures: hold to 1e-3 relative plus its rounding.
  for (int c = 0; c < 3; ++c) {
    const double tol =
        1e-3 * expected[c] + 0.5 * std::pow(10.0, std::floor(std::log10(expected[c])) - 2);
    EXPECT_NEAR(by_angles[c], expected[c], tol) << name << " channel " << c;
    EXPECT_NEAR(by_directions[c], by_angles[c], 1e-9 * by_angles[c]) << name << " channel " << c;
  }
}

TEST(NeuralBrdfTest, ChromeSpotValue) {
  SKIP_WITHOUT_DATA();
  ExpectSpotValue("chrome", {494, 538, 537});
}

TEST(NeuralBrdfTest, WhiteDiffuseSpotValue) {
  SKIP_WITHOUT_DATA();
  ExpectSpotValue("white-diffuse-bball", {0.148, 0.131, 0.106});
}

TEST(NeuralBrdfTest, AllNetworksLoadAndStayFinite) {
  SKIP_WITHOUT_DATA();
  int count = 0;
  for (const auto& entry : fs::directory_iterator(NbrdfDir())) {
    if (entry.path().extension() != ".h5") continue;
    const auto brdf = LoadMeasuredBrdf(entry.path().string());
    for (double th = 0; th < 1.5; th += 0.25) {
      for (double td = 0; td < 1.3; td += 0.25) {
        const Vec3d f = static_cast<const NeuralBrdf&>(*brdf).EvalAngles(th, td, 0.5);
        for (int c = 0; c < 3; ++c) EXPECT_TRUE(std::isfinite(f[c]) && f[c] >= 0);
      }
    }
    ++count;
  }
  EXPECT_EQ(count, 20);
}

// Writes an HDF5 file holding only the given (dataset path, shape) entries, zero-filled.
void WriteWeights(const std::string& path,
                  const std::vector<std::pair<std::string, std::vector<hsize_t>>>& sets) {
  const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  const hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
  H5Pset_create_intermediate_group(lcpl, 1);
  for (const auto& [name, shape] : sets) {
    std::size_t n = 1;
    for (hsize_t d : shape) n *= d;
    std::vector<float> zeros(n, 0.0f);
    const hid_t space = H5Screate_simple(static_cast<int>(shape.size()), shape.data(), nullptr);
    const hid_t set =
        H5Dcreate2(file, name.c_str(), H5T_IEEE_F32LE, space, lcpl, H5P_DEFAULT, H5P_DEFAULT);
    H5Dwrite(set, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, zeros.data());
    H5Dclose(set);
    H5Sclose(space);
  }
  H5Pclose(lcpl);
  H5Fclose(file);
}

const char* kConfig =
    R"({"class_name": "Sequential", "config": {"name": "s", "layers": [
  {"class_name": "Dense", "config": {"name": "dense_1", "units": 21, "activation": "relu"}},
  {"class_name": "Dense", "config": {"name": "dense_2", "units": 21, "activation": "relu"}},
  {"class_name": "Dense", "config": {"name": "dense_3", "units": 3, "activation": "linear"}},
  {"class_name": "Lambda", "config": {"name": "lambda_1"}}]}})";

TEST(NeuralBrdfTest, CompleteSyntheticFileLoads) {
  const std::string dir = testing::OutputDir();
  WriteWeights(dir + "/complete.h5", {{"/dense_1/dense_1/kernel:0", {6, 21}},
                                      {"/dense_1/dense_1/bias:0", {21}},
                                      {"/dense_2/dense_2/kernel:0", {21, 21}},
                                      {"/dense_2/dense_2/bias:0", {21}},
                                      {"/dense_3/dense_3/kernel:0", {21, 3}},
                                      {"/dense_3/dense_3/bias:0", {3}}});
  std::FILE* f = std::fopen((dir + "/complete.json").c_str(), "w");
  std::fputs(kConfig, f);
  std::fclose(f);
  const NeuralBrdf brdf(dir + "/complete.h5", dir + "/complete.json");
  // All weights zero: exp(0) - 1 = 0.
  EXPECT_EQ(brdf.EvalAngles(0.1, 0.2, 0.3).x, 0.0);
}

TEST(NeuralBrdfTest, MissingDatasetIsAnError) {
  const std::string dir = testing::OutputDir();
  const std::string h5 = dir + "/missing-dense3.h5", json = dir + "/missing-dense3.json";
  WriteWeights(h5, {{"/dense_1/dense_1/kernel:0", {6, 21}},
                    {"/dense_1/dense_1/bias:0", {21}},
                    {"/dense_2/dense_2/kernel:0", {21, 21}},
                    {"/dense_2/dense_2/bias:0", {21}},
                    {"/dense_3/dense_3/bias:0", {3}}});
  std::FILE* f = std::fopen(json.c_str(), "w");
  std::fputs(kConfig, f);
  std::fclose(f);
  try {
    LoadMeasuredBrdf(h5);
    ADD_FAILURE() << "no error for a file without /dense_3/dense_3/kernel:0";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what, h5 + ": /dense_3/dense_3/kernel:0: dataset missing (no link "
                         "/dense_3/dense_3/kernel:0)");
  }
  // A whole layer group missing names the dataset too.
  const std::string h5b = dir + "/missing-layer.h5", jsonb = dir + "/missing-layer.json";
  WriteWeights(h5b, {{"/dense_1/dense_1/kernel:0", {6, 21}}, {"/dense_1/dense_1/bias:0", {21}}});
  fs::copy_file(json, jsonb, fs::copy_options::overwrite_existing);
  try {
    NeuralBrdf b(h5b, jsonb);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              h5b + ": /dense_2/dense_2/kernel:0: dataset missing (no link /dense_2)");
  }
}

TEST(NeuralBrdfTest, WrongShapeAndMissingConfigAreErrors) {
  const std::string dir = testing::OutputDir();
  const std::string h5 = dir + "/bad-shape.h5", json = dir + "/bad-shape.json";
  WriteWeights(h5, {{"/dense_1/dense_1/kernel:0", {7, 21}}});
  std::FILE* f = std::fopen(json.c_str(), "w");
  std::fputs(kConfig, f);
  std::fclose(f);
  try {
    NeuralBrdf b(h5, json);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(h5 + ": /dense_1/dense_1/kernel:0: shape (7, 21)"),
              std::string::npos)
        << e.what();
  }
  const std::string lone = dir + "/lone.h5";
  WriteWeights(lone, {});
  try {
    LoadMeasuredBrdf(lone);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(lone + ": config:"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace shadefit::refs
