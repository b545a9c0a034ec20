// SSIM against scikit-image, MS-SSIM properties, masks and small images.
#include "shadefit/metrics/ssim.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "shadefit/metrics/common.h"
#include "shadefit/base/error.h"
#include "test_images.h"

namespace shadefit::metrics {
namespace {

namespace fs = std::filesystem;

// Debian's python3-skimage belongs to the system interpreter, not a pyenv `python3` on PATH.
constexpr const char* kPython = "/usr/bin/python3";

std::string RunCommand(const std::string& command, int* status) {
  std::string out;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) {
    *status = -1;
    return out;
  }
  char buffer[256];
  while (fgets(buffer, sizeof(buffer), pipe)) out += buffer;
  *status = pclose(pipe);
  return out;
}

void WriteRaw(const std::string& path, const Image& image) {
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(image.data.data()),
          static_cast<std::streamsize>(image.data.size() * sizeof(float)));
}

struct SkimagePair {
  std::string name;
  Image a, b;
  double data_range;
};

TEST(SsimTest, MatchesScikitImage) {
  int status = 0;
  RunCommand(std::string(kPython) + " -c 'import skimage.metrics' 2>/dev/null", &status);
  if (status != 0) {
    GTEST_SKIP() << "python3-skimage not installed for /usr/bin/python3, so SSIM cannot be "
                    "compared with scikit-image (apt install python3-skimage)";
  }
  std::vector<SkimagePair> pairs;
  {
    const Image scene = testing::LdrScene(64, 64);
    pairs.push_back({"luminance_64", DisplayEncode(Luminance(scene), 0.0f),
                     DisplayEncode(Luminance(testing::LdrDistorted(scene, 0.05f, 4)), 0.0f), 1.0});
  }
  {
    Image gradient(40, 30, 1);
    for (int y = 0; y < 30; ++y) {
      for (int x = 0; x < 40; ++x) gradient.at(x, y, 0) = 0.2f + 0.015f * x + 0.005f * y;
    }
    pairs.push_back({"noise_40x30", gradient, testing::AddGaussianNoise(gradient, 0.05, 99), 1.0});
  }
  {
    const Image hdr = Luminance(testing::HdrScene(48, 48));
    pairs.push_back({"hdr_range_25", hdr,
                     Luminance(testing::HdrDistorted(testing::HdrScene(48, 48), 0.2f, 3)), 25.0});
  }
  {
    Image small(11, 11, 1);
    for (std::size_t i = 0; i < small.data.size(); ++i) {
      small.data[i] = 0.5f + 0.4f * testing::HashNoise(i, 0, 0, 1);
    }
    pairs.push_back({"window_sized_11", small, testing::AddGaussianNoise(small, 0.1, 5), 1.0});
  }
  {
    Image signed_image(50, 70, 1);
    for (int y = 0; y < 70; ++y) {
      for (int x = 0; x < 50; ++x) {
        signed_image.at(x, y, 0) = std::sin(0.3f * x) * std::cos(0.2f * y);
      }
    }
    Image shifted = signed_image;
    for (float& v : shifted.data) v = std::clamp(0.8f * v + 0.1f, -1.0f, 1.0f);
    pairs.push_back({"signed_range_2", signed_image, shifted, 2.0});
  }
  {
    const Image scene = testing::LdrScene(32, 40);
    pairs.push_back({"rgb_32x40", scene, testing::LdrDistorted(scene, 0.1f, 8), 1.0});
  }

  const fs::path dir = fs::path(SHADEFIT_TEST_OUTPUT) / "ssim_skimage";
  fs::create_directories(dir);
  std::string args;
  for (const SkimagePair& p : pairs) {
    const std::string a = (dir / (p.name + "_a.f32")).string();
    const std::string b = (dir / (p.name + "_b.f32")).string();
    WriteRaw(a, p.a);
    WriteRaw(b, p.b);
    std::ostringstream spec;
    spec.precision(17);
    spec << a << "," << b << "," << p.a.width << "," << p.a.height << "," << p.a.channels << ","
         << p.data_range;
    args.push_back(' ');
    args.append(spec.str());
  }
  // The images travel as raw little-endian float32 and are promoted to float64, so skimage sees
  // exactly our input values and computes in double precision.
  const std::string script =
      "import sys, numpy as np\n"
      "from skimage.metrics import structural_similarity as ssim\n"
      "for spec in sys.argv[1:]:\n"
      "    a, b, w, h, c, r = spec.split(\",\")\n"
      "    w, h, c = int(w), int(h), int(c)\n"
      "    x = np.fromfile(a, dtype=\"<f4\").astype(np.float64).reshape(h, w, c)\n"
      "    y = np.fromfile(b, dtype=\"<f4\").astype(np.float64).reshape(h, w, c)\n"
      "    kw = {\"channel_axis\": 2} if c > 1 else {}\n"
      "    if c == 1: x, y = x[:, :, 0], y[:, :, 0]\n"
      "    print(\"%.12f\" % ssim(x, y, gaussian_weights=True, sigma=1.5,\n"
      "          use_sample_covariance=False, data_range=float(r), **kw))\n";
  std::ofstream(dir / "compare.py") << script;
  const std::string output =
      RunCommand(std::string(kPython) + " " + (dir / "compare.py").string() + args, &status);
  ASSERT_EQ(status, 0) << output;
  std::istringstream lines(output);
  double worst = 0.0;
  for (const SkimagePair& p : pairs) {
    double expected = 0.0;
    ASSERT_TRUE(lines >> expected) << "missing skimage output for " << p.name << ": " << output;
    SsimParameters params;
    params.data_range = p.data_range;
    const double ours = Ssim(p.a, p.b, params).mean;
    EXPECT_NEAR(ours, expected, 1e-4) << p.name;
    EXPECT_LT(ours, 1.0) << p.name;  // Every pair differs.
    worst = std::max(worst, std::abs(ours - expected));
    std::printf("%-16s ours %.10f skimage %.10f\n", p.name.c_str(), ours, expected);
  }
  std::printf("max |SSIM - skimage| over %zu pairs: %.3g\n", pairs.size(), worst);
}

TEST(SsimTest, IdenticalImagesGiveOne) {
  const Image a = testing::LdrScene(40, 32);
  Image map;
  const SsimResult r = Ssim(a, a, {}, &map);
  EXPECT_NEAR(r.mean, 1.0, 1e-12);
  ASSERT_EQ(r.channel_means.size(), 3u);
  EXPECT_EQ(map.channels, 3);
  for (float v : map.data) EXPECT_NEAR(v, 1.0f, 1e-6f);
  EXPECT_EQ(r.pooled_pixels, static_cast<std::size_t>((40 - 10) * (32 - 10)));
  EXPECT_NEAR(MsSsim(a, a).value, 1.0, 1e-12);
}

TEST(SsimTest, MoreNoiseGivesLowerSsim) {
  const Image a = DisplayEncode(Luminance(testing::LdrScene(64, 64)), 0.0f);
  double previous_ssim = 1.0, previous_ms = 1.0;
  for (double sigma : {0.01, 0.03, 0.1, 0.3}) {
    const Image b = testing::AddGaussianNoise(a, sigma, 17);
    const double s = Ssim(a, b).mean, ms = MsSsim(a, b).value;
    EXPECT_LT(s, previous_ssim) << sigma;
    EXPECT_LT(ms, previous_ms) << sigma;
    previous_ssim = s;
    previous_ms = ms;
  }
}

TEST(SsimTest, MsSsimScalesFollowImageSize) {
  const Image big(200, 180, 1, 0.5f);
  EXPECT_EQ(MsSsim(big, big).scales_used, 5);  // 180 / 16 = 11 still holds a window.
  const Image medium(64, 64, 1, 0.5f);
  const MsSsimResult r = MsSsim(medium, testing::AddGaussianNoise(medium, 0.05, 1));
  EXPECT_EQ(r.scales_used, 3);  // 64, 32, 16; 8 < 11.
  EXPECT_EQ(r.contrast_structure.size(), 3u);
  EXPECT_GT(r.value, 0.0);
  EXPECT_LT(r.value, 1.0);
}

TEST(SsimTest, MaskErodedByTheWindow) {
  const Image a = DisplayEncode(Luminance(testing::LdrScene(64, 64)), 0.0f);
  Image b = a, mask(64, 64, 1, 0.0f);
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) {
      if (x < 32) mask.at(x, y, 0) = 1.0f;
      if (x >= 36) b.at(x, y, 0) = 1.0f - a.at(x, y, 0);  // Changed right of column 36.
    }
  }
  SsimParameters p;
  p.mask = &mask;
  const SsimResult r = Ssim(a, b, p);
  // Pooled: x in [5, 26] (window inside the mask), y in [5, 58]; no window reaches x >= 36.
  EXPECT_EQ(r.pooled_pixels, static_cast<std::size_t>(22 * 54));
  EXPECT_NEAR(r.mean, 1.0, 1e-12);
  EXPECT_LT(Ssim(a, b).mean, 0.9);
}

// Without a map, SSIM computes only the pooled pixels' windows: the same bits as the whole frame's
// map pooled over the same mask (a disc, lone pixels that pool nothing, and pooled pixels whose
// windows reach the frame's mirrored edges).
TEST(SsimTest, PooledPixelsOnlyGiveTheWholeFramesBits) {
  const int w = 90, h = 70;
  const Image ref = testing::LdrScene(w, h);
  const Image test = testing::LdrDistorted(ref, 0.08f, 9);
  Image mask(w, h, 1, 0.0f);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const float dx = x - 40.0f, dy = y - 33.0f;
      if (dx * dx + dy * dy < 25.0f * 25.0f || (x >= 70 && y >= 55) || (x < 14 && y < 12)) {
        mask.at(x, y, 0) = 1.0f;
      }
    }
  }
  mask.at(85, 5, 0) = 1.0f;
  SsimParameters p;
  p.mask = &mask;
  Image map;
  const SsimResult whole = Ssim(ref, test, p, &map);
  const SsimResult pooled = Ssim(ref, test, p);
  EXPECT_EQ(whole.mean, pooled.mean);
  EXPECT_EQ(whole.channel_means, pooled.channel_means);
  EXPECT_EQ(whole.pooled_pixels, pooled.pooled_pixels);
  EXPECT_LT(pooled.mean, 0.99);
}

TEST(SsimTest, TooSmallOrEmptyIsAnError) {
  const Image small(10, 30, 1, 0.5f);
  try {
    Ssim(small, small);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "reference: resolution: 10x30 is smaller than the 11x11 SSIM window");
  }
  const Image a(30, 30, 1, 0.5f);
  Image thin(30, 30, 1, 0.0f);
  for (int y = 0; y < 30; ++y) thin.at(15, y, 0) = 1.0f;  // One column: no window fits.
  SsimParameters p;
  p.mask = &thin;
  try {
    Ssim(a, a, p);
    FAIL() << "no error";
  } catch (const NoSsimWindowInMaskError& e) {  // Its own type: the runner falls back on it.
    EXPECT_STREQ(e.what(),
                 "mask: pixels: no pixel whose 11x11 SSIM window lies inside the mask");
  }
}

}  // namespace
}  // namespace shadefit::metrics

namespace shadefit::metrics {
namespace {

// A sphere-shaped mask on a 256^2 frame (the study's references): the mask shrinks at every
// MS-SSIM scale, so only the scales where a window still fits inside it are used.
TEST(SsimTest, MsSsimWithDiscMaskUsesTheScalesThatFit) {
  const int n = 256;
  Image a(n, n, 1), b(n, n, 1), mask(n, n, 1);
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const double dx = x + 0.5 - n / 2.0, dy = y + 0.5 - n / 2.0;
      mask.at(x, y, 0) = dx * dx + dy * dy < 98.0 * 98.0 ? 1.0f : 0.0f;
      a.at(x, y, 0) = static_cast<float>(0.5 + 0.4 * std::sin(0.05 * x) * std::cos(0.07 * y));
      b.at(x, y, 0) = a.at(x, y, 0) + static_cast<float>(0.05 * std::sin(0.9 * x + 0.4 * y));
    }
  }
  MsSsimParameters p;
  p.ssim.data_range = 1.0;
  p.ssim.mask = &mask;
  const MsSsimResult same = MsSsim(a, a, p);
  EXPECT_NEAR(same.value, 1.0, 1e-9);
  EXPECT_GE(same.scales_used, 3);
  EXPECT_LT(same.scales_used, 5);
  const MsSsimResult differ = MsSsim(a, b, p);
  EXPECT_LT(differ.value, 0.999);
  EXPECT_GT(differ.value, 0.0);
}

}  // namespace
}  // namespace shadefit::metrics
