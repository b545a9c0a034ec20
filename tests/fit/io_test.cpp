// Reading references (sidecar -> scene), provenance hashes, output files, and the `fit`
// subcommand end to end, including "bad input -> one-line error and no output file".
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "commands.h"
#include "fit_test_util.h"
#include "shadefit/render/error.h"

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
  EXPECT_FALSE(fs::exists(out + ".tmp"));
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
