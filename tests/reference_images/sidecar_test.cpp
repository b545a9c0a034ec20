// The sidecar schema's readers (reference_images/src/sidecar.cpp): the scene a sidecar names and
// the one mapping of a Cycles material to the model that is its exact twin.
#include "shadefit/reference_images/sidecar.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "shadefit/render/models.h"

namespace shadefit::reference_images {
namespace {
namespace fs = std::filesystem;

std::string Shipped(const std::string& stem) {
  return std::string(SHADEFIT_SOURCE_DIR) + "/reference_images/cycles/" + stem + ".json";
}

// A sidecar with only `material`, in the build tree's test_output.
std::string WriteSidecar(const std::string& name, const std::string& material_json) {
  const fs::path dir = fs::path(SHADEFIT_TEST_OUTPUT) / "sidecar_test";
  fs::create_directories(dir);
  const fs::path p = dir / (name + ".json");
  std::ofstream(p) << "{\"scene_file\": \"scenes/x.toml\", \"material\": " << material_json << "}";
  return p.string();
}

TEST(SidecarTest, PathAndSceneOfShippedReference) {
  const std::string sidecar = Shipped("gold-key");
  if (!fs::exists(sidecar)) GTEST_SKIP() << "shipped references not present";
  EXPECT_EQ(
      SidecarPathFor(std::string(SHADEFIT_SOURCE_DIR) + "/reference_images/cycles/gold-key.exr"),
      sidecar);
  EXPECT_EQ(fs::path(SceneOfSidecar(sidecar)),
            (fs::path(sidecar).parent_path() / "scenes" / "sphere-key.toml").lexically_normal());
  EXPECT_EQ(SceneOfSidecar(""), "");
  EXPECT_EQ(SceneOfSidecar("/nonexistent/x.json"), "");
}

TEST(SidecarTest, PrincipledGgxIsCyclesPrincipledByName) {
  const std::string sidecar = Shipped("gold-key");
  if (!fs::exists(sidecar)) GTEST_SKIP() << "shipped references not present";
  const auto truth = TruthOfSidecar(sidecar);
  ASSERT_TRUE(truth.has_value());
  EXPECT_EQ(truth->model->name, "cycles-principled");
  // gold-key.json: base_color (1, 0.766, 0.336), metallic 1, specular 0.5, roughness 0.25; set
  // by name, so the vector follows the model's parameter table.
  const ModelInfo& info = FindModel("cycles-principled");
  std::vector<double> want = DefaultParams(info);
  SetParam(info, "base_color", {1.0, 0.766, 0.336}, "test", &want);
  SetParam(info, "metallic", {1.0}, "test", &want);
  SetParam(info, "specular", {0.5}, "test", &want);
  SetParam(info, "roughness", {0.25}, "test", &want);
  EXPECT_EQ(truth->params, want);
}

TEST(SidecarTest, DiffuseIsLambert) {
  const std::string sidecar = Shipped("white-lambert-key");
  if (!fs::exists(sidecar)) GTEST_SKIP() << "shipped references not present";
  const auto truth = TruthOfSidecar(sidecar);
  ASSERT_TRUE(truth.has_value());
  EXPECT_EQ(truth->model->name, "lambert");
  EXPECT_EQ(truth->params.size(), 3u);
}

TEST(SidecarTest, RoughnessZeroIsRaisedToTheTableMinimum) {
  const auto truth = TruthOfSidecar(WriteSidecar(
      "mirror", R"({"type": "principled", "base_color": [0.9, 0.9, 0.9], "roughness": 0.0})"));
  ASSERT_TRUE(truth.has_value());
  const ModelInfo& info = FindModel("cycles-principled");
  std::vector<double> want = DefaultParams(info);
  SetParam(info, "base_color", {0.9, 0.9, 0.9}, "test", &want);
  SetParam(info, "roughness", {0.01}, "test", &want);
  EXPECT_EQ(truth->params, want);
}

TEST(SidecarTest, NoExactTwinSaysWhy) {
  std::string why;
  EXPECT_FALSE(TruthOfSidecar(WriteSidecar("multi", R"({"type": "principled",
      "distribution": "MULTI_GGX", "base_color": [0.9, 0.9, 0.9]})"),
                              &why));
  EXPECT_NE(why.find("MULTI_GGX"), std::string::npos) << why;
  EXPECT_FALSE(TruthOfSidecar(WriteSidecar("oren-nayar", R"({"type": "diffuse",
      "roughness": 0.5, "base_color": [0.5, 0.5, 0.5]})"),
                              &why));
  EXPECT_NE(why.find("Oren-Nayar"), std::string::npos) << why;
  EXPECT_FALSE(TruthOfSidecar(WriteSidecar("glass", R"({"type": "glass"})"), &why));
  EXPECT_NE(why.find("glass"), std::string::npos) << why;
  EXPECT_FALSE(TruthOfSidecar(WriteSidecar("no-colour", R"({"type": "diffuse"})"), &why));
  EXPECT_FALSE(TruthOfSidecar("/nonexistent/x.json", &why));
  EXPECT_FALSE(TruthOfSidecar(""));
}

}  // namespace
}  // namespace shadefit::reference_images
