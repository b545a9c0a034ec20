// Point-wise metrics and PSNR on hand-computable cases.
#include "shadefit/metrics/pixel_metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>
#include <string>

#include "shadefit/base/error.h"
#include "shadefit/metrics/common.h"
#include "test_images.h"

namespace shadefit::metrics {
namespace {

TEST(PixelMetricsTest, IdenticalImagesGiveZero) {
  const Image a = testing::HdrScene(32, 24);
  EXPECT_EQ(Rmse(a, a), 0.0);
  EXPECT_EQ(RelativeRmse(a, a), 0.0);
  EXPECT_EQ(LogRmse(a, a), 0.0);
  EXPECT_EQ(MeanAbsoluteError(a, a), 0.0);
  EXPECT_TRUE(std::isinf(Psnr(a, a)));
}

TEST(PixelMetricsTest, ConstantOffset) {
  const Image r(16, 16, 3, 1.0f), t(16, 16, 3, 1.1f);
  EXPECT_NEAR(Rmse(r, t), 0.1, 1e-6);
  EXPECT_NEAR(MeanAbsoluteError(r, t), 0.1, 1e-6);
  // |t - r| / (|r| + eps) = 0.1 / 1.01.
  EXPECT_NEAR(RelativeRmse(r, t), 0.1 / 1.01, 1e-6);
  EXPECT_NEAR(LogRmse(r, t), std::log(2.1) - std::log(2.0), 1e-6);
  // log(1 + (e - 1)) - log(1 + 1) = 1 - ln 2.
  const Image e(4, 4, 1, static_cast<float>(std::numbers::e - 1.0)), one(4, 4, 1, 1.0f);
  EXPECT_NEAR(LogRmse(one, e), 1.0 - std::log(2.0), 1e-6);
}

TEST(PixelMetricsTest, PsnrOfAKnownDisplayOffset) {
  // Linear 0 encodes to 0; SrgbToLinear(0.1) encodes back to 0.1: MSE 0.01, PSNR 20 dB.
  const Image r(8, 8, 3, 0.0f), t(8, 8, 3, SrgbToLinear(0.1f));
  EXPECT_NEAR(Psnr(r, t), 20.0, 1e-4);
  // One stop of exposure doubles the linear test value before encoding.
  const Image t2(8, 8, 3, SrgbToLinear(0.1f) / 2.0f);
  EXPECT_NEAR(Psnr(r, t2, {1.0f, nullptr}), 20.0, 1e-4);
  // Values above 1 are clipped after the OETF: 5.0 vs 2.0 is no display difference.
  EXPECT_TRUE(std::isinf(Psnr(Image(4, 4, 3, 2.0f), Image(4, 4, 3, 5.0f))));
}

TEST(PixelMetricsTest, GaussianNoiseOfKnownSigma) {
  // 256 x 256 x 3 samples of N(0, 0.05^2), fixed seed: RMSE ~ sigma, MAE ~ sigma sqrt(2 / pi).
  const double sigma = 0.05;
  const Image r(256, 256, 3, 0.5f);
  const Image t = testing::AddGaussianNoise(r, sigma, 1234);
  EXPECT_NEAR(Rmse(r, t), sigma, 0.01 * sigma);
  EXPECT_NEAR(MeanAbsoluteError(r, t), sigma * std::sqrt(2.0 / std::numbers::pi), 0.01 * sigma);
  EXPECT_NEAR(RelativeRmse(r, t), sigma / 0.51, 0.01 * sigma / 0.51);
}

TEST(PixelMetricsTest, MoreNoiseGivesLargerErrors) {
  const Image r = testing::HdrScene(64, 64);
  double previous[5] = {0, 0, 0, 0, 1e9};
  for (double sigma : {0.01, 0.03, 0.1, 0.3}) {
    const Image t = testing::AddGaussianNoise(r, sigma, 7);
    const double now[5] = {Rmse(r, t), RelativeRmse(r, t), LogRmse(r, t), MeanAbsoluteError(r, t),
                           Psnr(r, t)};
    for (int k = 0; k < 4; ++k) EXPECT_GT(now[k], previous[k]) << k << " sigma " << sigma;
    EXPECT_LT(now[4], previous[4]) << "PSNR, sigma " << sigma;
    std::copy(now, now + 5, previous);
  }
}

TEST(PixelMetricsTest, MaskRestrictsTheAverage) {
  Image r(10, 10, 3, 0.5f), t = r, mask(10, 10, 1, 0.0f);
  for (int y = 0; y < 10; ++y) {
    for (int x = 0; x < 10; ++x) {
      if (x < 5) {
        mask.at(x, y, 0) = 1.0f;
        for (int c = 0; c < 3; ++c) t.at(x, y, c) = 0.7f;  // Error 0.2 inside the mask.
      } else {
        for (int c = 0; c < 3; ++c) t.at(x, y, c) = 3.0f;  // Huge error outside.
      }
    }
  }
  PixelMetricParameters p;
  p.mask = &mask;
  EXPECT_NEAR(Rmse(r, t, p), 0.2, 1e-6);
  EXPECT_NEAR(MeanAbsoluteError(r, t, p), 0.2, 1e-6);
  const Image map = AbsoluteErrorMap(r, t, &mask);
  EXPECT_NEAR(map.at(0, 0, 0), 0.2f, 1e-6f);
  EXPECT_TRUE(std::isnan(map.at(9, 0, 0)));
  EXPECT_NEAR(RelativeErrorMap(r, t, 0.01f).at(9, 9, 0), 2.5f / 0.51f, 1e-5f);
}

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(PixelMetricsTest, BadInputsNameFileAndField) {
  const Image a(8, 8, 3, 0.5f);
  EXPECT_EQ(ErrorOf([&] { Rmse(a, Image(8, 4, 3)); }),
            "test: resolution: 8x4 differs from the reference's 8x8 (reference)");
  EXPECT_EQ(ErrorOf([&] { Rmse(a, Image(8, 8, 1)); }),
            "test: channels: has 1, the reference has 3");
  Image inf = a;
  inf.at(2, 5, 2) = INFINITY;
  EXPECT_EQ(ErrorOf([&] { Rmse(inf, a); }),
            "reference: pixels: infinite value at (2, 5) channel 2");
  const Image empty_mask(8, 8, 1, 0.0f);
  PixelMetricParameters p;
  p.mask = &empty_mask;
  EXPECT_EQ(ErrorOf([&] { Rmse(a, a, p); }), "mask: pixels: empty mask (no pixel > 0.5)");
  const Image rgb_mask(8, 8, 3, 1.0f);
  p.mask = &rgb_mask;
  EXPECT_EQ(ErrorOf([&] { Rmse(a, a, p); }), "mask: channels: mask must have 1 channel, has 3");
  InputNames names{"ref.exr", "test.exr", "m.png"};
  EXPECT_EQ(ErrorOf([&] { ValidateInputs(a, Image(4, 8, 3), nullptr, 3, names); }),
            "test.exr: resolution: 4x8 differs from the reference's 8x8 (ref.exr)");
}

}  // namespace
}  // namespace shadefit::metrics
