// Neural-BRDF reader: the README's spot values, synthetic networks with non-trivial weights held
// to a hand-worked value and to a forward pass written here, and bad weights files (all written
// here with the HDF5 C API).
#include <gtest/gtest.h>
#include <hdf5.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <vector>

#include "reference_images_test_util.h"
#include "shadefit/reference_images/measured_brdf.h"
#include "shadefit/base/error.h"

namespace shadefit::reference_images {
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

// --- Non-trivial networks against a forward pass written here ---------------------------------
//
// The architecture is the one Sztrajman et al. 2021 ("Neural BRDF Representation and Importance
// Sampling", CGF 40(6)) published and ../shared/brdf-data/README.md documents: a Keras
// Sequential Dense(6 -> 21, relu), Dense(21 -> 21, relu), Dense(21 -> 3, linear), then
// exp(x) - 1 clamped at 0; Keras stores a Dense kernel as (inputs, outputs) and evaluates the row
// vector x times the kernel plus the bias. The input is (sin theta_h, 0, cos theta_h, d) with d the
// Rusinkiewicz difference vector.

struct Dense {
  int in, out;
  std::vector<float> kernel;  // (in, out), row-major as HDF5 stores it
  std::vector<float> bias;    // out
};

void WriteNetwork(const std::string& base, const std::array<Dense, 3>& layers) {
  const hid_t file = H5Fcreate((base + ".h5").c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  const hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
  H5Pset_create_intermediate_group(lcpl, 1);
  auto write = [&](const std::string& name, std::vector<hsize_t> shape,
                   const std::vector<float>& values) {
    const hid_t space = H5Screate_simple(static_cast<int>(shape.size()), shape.data(), nullptr);
    const hid_t set =
        H5Dcreate2(file, name.c_str(), H5T_IEEE_F32LE, space, lcpl, H5P_DEFAULT, H5P_DEFAULT);
    H5Dwrite(set, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data());
    H5Dclose(set);
    H5Sclose(space);
  };
  for (int l = 0; l < 3; ++l) {
    const std::string name = "dense_" + std::to_string(l + 1);
    const Dense& d = layers[l];
    write("/" + name + "/" + name + "/kernel:0",
          {static_cast<hsize_t>(d.in), static_cast<hsize_t>(d.out)}, d.kernel);
    write("/" + name + "/" + name + "/bias:0", {static_cast<hsize_t>(d.out)}, d.bias);
  }
  H5Pclose(lcpl);
  H5Fclose(file);
  std::FILE* f = std::fopen((base + ".json").c_str(), "w");
  std::fputs(kConfig, f);
  std::fclose(f);
}

std::array<Dense, 3> ZeroNetwork() {
  return {Dense{6, 21, std::vector<float>(6 * 21, 0.0f), std::vector<float>(21, 0.0f)},
          Dense{21, 21, std::vector<float>(21 * 21, 0.0f), std::vector<float>(21, 0.0f)},
          Dense{21, 3, std::vector<float>(21 * 3, 0.0f), std::vector<float>(3, 0.0f)}};
}

// The test's own forward pass, also reporting how many hidden pre-activations were negative
// (where relu matters).
Vec3d HandForward(const std::array<Dense, 3>& net, const std::vector<double>& x,
                  int* negative_hidden) {
  std::vector<double> a = x;
  for (int l = 0; l < 3; ++l) {
    const Dense& d = net[l];
    std::vector<double> z(d.out);
    for (int o = 0; o < d.out; ++o) {
      double s = d.bias[o];
      for (int i = 0; i < d.in; ++i) s += a[i] * d.kernel[i * d.out + o];
      if (l < 2 && s < 0) {
        ++*negative_hidden;
        s = 0;
      }
      z[o] = s;
    }
    a = z;
  }
  return {std::max(std::exp(a[0]) - 1, 0.0), std::max(std::exp(a[1]) - 1, 0.0),
          std::max(std::exp(a[2]) - 1, 0.0)};
}

TEST(NeuralBrdfTest, SparseNetworkGivesHandComputedValue) {
  // At theta_h = theta_d = 0 the input is x = (0, 0, 1, 0, 0, 1). Worked through on paper:
  //   layer 1: z0 = x2 + 0.5 x5 = 1.5; z1 = -2 x2 + 0.5 = -1.5 -> relu 0; z3 = 0.25 x5 = 0.25;
  //            z4 = -0.1 -> 0.                                   a1 = (1.5, 0, 0, 0.25, 0, ...)
  //   layer 2: z0 = 2 a1[3] = 0.5; z2 = 0.6 a1[0] + 0.1 = 1.0; z5 = -2 a1[1] = 0 (it would be 3
  //            were layer 1 linear); z6 = -a1[0] = -1.5 -> 0.   a2 = (0.5, 0, 1.0, 0, 0, 0, 0, ...)
  //   layer 3: y0 = a2[0] = 0.5; y1 = 0.5 a2[2] + a2[5] + 0.2 = 0.7;
  //            y2 = -0.25 a2[2] + 3 a2[6] + 0.5 = 0.25 (it would be -4.25 were layer 2 linear)
  //   output:  (e^0.5 - 1, e^0.7 - 1, e^0.25 - 1).
  // A transposed kernel moves these weights to other units (e.g. layer 2's a1[3] -> unit 0
  // becomes a1[0] -> unit 3) and changes every channel.
  auto net = ZeroNetwork();
  auto k = [&](int l, int i, int o) -> float& { return net[l].kernel[i * net[l].out + o]; };
  k(0, 2, 0) = 1.0f;
  k(0, 5, 0) = 0.5f;
  k(0, 2, 1) = -2.0f;
  k(0, 5, 3) = 0.25f;
  net[0].bias[1] = 0.5f;
  net[0].bias[4] = -0.1f;
  k(1, 3, 0) = 2.0f;
  k(1, 0, 2) = 0.6f;
  k(1, 1, 5) = -2.0f;
  k(1, 0, 6) = -1.0f;
  net[1].bias[2] = 0.1f;
  k(2, 0, 0) = 1.0f;
  k(2, 2, 1) = 0.5f;
  k(2, 5, 1) = 1.0f;
  k(2, 2, 2) = -0.25f;
  k(2, 6, 2) = 3.0f;
  net[2].bias = {0.0f, 0.2f, 0.5f};
  const std::string base = testing::OutputDir() + "/sparse-network";
  WriteNetwork(base, net);
  const NeuralBrdf brdf(base + ".h5", base + ".json");
  const Vec3d expected{0.6487212707001282, 1.0137527074704766, 0.2840254166877415};
  const Vec3d got = brdf.EvalAngles(0.0, 0.0, 0.0);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], expected[c], 1e-6) << "channel " << c;
  // The same through directions: theta_h = theta_d = 0 is wi = wo = +z.
  const Vec3d by_dirs = brdf.Eval({0, 0, 1}, {0, 0, 1});
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(by_dirs[c], expected[c], 1e-6) << "channel " << c;
}

TEST(NeuralBrdfTest, DenseNetworkMatchesIndependentForwardPass) {
  // Mixed-sign weights, no symmetry: every kernel entry and bias matters, and many hidden units
  // are cut by relu at every input (counted below so the check cannot pass on linear layers).
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> w(-0.6f, 0.6f);
  auto net = ZeroNetwork();
  for (auto& layer : net) {
    for (float& v : layer.kernel) v = w(rng);
    for (float& v : layer.bias) v = 0.5f * w(rng);
  }
  net[2].bias = {0.3f, 0.1f, 0.2f};
  const std::string base = testing::OutputDir() + "/dense-network";
  WriteNetwork(base, net);
  const NeuralBrdf brdf(base + ".h5", base + ".json");

  std::uniform_real_distribution<double> u(0.0, 1.0);
  int negative_hidden = 0, positive_outputs = 0;
  for (int n = 0; n < 200; ++n) {
    // wi, wo in the upper hemisphere; d computed here: wi rotated by -phi_h about z, then by
    // -theta_h about y (Rusinkiewicz 1998, section 3).
    auto dir = [&] {
      const double t = 1.4 * u(rng), p = 2 * kPi * u(rng);
      return Vec3d{std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
    };
    const Vec3d wi = dir(), wo = dir();
    const Vec3d s = wi + wo;
    const double len = std::sqrt(s.x * s.x + s.y * s.y + s.z * s.z);
    const double theta_h = std::acos(s.z / len), phi_h = std::atan2(s.y, s.x);
    const double x1 = wi.x * std::cos(phi_h) + wi.y * std::sin(phi_h);
    const double y1 = -wi.x * std::sin(phi_h) + wi.y * std::cos(phi_h);
    const double dx = x1 * std::cos(theta_h) - wi.z * std::sin(theta_h);
    const double dz = x1 * std::sin(theta_h) + wi.z * std::cos(theta_h);
    const Vec3d expected = HandForward(
        net, {std::sin(theta_h), 0.0, std::cos(theta_h), dx, y1, dz}, &negative_hidden);
    const Vec3d got = brdf.Eval(wi, wo);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(got[c], expected[c], 1e-6 * (1 + expected[c])) << "sample " << n << " ch " << c;
      positive_outputs += expected[c] > 0;
    }
  }
  std::printf("dense network: %d negative hidden pre-activations, %d positive outputs of 600\n",
              negative_hidden, positive_outputs);
  EXPECT_GT(negative_hidden, 200 * 5);  // relu cut at least 5 of 42 units per input on average
  EXPECT_GT(positive_outputs, 300);     // the output clamp does not hide the values
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
}  // namespace shadefit::reference_images
