// Reading references (sidecar -> scene), provenance hashes, output files (their contents: fitted
// image, error image, preview; no temporary left), and the `fit` subcommand end to end, including
// "bad input -> one-line error and no output file".
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "commands.h"
#include "fit_test_util.h"
#include "shadefit/base/error.h"

namespace shadefit {
namespace {
namespace fs = std::filesystem;

// FIPS 180-4 example vectors (NIST CSRC "SHA256.pdf").
TEST(Sha256Test, KnownVectors) {
  EXPECT_EQ(fit::Sha256("abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(fit::Sha256(""),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(fit::Sha256("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
}

// Writes a small reference set into test_output/<sub>: image, sidecar, scene.
struct Files {
  std::string dir, exr, json, toml;
};
Files MakeReferenceFiles(const std::string& sub, bool write_sidecar = true) {
  Files f;
  f.dir = testing::TestOutputDir(sub);
  f.exr = f.dir + "/ref.exr";
  f.json = f.dir + "/ref.json";
  f.toml = f.dir + "/scenes/key.toml";
  fs::create_directories(f.dir + "/scenes");
  fs::remove(f.json);
  const Scene scene = testing::SyntheticScenes(48)[0];
  std::ofstream(f.toml) << scene.source_text;
  const Image image = testing::SharedRenderer().Render(
      scene, FindModel("ggx").id, {0.6, 0.3, 0.1, 0.04, 0.04, 0.04, 0.3});
  WriteExr(f.exr, image);
  if (write_sidecar) std::ofstream(f.json) << R"({"scene_file": "scenes/key.toml"})";
  return f;
}

TEST(LoadReferenceTest, SceneFromSidecarAndHashes) {
  const Files f = MakeReferenceFiles("fit_io_load");
  const fit::FitReference ref = fit::LoadReference(f.exr);
  EXPECT_EQ(ref.name, "ref");
  EXPECT_EQ(fs::path(ref.scene_path), fs::path(f.toml).lexically_normal());
  EXPECT_EQ(ref.sha256.at("image"), fit::Sha256File(f.exr));
  EXPECT_EQ(ref.sha256.at("scene").size(), 64u);
  EXPECT_TRUE(std::isinf(ref.clip_level));
}

TEST(LoadReferenceTest, ShippedCyclesReferenceResolvesItsScene) {
  const std::string exr =
      std::string(SHADEFIT_SOURCE_DIR) + "/reference_images/cycles/red-plastic-key.exr";
  if (!fs::exists(exr)) GTEST_SKIP() << "shipped references not present";
  const fit::FitReference ref = fit::LoadReference(exr);
  EXPECT_EQ(fs::path(ref.scene_path).filename(), "sphere-key.toml");
  EXPECT_EQ(ref.image.width, ref.scene.camera.width);
}

TEST(LoadReferenceTest, MissingSidecarNamesIt) {
  const Files f = MakeReferenceFiles("fit_io_nosidecar", /*write_sidecar=*/false);
  try {
    fit::LoadReference(f.exr);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("ref.json"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(fit::LoadReference(f.exr, f.toml));  // --scene instead.
}

TEST(LoadReferenceTest, MissingSceneAndSizeMismatch) {
  const Files f = MakeReferenceFiles("fit_io_badscene");
  std::ofstream(f.json) << R"({"scene_file": "scenes/nope.toml"})";
  try {
    fit::LoadReference(f.exr);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("scene_file"), std::string::npos) << e.what();
  }
  std::ofstream(f.dir + "/big.toml")
      << testing::CameraToml("[0.0, -6.0, 0.0]", 22.0, 64) << testing::kSphere;
  try {
    fit::LoadReference(f.exr, f.dir + "/big.toml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("resolution"), std::string::npos) << e.what();
  }
}

int RunCli(std::vector<std::string> args) {
  CLI::App app{"shadefit"};
  cli::RegisterFitCommand(app);
  args.insert(args.begin(), "shadefit");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  try {
    app.parse(static_cast<int>(argv.size()), argv.data());
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "shadefit: error: %s\n", e.what());
    return 1;
  }
  return 0;
}

// Hidden temporaries of the atomic writers ("<dir>/.<name>.<pid>.<n>.tmp", base/files.h) or any
// other ".tmp" left in a folder.
std::vector<std::string> LeftoverTemporaries(const std::string& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.ends_with(".tmp") || name.find(".tmp.") != std::string::npos) out.push_back(name);
  }
  return out;
}

// sRGB encoding (IEC 61966-2-1): 12.92 x below 0.0031308, else 1.055 x^(1/2.4) - 0.055.
double Srgb(double x) { return x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1 / 2.4) - 0.055; }

TEST(FitCommandTest, WritesJsonAndImages) {
  const Files f = MakeReferenceFiles("fit_io_cli");
  const std::string out = f.dir + "/out/fit.json";
  fs::remove_all(f.dir + "/out");
  ASSERT_EQ(RunCli({"fit", "--ref", f.exr, "--model", "ggx", "--starts", "2", "-o", out}), 0);
  std::ifstream in(out);
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["model"], "ggx");
  EXPECT_EQ(j["derivative_path"], "gbuffer");
  EXPECT_TRUE(j["converged"].get<bool>());
  EXPECT_NEAR(j["values"]["roughness"].get<double>(), 0.3, 0.006);
  EXPECT_EQ(j["inputs"]["hash"], "sha256");
  EXPECT_EQ(j["inputs"]["references"][0]["image"]["sha256"], fit::Sha256File(f.exr));
  EXPECT_EQ(j["starts"]["count"], 2);
  for (const char* suffix : {".fit.exr", ".error.exr", ".error.png"}) {
    EXPECT_TRUE(fs::exists(f.dir + "/out/fit.ref" + suffix)) << suffix;
  }
  const std::vector<std::string> left = LeftoverTemporaries(f.dir + "/out");
  EXPECT_TRUE(left.empty()) << left.front();
}

// A model that cannot reproduce the reference (Lambert on a GGX render), so the fit and error
// images have content: the fitted image is a render at the fitted values, the error image is
// |fit - reference| on exactly the fitted pixels, its RMSE is the JSON's, and the preview is the
// error over its 99th percentile, sRGB-encoded. No temporary is left beside them.
TEST(FitCommandTest, ImagesHoldFitAndError) {
  const Files f = MakeReferenceFiles("fit_io_cli_images");
  const std::string out_dir = f.dir + "/out";
  fs::remove_all(out_dir);
  ASSERT_EQ(RunCli({"fit", "--ref", f.exr, "--model", "lambert", "-o", out_dir + "/fit.json"}), 0);
  std::ifstream in(out_dir + "/fit.json");
  const nlohmann::json j = nlohmann::json::parse(in);

  // Parameters in the table's order, from the JSON's values.
  const ModelInfo& info = FindModel("lambert");
  std::vector<double> params;
  for (const ParamSpec& p : info.params) {
    const nlohmann::json& v = j["values"][p.name];
    if (p.size == 1) {
      params.push_back(v.get<double>());
    } else {
      for (int c = 0; c < 3; ++c) params.push_back(v[c].get<double>());
    }
  }
  const double exposure = j["exposure"]["value"].get<double>();
  const Image render =
      testing::SharedRenderer().Render(LoadScene(f.toml), info.id, params);
  const Image ref = ReadImage(f.exr);
  const Image fit = ReadImage(out_dir + "/fit.ref.fit.exr");
  const Image err = ReadImage(out_dir + "/fit.ref.error.exr");
  const Image png = ReadImage(out_dir + "/fit.ref.error.png");
  ASSERT_EQ(fit.PixelCount(), ref.PixelCount());
  ASSERT_EQ(err.PixelCount(), ref.PixelCount());
  ASSERT_EQ(png.PixelCount(), ref.PixelCount());
  ASSERT_EQ(err.channels, 4);
  ASSERT_GE(png.channels, 3);

  double sq = 0, fit_vs_ref = 0;
  long fitted = 0;
  std::vector<double> errors;
  for (std::size_t p = 0; p < ref.PixelCount(); ++p) {
    for (int c = 0; c < 3; ++c) {
      const double expected = exposure * render.data[p * render.channels + c];
      EXPECT_NEAR(fit.data[p * fit.channels + c], expected, 1e-6 + 1e-6 * std::abs(expected))
          << "fit pixel " << p << " channel " << c;
    }
    const float alpha = err.data[p * 4 + 3];
    ASSERT_TRUE(alpha == 0.0f || alpha == 1.0f) << "error alpha " << alpha << " at " << p;
    for (int c = 0; c < 3; ++c) {
      const double d = fit.data[p * fit.channels + c] - ref.data[p * ref.channels + c];
      if (alpha == 1.0f) {
        EXPECT_NEAR(err.data[p * 4 + c], std::abs(d), 1e-6) << "error pixel " << p;
        sq += d * d;
        fit_vs_ref = std::max(fit_vs_ref, std::abs(d));
        errors.push_back(std::abs(d));
      } else {
        EXPECT_EQ(err.data[p * 4 + c], 0.0f) << "unfitted pixel " << p;
      }
    }
    fitted += alpha == 1.0f;
  }
  const nlohmann::json& per_ref = j["rmse"]["per_reference"][0];
  EXPECT_EQ(fitted, per_ref["pixels"].get<long>());
  const double rmse = std::sqrt(sq / (3.0 * fitted));
  std::printf("lambert on ggx: %ld fitted pixels, RMSE %.5g (JSON %.5g), max |error| %.4g\n",
              fitted, rmse, per_ref["rmse"].get<double>(), fit_vs_ref);
  EXPECT_GT(rmse, 1e-3);  // a real misfit: the highlight
  EXPECT_NEAR(rmse, per_ref["rmse"].get<double>(), 1e-3 * rmse);

  // Preview: min(1, sRGB(error / p99)), p99 = the 99th percentile of the fitted pixels' errors.
  std::vector<double> sorted = errors;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() * 99 / 100, sorted.end());
  const double p99 = sorted[sorted.size() * 99 / 100];
  ASSERT_GT(p99, 0);
  int white = 0;
  for (std::size_t p = 0; p < png.PixelCount(); ++p) {
    for (int c = 0; c < 3; ++c) {
      const double expected = std::min(1.0, Srgb(err.data[p * 4 + c] / p99));
      EXPECT_NEAR(png.data[p * png.channels + c], expected, 0.5 / 255 + 1e-4)
          << "preview pixel " << p << " channel " << c;
      white += png.data[p * png.channels + c] == 1.0f;
    }
  }
  EXPECT_GT(white, 0);

  // Exactly the four outputs, no temporary.
  EXPECT_TRUE(LeftoverTemporaries(out_dir).empty());
  int files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(out_dir)) ++files;
  EXPECT_EQ(files, 4);
}

TEST(FitCommandTest, BadInputWritesNothing) {
  const Files f = MakeReferenceFiles("fit_io_cli_bad");
  const std::string out = f.dir + "/bad/fit.json";
  fs::remove_all(f.dir + "/bad");
  // All-masked reference: a PNG mask of zeros.
  Image mask(48, 48, 3, 0.0f);
  WritePng8(f.dir + "/mask.png", mask);
  EXPECT_EQ(RunCli({"fit", "--ref", f.exr, "--mask", f.dir + "/mask.png", "--model", "ggx",
                    "-o", out}),
            1);
  EXPECT_EQ(RunCli({"fit", "--ref", f.exr, "--model", "nope", "-o", out}), 1);
  EXPECT_EQ(RunCli({"fit", "--ref", f.exr, "--model", "ggx", "--loss", "l3", "-o", out}), 1);
  EXPECT_FALSE(fs::exists(f.dir + "/bad"));
}

// The EGL context is made on a helper thread while the references are read (fit_command.cpp):
// a bad reference is still the error reported when the context fails too, and a context that
// fails is reported as itself, with nothing written either way.
TEST(FitCommandTest, ContextMadeAlongsideTheReferencesKeepsTheErrorOrder) {
  const Files f = MakeReferenceFiles("fit_io_cli_context");
  const std::string out = f.dir + "/ctx/fit.json";
  fs::remove_all(f.dir + "/ctx");
  ASSERT_EQ(setenv("SHADEFIT_EGL_DEVICE", "no-such-device", 1), 0);
  ::testing::internal::CaptureStderr();
  const int missing_rc =
      RunCli({"fit", "--ref", f.dir + "/missing.exr", "--model", "ggx", "-o", out});
  const std::string missing_err = ::testing::internal::GetCapturedStderr();
  ::testing::internal::CaptureStderr();
  const int device_rc = RunCli({"fit", "--ref", f.exr, "--model", "ggx", "-o", out});
  const std::string device_err = ::testing::internal::GetCapturedStderr();
  unsetenv("SHADEFIT_EGL_DEVICE");
  EXPECT_EQ(missing_rc, 1);
  EXPECT_NE(missing_err.find("missing.exr"), std::string::npos) << missing_err;
  EXPECT_EQ(missing_err.find("SHADEFIT_EGL_DEVICE"), std::string::npos) << missing_err;
  EXPECT_EQ(device_rc, 1);
  EXPECT_NE(device_err.find("SHADEFIT_EGL_DEVICE"), std::string::npos) << device_err;
  EXPECT_FALSE(fs::exists(f.dir + "/ctx"));
  // And the context the helper made is usable on this thread: the same fit now succeeds.
  ASSERT_EQ(RunCli({"fit", "--ref", f.exr, "--model", "ggx", "--no-images", "-o", out}), 0);
  EXPECT_TRUE(fs::exists(out));
}

TEST(FitCommandTest, NonConvergedFitSaysSo) {
  const Files f = MakeReferenceFiles("fit_io_cli_nc");
  const std::string out = f.dir + "/nc/fit.json";
  ::testing::internal::CaptureStderr();
  const int rc = RunCli({"fit", "--ref", f.exr, "--model", "ggx", "--max-iterations", "1",
                         "--no-images", "-o", out});
  const std::string err = ::testing::internal::GetCapturedStderr();
  ASSERT_EQ(rc, 0) << err;
  EXPECT_NE(err.find("did not converge"), std::string::npos) << err;
  std::ifstream in(out);
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_FALSE(j["converged"].get<bool>());
}

}  // namespace
}  // namespace shadefit
