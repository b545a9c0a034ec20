// The combined report, its JSON, and the false-colour maps.
#include "shadefit/metrics/report.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "shadefit/base/error.h"
#include "shadefit/metrics/false_color.h"
#include "test_images.h"

namespace shadefit::metrics {
namespace {

namespace fs = std::filesystem;

TEST(ReportTest, IdenticalImages) {
  const Image a = testing::HdrScene(64, 64);
  const MetricsReport r = ComputeMetrics(a, a, nullptr);
  EXPECT_EQ(r.rmse, 0.0);
  EXPECT_EQ(r.mae, 0.0);
  EXPECT_TRUE(std::isinf(r.psnr));
  EXPECT_NEAR(r.ssim_luminance.mean, 1.0, 1e-12);
  EXPECT_NEAR(r.ssim_rgb.mean, 1.0, 1e-12);
  EXPECT_NEAR(r.ms_ssim.value, 1.0, 1e-12);
  EXPECT_EQ(r.ciede2000.mean, 0.0);
  EXPECT_EQ(r.delta_e_itp.mean, 0.0);
  EXPECT_EQ(r.flip_ldr.mean, 0.0);
  EXPECT_EQ(r.flip_hdr.mean, 0.0);
  const nlohmann::json j = MetricsToJson(r);
  EXPECT_TRUE(j["display"]["psnr_db"].is_null());  // +inf has no JSON number.
}

TEST(ReportTest, JsonHasEveryDocumentedField) {
  const Image a = testing::HdrScene(64, 64);
  const Image b = testing::HdrDistorted(a, 0.1f, 2);
  Image mask(64, 64, 1, 1.0f);
  mask.at(0, 0, 0) = 0.0f;
  MetricsMaps maps;
  const MetricsReport r = ComputeMetrics(a, b, &mask, {}, &maps);
  EXPECT_EQ(r.valid_pixels, 64u * 64u - 1u);
  const nlohmann::json j = MetricsToJson(r);
  EXPECT_EQ(j["schema"], "shadefit.metrics/1");
  for (const char* key : {"width", "height", "masked", "valid_pixels", "parameters", "linear",
                          "display", "ciede2000", "delta_e_itp", "flip_ldr", "flip_hdr"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  for (const char* key : {"mean", "p95", "max"}) {
    EXPECT_GT(j["delta_e_itp"][key].get<double>(), 0.0) << key;
  }
  EXPECT_EQ(j["parameters"]["itp_white_luminance"].get<double>(), 100.0);
  for (const char* key : {"rmse", "relative_rmse", "log_rmse", "mae"}) {
    EXPECT_GT(j["linear"][key].get<double>(), 0.0) << key;
  }
  for (const char* key :
       {"psnr_db", "ssim_luminance", "ssim_rgb", "ssim_pooled_pixels", "ms_ssim"}) {
    EXPECT_TRUE(j["display"].contains(key)) << key;
  }
  for (const char* key :
       {"mean", "median", "p95", "p99", "max", "weighted_median", "weighted_q1", "weighted_q3",
        "histogram", "start_exposure", "stop_exposure", "num_exposures"}) {
    EXPECT_TRUE(j["flip_hdr"].contains(key)) << key;
  }
  EXPECT_TRUE(std::isnan(maps.absolute_error.at(0, 0, 0)));

  const fs::path dir = fs::path(SHADEFIT_TEST_OUTPUT) / "metrics_maps";
  fs::create_directories(dir);
  WriteMetricMaps(maps, dir.string());
  for (const char* name : {"abs_error.png", "rel_error.png", "ciede2000.png", "delta_e_itp.png",
                           "ssim.png", "flip_ldr.png", "flip_hdr.png"}) {
    const Image png = ReadImage((dir / name).string());
    EXPECT_EQ(png.height, 64) << name;
    EXPECT_GT(png.width, 64 + 16) << name;  // Map plus the colour bar strip.
  }
}

TEST(ReportTest, ErrorsNameTheFile) {
  const Image a(32, 32, 3, 0.5f), b(16, 32, 3, 0.5f);
  MetricsParameters p;
  p.names = {"ref.exr", "test.exr", "m.png"};
  try {
    ComputeMetrics(a, b, nullptr, p);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(),
                 "test.exr: resolution: 16x32 differs from the reference's 32x32 (ref.exr)");
  }
  const Image empty(32, 32, 1, 0.0f);
  try {
    ComputeMetrics(a, a, &empty, p);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "m.png: pixels: empty mask (no pixel > 0.5)");
  }
}

TEST(FalseColorTest, EndsOfTheScaleAndNan) {
  Image map(3, 1, 1);
  map.data = {0.0f, 1.0f, std::nanf("")};
  FalseColorParameters p;
  p.color_bar = false;
  p.min = 0.0;
  p.max = 1.0;
  const Image rgb = FalseColor(map, p);
  ASSERT_EQ(rgb.width, 3);
  // viridis starts dark purple (0.267, 0.005, 0.329) and ends yellow (0.993, 0.906, 0.144).
  EXPECT_NEAR(rgb.at(0, 0, 0), 0.267004f, 1e-6f);
  EXPECT_NEAR(rgb.at(1, 0, 1), 0.906157f, 1e-6f);
  EXPECT_NEAR(rgb.at(2, 0, 0), 0.5f, 1e-6f);
  p.color_map = ColorMap::kMagma;
  EXPECT_NEAR(FalseColor(map, p).at(0, 0, 2), 0.013866f, 1e-6f);  // magma's first entry.
}

TEST(FalseColorTest, ColorBarRunsFromMaxAtTopToMinAtBottom) {
  Image map(40, 40, 1, 0.5f);
  const Image rgb = FalseColor(map, {});
  ASSERT_GT(rgb.width, 40);
  const int bar_x = 40 + 4 + 6;                         // Middle of the bar.
  EXPECT_NEAR(rgb.at(bar_x, 39, 0), 0.267004f, 1e-6f);  // min at the bottom
  EXPECT_NEAR(rgb.at(bar_x, 0, 1), 0.906157f, 1e-6f);   // max at the top
}

}  // namespace
}  // namespace shadefit::metrics
