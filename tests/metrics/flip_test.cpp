// FLIP (LDR and HDR) against NVIDIA's reference implementation, plus properties.
#include "shadefit/metrics/flip.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "shadefit/render/error.h"
#include "test_images.h"

namespace shadefit::metrics {
namespace {

const std::string kData = std::string(SHADEFIT_SOURCE_DIR) + "/tests/metrics/data/";

// The committed inputs were written from test_images.h: LdrScene(64, 64) and
// LdrDistorted(scene, 0.04, seed 7) through WritePngPreview (sRGB OETF, 8 bit); HdrScene(64, 64)
// and HdrDistorted(scene, 0.1, seed 11) through WriteExr (float).
Image ReadLdr(const std::string& name) {
  Image image = ReadImage(kData + name);
  for (float& v : image.data) v = SrgbToLinear(v);  // What the reference tool does for PNGs.
  return image;
}

// Golden means from NVIDIA's reference FLIP tool, C++ version (github.com/NVlabs/flip, commit
// 1eb247cabcf2862c2c8207ab15314304394132b9, "FLIP v1.6"), built with
// `g++ -O2 -std=c++17 -fopenmp -I.. FLIP-tool.cpp` in src/cpp/tool and run as
// `flip -r <reference> -t <test> -ppd <ppd>` on the files in tests/metrics/data/.
// The tool printed the means with six decimals.
struct Golden {
  const char* reference;
  const char* test;
  bool hdr;
  double ppd;
  double mean;
  double start_exposure;  // HDR only (tool output, four decimals).
  double stop_exposure;
  int num_exposures;
};
constexpr Golden kGolden[] = {
    {"flip_ldr_reference.png", "flip_ldr_test.png", false, 67.0, 0.165967, 0, 0, 0},
    {"flip_ldr_reference.png", "flip_ldr_test.png", false, 30.0, 0.182110, 0, 0, 0},
    {"flip_hdr_reference.exr", "flip_hdr_test.exr", true, 67.0, 0.152875, -3.1197, 3.5572, 7},
    {"flip_hdr_reference.exr", "flip_hdr_test.exr", true, 30.0, 0.169213, -3.1197, 3.5572, 7},
};

TEST(FlipTest, MatchesReferenceImplementation) {
  for (const Golden& g : kGolden) {
    SCOPED_TRACE(std::string(g.test) + " ppd " + std::to_string(g.ppd));
    FlipParameters p;
    p.ppd = g.ppd;
    if (g.hdr) {
      const FlipResult r =
          FlipHdr(ReadImage(kData + g.reference), ReadImage(kData + g.test), p);
      EXPECT_NEAR(r.mean, g.mean, 1e-3);
      EXPECT_NEAR(r.start_exposure, g.start_exposure, 1e-3);
      EXPECT_NEAR(r.stop_exposure, g.stop_exposure, 1e-3);
      EXPECT_EQ(r.num_exposures, g.num_exposures);
      std::printf("HDR ppd %.0f: mean %.6f, reference tool %.6f, deviation %.2e\n", g.ppd, r.mean,
                  g.mean, std::abs(r.mean - g.mean));
    } else {
      const FlipResult r = FlipLdr(ReadLdr(g.reference), ReadLdr(g.test), p);
      EXPECT_NEAR(r.mean, g.mean, 1e-3);
      std::printf("LDR ppd %.0f: mean %.6f, reference tool %.6f, deviation %.2e\n", g.ppd, r.mean,
                  g.mean, std::abs(r.mean - g.mean));
    }
  }
}

TEST(FlipTest, CommittedInputsMatchTheirGenerator) {
  // Guards the golden values: the data files must still be what test_images.h produces.
  const Image ldr = testing::LdrScene(64, 64);
  const Image ref = ReadImage(kData + "flip_ldr_reference.png");
  for (std::size_t i = 0; i < ldr.data.size(); ++i) {
    ASSERT_NEAR(ref.data[i], SrgbOetf(ldr.data[i]), 0.5 / 255.0 + 1e-6) << i;
  }
  const Image hdr = testing::HdrDistorted(testing::HdrScene(64, 64), 0.1f, 11);
  const Image test = ReadImage(kData + "flip_hdr_test.exr");
  ASSERT_EQ(test.data.size(), hdr.data.size());
  for (std::size_t i = 0; i < hdr.data.size(); ++i) ASSERT_EQ(test.data[i], hdr.data[i]) << i;
}

TEST(FlipTest, IdenticalImagesGiveZero) {
  const Image ldr = testing::LdrScene(48, 40);
  Image map;
  const FlipResult r = FlipLdr(ldr, ldr, {}, &map);
  EXPECT_EQ(r.mean, 0.0);
  EXPECT_EQ(r.max, 0.0);
  ASSERT_EQ(map.width, 48);
  const Image hdr = testing::HdrScene(48, 40);
  EXPECT_EQ(FlipHdr(hdr, hdr).mean, 0.0);
}

TEST(FlipTest, BlackVersusWhiteIsMaximal) {
  // Pure colour difference of the largest kind: LDR-FLIP's colour term reaches 1 only for the
  // green-blue pair, but black-white must be close to it and uniform in the interior.
  const Image black(32, 32, 3, 0.0f), white(32, 32, 3, 1.0f);
  const FlipResult r = FlipLdr(black, white);
  EXPECT_GT(r.mean, 0.9);
  EXPECT_LE(r.max, 1.0);
}

TEST(FlipTest, MoreNoiseGivesLargerFlip) {
  const Image ref = testing::LdrScene(64, 64);
  double previous = 0.0;
  for (float amplitude : {0.01f, 0.03f, 0.1f, 0.3f}) {
    const double mean = FlipLdr(ref, testing::LdrDistorted(ref, amplitude, 3)).mean;
    EXPECT_GT(mean, previous) << amplitude;
    previous = mean;
  }
  const Image hdr = testing::HdrScene(64, 64);
  previous = 0.0;
  for (float amplitude : {0.02f, 0.1f, 0.4f}) {
    const double mean = FlipHdr(hdr, testing::HdrDistorted(hdr, amplitude, 5)).mean;
    EXPECT_GT(mean, previous) << amplitude;
    previous = mean;
  }
}

TEST(FlipTest, MaskSelectsPooledPixels) {
  const Image ref = testing::LdrScene(64, 64);
  Image test = ref;
  for (int y = 0; y < 64; ++y) {
    for (int x = 48; x < 64; ++x) test.at(x, y, 0) = 1.0f;  // Error only on the right.
  }
  Image mask(64, 64, 1, 0.0f);
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 16; ++x) mask.at(x, y, 0) = 1.0f;  // Pool the far left only.
  }
  FlipParameters p;
  p.mask = &mask;
  EXPECT_LT(FlipLdr(ref, test, p).mean, 1e-6);
  EXPECT_GT(FlipLdr(ref, test).mean, 0.05);
}

TEST(FlipTest, PercentilesAreOrdered) {
  const Image ref = testing::LdrScene(64, 64);
  const FlipResult r = FlipLdr(ref, testing::LdrDistorted(ref, 0.05f, 1));
  EXPECT_LE(r.median, r.p95);
  EXPECT_LE(r.p95, r.p99);
  EXPECT_LE(r.p99, r.max);
  EXPECT_LE(r.weighted_q1, r.weighted_median);
  EXPECT_LE(r.weighted_median, r.weighted_q3);
  double total = 0.0;
  for (double h : r.histogram) total += h;
  EXPECT_NEAR(total, 1.0, 1e-12);
}

TEST(FlipTest, BadInputsNameTheField) {
  const Image a(16, 16, 3, 0.5f), b(16, 8, 3, 0.5f);
  try {
    FlipLdr(a, b);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("test: resolution"), std::string::npos) << e.what();
  }
  Image nan = a;
  nan.at(3, 4, 1) = std::nanf("");
  try {
    FlipHdr(a, nan);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("test: pixels: NaN value at (3, 4)"), std::string::npos)
        << e.what();
  }
  const Image gray(16, 16, 1, 0.5f);
  EXPECT_THROW(FlipLdr(gray, gray), Error);  // Needs RGB.
}

}  // namespace
}  // namespace shadefit::metrics
