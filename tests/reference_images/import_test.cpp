// Import of photographed / published images: counts on a JPEG made from a Cycles reference,
// sphere and light detection on a synthetic orthographic render, and one test per bad input.
#include "shadefit/reference_images/import.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <vector>

#include "reference_images_test_util.h"
#include "shadefit/reference_images/render_measured.h"
#include "shadefit/base/error.h"
#include "shadefit/render/models.h"
#include "test_util.h"

namespace shadefit::reference_images {
namespace {

namespace fs = std::filesystem;

Renderer& GlRenderer() { return shadefit::testing::SharedRenderer(); }

// Writes an 8-bit file (PNG, JPEG by extension) of values in [0, 1], already encoded.
void WriteEncoded8(const std::string& path, const Image& img, int jpeg_quality = 95) {
  std::vector<unsigned char> bytes(img.data.size());
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    bytes[i] = static_cast<unsigned char>(std::lround(std::clamp(img.data[i], 0.0f, 1.0f) * 255));
  }
  OIIO::ImageSpec spec(img.width, img.height, img.channels, OIIO::TypeDesc::UINT8);
  spec.attribute("compression", "jpeg:" + std::to_string(jpeg_quality));
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out && out->open(path, spec) &&
              out->write_image(OIIO::TypeDesc::UINT8, bytes.data()) && out->close());
}

void WriteFloatExr(const std::string& path, const Image& img) {
  OIIO::ImageSpec spec(img.width, img.height, img.channels, OIIO::TypeDesc::FLOAT);
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out && out->open(path, spec) &&
              out->write_image(OIIO::TypeDesc::FLOAT, img.data.data()) && out->close());
}

nlohmann::json ReadJson(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

// --- A JPEG made from a shipped Cycles reference ------------------------------------------------

TEST(ImportTest, CyclesJpegWithOtherExposureAndClippedHighlights) {
  const fs::path cycles = fs::path(SHADEFIT_SOURCE_DIR) / "reference_images/cycles";
  const std::string exr = (cycles / "gold-key.exr").string();
  const std::string scene = (cycles / "scenes/sphere-key.toml").string();
  if (!fs::exists(exr) || !fs::exists(scene)) {
    GTEST_SKIP() << "reference_images/cycles/gold-key.exr absent, because the Cycles references "
                    "are rendered by `shadefit refs cycles` (Blender) and may not be shipped";
  }
  const Image ref = ReadImage(exr);
  // Two stops brighter than the reference... a "photograph" with another exposure: x 2, sRGB,
  // 8 bits, JPEG quality 95. The highlight (radiance up to ~65) clips.
  constexpr double kExposure = 2.0;
  Image encoded(ref.width, ref.height, 3);
  for (std::size_t i = 0; i < ref.PixelCount(); ++i) {
    for (int c = 0; c < 3; ++c) {
      encoded.data[3 * i + c] = SrgbOetf(static_cast<float>(kExposure * ref.data[4 * i + c]));
    }
  }
  const std::string dir = testing::OutputDir();
  const std::string jpg = dir + "/gold-key-photo.jpg";
  WriteEncoded8(jpg, encoded);

  // Count the clipped pixels from the same 8-bit data the importer will see.
  const Image decoded = ReadImage(jpg);
  ASSERT_EQ(decoded.channels, 3);
  long long clipped = 0, clipped_right_half = 0;
  for (int y = 0; y < decoded.height; ++y) {
    for (int x = 0; x < decoded.width; ++x) {
      bool clip = false;
      for (int c = 0; c < 3; ++c) clip |= std::lround(decoded.at(x, y, c) * 255) >= 254;
      clipped += clip;
      clipped_right_half += clip && x >= decoded.width / 2;
    }
  }
  std::printf("JPEG: %lld clipped pixels (%lld in the right half)\n", clipped, clipped_right_half);
  ASSERT_GT(clipped, 20);
  ASSERT_LT(clipped, 3000);

  ImportOptions opt;
  opt.image_path = jpg;
  opt.scene_path = scene;
  opt.output = dir + "/gold-key-photo.exr";
  const ImportResult r = ImportReference(opt, GlRenderer());
  EXPECT_EQ(r.encoding, Encoding::kSrgb);
  EXPECT_EQ(r.counts.total, 256 * 256);
  EXPECT_EQ(r.counts.masked_out, 0);
  EXPECT_EQ(r.counts.clipped, clipped);
  EXPECT_EQ(r.counts.valid, 256 * 256 - clipped);
  const nlohmann::json side = ReadJson(SidecarPath(opt.output));
  EXPECT_EQ(side["counts"]["clipped"], clipped);
  EXPECT_EQ(side["exposure"], "unknown");
  EXPECT_EQ(side["encoding"], "srgb");
  EXPECT_EQ(side["source"]["sha256"].get<std::string>().size(), 64u);

  // The imported values are the reference times the exposure (up to JPEG error), and alpha is
  // zero exactly on the clipped pixels and off the sphere.
  const Image out = ReadImage(opt.output);
  std::vector<double> ratio;
  long long alpha_zero_on_sphere = 0;
  for (std::size_t i = 0; i < out.PixelCount(); ++i) {
    const double a = out.data[4 * i + 3];
    if (ref.data[4 * i + 3] > 0.999 && a == 0) ++alpha_zero_on_sphere;
    const double want = kExposure * ref.data[4 * i + 1];
    if (a > 0.999 && want > 0.05 && want < 0.9) ratio.push_back(out.data[4 * i + 1] / want);
  }
  std::sort(ratio.begin(), ratio.end());
  std::printf("imported / (2 x reference): median %.4f over %zu pixels\n", ratio[ratio.size() / 2],
              ratio.size());
  EXPECT_NEAR(ratio[ratio.size() / 2], 1.0, 0.02);
  EXPECT_EQ(alpha_zero_on_sphere, clipped);  // the highlight lies well inside the disc

  // With a mask hiding the left half, those pixels count as masked out and the clipped ones are
  // counted among the rest.
  Image mask(256, 256, 1, 0.0f);
  for (int y = 0; y < 256; ++y) {
    for (int x = 128; x < 256; ++x) mask.at(x, y, 0) = 1.0f;
  }
  opt.mask_path = dir + "/right-half.png";
  WritePng8(opt.mask_path, mask);
  opt.output = dir + "/gold-key-photo-masked.exr";
  const ImportResult m = ImportReference(opt, GlRenderer());
  EXPECT_EQ(m.counts.masked_out, 128 * 256);
  EXPECT_EQ(m.counts.clipped, clipped_right_half);
  EXPECT_EQ(m.counts.valid, 128 * 256 - clipped_right_half);
}

// --- Auto-sphere on a synthetic orthographic render -------------------------------------------

TEST(ImportTest, AutoSphereFindsDiscAndLight) {
  // 200 x 160 px, 60 px per world unit, sphere centre off the image centre.
  constexpr int kW = 200, kH = 160;
  constexpr double kR = 60.0, kOx = 0.3, kOz = -0.2;
  const Vec3d to_light = Normalize(Vec3d{0.35, -1.0, 0.45});
  const std::string toml = fmt::format(
      "[camera]\ntype = \"orthographic\"\nposition = [{0}, -10.0, {1}]\n"
      "look_at = [{0}, 0.0, {1}]\nup = [0.0, 0.0, 1.0]\nheight = {2}\nresolution = [{3}, {4}]\n"
      "supersample = 4\n[[objects]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\n"
      "radius = 1.0\n[[lights]]\ntype = \"directional\"\ndirection = [{5}, {6}, {7}]\n"
      "irradiance = 3.0\n",
      kOx, kOz, kH / kR, kW, kH, -to_light.x, -to_light.y, -to_light.z);
  const Scene scene = ParseScene(toml, "ortho.toml");
  const ModelInfo& ggx = GetModel(ModelId::kGgx);
  std::vector<double> p = DefaultParams(ggx);
  SetParam(ggx, "kd", {0.5, 0.4, 0.3}, "test", &p);
  SetParam(ggx, "f0", {0.04}, "test", &p);
  SetParam(ggx, "roughness", {0.2}, "test", &p);
  const Image render = GlRenderer().Render(scene, ModelId::kGgx, p);
  const double expected_cx = kW / 2.0 - kOx * kR, expected_cy = kH / 2.0 + kOz * kR;

  // 8-bit sRGB PNG with the highlight clipped, as a photograph would be.
  Image encoded(kW, kH, 3);
  for (std::size_t i = 0; i < render.PixelCount(); ++i) {
    for (int c = 0; c < 3; ++c) {
      encoded.data[3 * i + c] = SrgbOetf(1.5f * render.data[4 * i + c]);
    }
  }
  const std::string dir = testing::OutputDir();
  const std::string png = dir + "/ortho-sphere.png";
  WriteEncoded8(png, encoded);
  ImportOptions opt;
  opt.image_path = png;
  opt.auto_sphere = true;
  opt.output = dir + "/ortho-sphere.exr";
  const ImportResult r = ImportReference(opt, GlRenderer());
  ASSERT_TRUE(r.has_sphere);
  const SphereEstimate& s = r.sphere;
  const double angle_deg =
      std::acos(std::clamp(Dot(s.light_direction, to_light), -1.0, 1.0)) * 180.0 / kPi;
  std::printf(
      "sphere: centre (%.3f, %.3f) vs (%.3f, %.3f), radius %.3f vs %.3f, fit rms %.3f "
      "px over %d points; light %.2f deg off (highlight at %.2f, %.2f)\n",
      s.center_x, s.center_y, expected_cx, expected_cy, s.radius, kR, s.fit_rms_px,
      s.contour_points_used, angle_deg, s.highlight_x, s.highlight_y);
  EXPECT_NEAR(s.center_x, expected_cx, 1.0);
  EXPECT_NEAR(s.center_y, expected_cy, 1.0);
  EXPECT_NEAR(s.radius, kR, 1.0);
  EXPECT_LT(angle_deg, 3.0);

  // The written scene parses, frames the sphere where the picture has it, and holds the light.
  ASSERT_TRUE(fs::exists(r.scene_path));
  const Scene written = LoadScene(r.scene_path);
  EXPECT_EQ(written.camera.type, Camera::Type::kOrthographic);
  ASSERT_EQ(written.lights.size(), 1u);
  EXPECT_NEAR(Dot(written.lights[0].direction, to_light), -1.0, 1e-2);
  const GBuffer g = GlRenderer().RenderGBuffer(written);
  const GBuffer truth = GlRenderer().RenderGBuffer(scene);
  long long differ = 0, covered = 0;
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      covered += truth.Hit(x, y);
      differ += g.Hit(x, y) != truth.Hit(x, y);
    }
  }
  double mx = 0, my = 0;
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      if (truth.Hit(x, y)) {
        mx += x + 0.5;
        my += y + 0.5;
      }
    }
  }
  std::printf(
      "coverage: %lld pixels differ of %lld on the sphere; true disc centroid (%.3f, "
      "%.3f), radius from area %.3f\n",
      differ, covered, mx / covered, my / covered, std::sqrt(covered / kPi));
  EXPECT_LT(differ, 0.02 * covered);  // a 1 px ring is 2 pi r / (pi r^2) = 3.3% at r = 60
  const nlohmann::json side = ReadJson(SidecarPath(opt.output));
  EXPECT_NEAR(side["auto_sphere"]["radius_px"].get<double>(), s.radius, 1e-9);
}

TEST(ImportTest, DetectSphereOnAHalfLitSphere) {
  // Light from the side (90 degrees from the view): only half of the disc is lit.
  const std::string toml =
      "[camera]\ntype = \"orthographic\"\nposition = [0.0, -10.0, 0.0]\n"
      "look_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nheight = 3.2\nresolution = [160, 160]\n"
      "[[objects]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n"
      "[[lights]]\ntype = \"directional\"\ndirection = [-1.0, 0.0, 0.0]\nirradiance = 3.0\n";
  const Scene scene = ParseScene(toml, "side.toml");
  const Image render =
      GlRenderer().Render(scene, ModelId::kLambert, DefaultParams(GetModel(ModelId::kLambert)));
  const SphereEstimate s = DetectSphere(render.Channels(0, 3), 1.0, "side.exr");
  std::printf("half-lit: centre (%.3f, %.3f), radius %.3f (truth 80, 80, 50)\n", s.center_x,
              s.center_y, s.radius);
  EXPECT_NEAR(s.center_x, 80.0, 1.5);
  EXPECT_NEAR(s.center_y, 80.0, 1.5);
  EXPECT_NEAR(s.radius, 50.0, 1.5);
}

// --- Bad input: one-line error naming the file and the field, and no output file. -------------

class BadImportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // One folder per test: ctest may run the tests of this fixture in parallel processes.
    dir_ = testing::OutputDir() + "/bad-input/" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name();
    fs::create_directories(dir_);
    scene_ = dir_ + "/scene.toml";
    std::ofstream(scene_) << shadefit::testing::SphereSceneToml(
        32, 32, "[[lights]]\ntype = \"point\"\nposition = [0.0, -5.0, 0.0]\npower = 100.0\n");
    Image grey(32, 32, 3, 0.5f);
    good_png_ = dir_ + "/good.png";
    WritePng8(good_png_, grey);
  }

  // Runs the import of `image` and checks the error and that nothing was written.
  void ExpectImportError(const std::string& image, const std::string& named_file,
                         const std::string& field, const std::string& mask = "") {
    ImportOptions opt;
    opt.image_path = image;
    opt.scene_path = scene_;
    opt.mask_path = mask;
    opt.output =
        dir_ + "/out-" + ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".exr";
    fs::remove(opt.output);
    fs::remove(SidecarPath(opt.output));
    try {
      ImportReference(opt, GlRenderer());
      ADD_FAILURE() << "no error for " << image;
    } catch (const Error& e) {
      const std::string what = e.what();
      std::printf("error: %s\n", what.c_str());
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
      EXPECT_EQ(what.rfind(named_file + ": " + field + ": ", 0), 0u) << what;
    }
    EXPECT_FALSE(fs::exists(opt.output));
    EXPECT_FALSE(fs::exists(SidecarPath(opt.output)));
    for (const auto& entry : fs::directory_iterator(dir_)) {
      EXPECT_EQ(entry.path().filename().string().find(".out-"), std::string::npos)
          << "temporary file left: " << entry.path();
    }
  }

  // A copy of `from` cut to `fraction` of its bytes.
  std::string Truncated(const std::string& from, const std::string& name, double fraction) {
    std::ifstream in(from, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string path = dir_ + "/" + name;
    std::ofstream(path, std::ios::binary | std::ios::trunc)
        << bytes.substr(0, static_cast<std::size_t>(bytes.size() * fraction));
    return path;
  }

  // A 32 x 32 image with varied content (compresses poorly, so truncation cuts pixel data).
  Image Noise(int channels) {
    Image img(32, 32, channels);
    unsigned state = 12345;
    for (float& v : img.data) {
      state = state * 1664525u + 1013904223u;
      v = static_cast<float>((state >> 8) & 0xFF) / 255.0f;
    }
    return img;
  }

  std::string dir_, scene_, good_png_;
};

TEST_F(BadImportTest, MissingFile) {
  const std::string path = dir_ + "/does-not-exist.png";
  ExpectImportError(path, path, "image");
}

TEST_F(BadImportTest, TruncatedExr) {
  const std::string full = dir_ + "/full.exr";
  WriteFloatExr(full, Noise(3));
  ExpectImportError(Truncated(full, "cut.exr", 0.5), dir_ + "/cut.exr", "pixels");
}

TEST_F(BadImportTest, TruncatedPng) {
  const std::string full = dir_ + "/full.png";
  WritePng8(full, Noise(3));
  ExpectImportError(Truncated(full, "cut.png", 0.6), dir_ + "/cut.png", "pixels");
}

TEST_F(BadImportTest, TruncatedJpeg) {
  const std::string full = dir_ + "/full.jpg";
  WriteEncoded8(full, Noise(3));
  ExpectImportError(Truncated(full, "cut.jpg", 0.6), dir_ + "/cut.jpg", "pixels");
}

TEST_F(BadImportTest, NanPixels) {
  Image img(32, 32, 3, 0.25f);
  img.at(7, 9, 1) = std::numeric_limits<float>::quiet_NaN();
  const std::string path = dir_ + "/nan.exr";
  WriteFloatExr(path, img);
  ExpectImportError(path, path, "pixels");
}

TEST_F(BadImportTest, InfPixels) {
  Image img(32, 32, 3, 0.25f);
  img.at(3, 4, 0) = std::numeric_limits<float>::infinity();
  const std::string path = dir_ + "/inf.exr";
  WriteFloatExr(path, img);
  ExpectImportError(path, path, "pixels");
}

TEST_F(BadImportTest, TwoChannels) {
  const std::string path = dir_ + "/two-channels.exr";
  WriteFloatExr(path, Image(32, 32, 2, 0.5f));
  ExpectImportError(path, path, "channels");
}

TEST_F(BadImportTest, MaskSizeMismatch) {
  const std::string mask = dir_ + "/mask-16.png";
  WritePng8(mask, Image(16, 16, 1, 1.0f));
  ExpectImportError(good_png_, mask, "resolution", mask);
}

TEST_F(BadImportTest, ImageSizeDiffersFromTheScene) {
  const std::string path = dir_ + "/small.png";
  WritePng8(path, Image(20, 32, 3, 0.5f));
  ExpectImportError(path, path, "resolution");
}

TEST_F(BadImportTest, GoodInputImports) {
  // The fixture's inputs are otherwise fine: the errors above come from the one defect each.
  ImportOptions opt;
  opt.image_path = good_png_;
  opt.scene_path = scene_;
  opt.output = dir_ + "/good.exr";
  const ImportResult r = ImportReference(opt, GlRenderer());
  EXPECT_EQ(r.counts.total, 32 * 32);
  EXPECT_TRUE(fs::exists(opt.output));
}

}  // namespace
}  // namespace shadefit::reference_images
