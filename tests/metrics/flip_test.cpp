// FLIP (LDR and HDR) against NVIDIA's reference implementation, plus properties.
#include "shadefit/metrics/flip.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "../../metrics/src/flip_map.h"
#include "../../metrics/src/weighted_sum.h"
#include "shadefit/base/error.h"
#include "test_images.h"

namespace shadefit::metrics {
namespace {

const std::string kData = std::string(SHADEFIT_SOURCE_DIR) + "/tests/metrics/data/";

// The committed inputs were written from test_images.h: LdrScene(64, 64) and
// LdrDistorted(scene, 0.04, seed 7) through WritePngPreview (sRGB OETF, 8 bit); HdrScene(64, 64)
// and HdrDistorted(scene, 0.1, seed 11) through WriteExr (float).
Image Clamped(const Image& hdr) {
  Image out = hdr;
  for (float& v : out.data) v = std::clamp(v, 0.0f, 1.0f);
  return out;
}

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

// x with ACES(x) = 0.85 by bisection on the tone curve written out here (Narkowicz 2015 applied
// to 0.6 x), independently of flip.cpp's closed-form inverse.
double AcesInputFor085() {
  const auto aces = [](double x) {
    const double v = 0.6 * x;
    return v * (2.51 * v + 0.03) / (v * (2.43 * v + 0.59) + 0.14);
  };
  double lo = 0.0, hi = 100.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (aces(mid) < 0.85 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// A grey disc-like block on black: HDR-FLIP's exposure range comes from the masked pixels, and
// when more than half of them are black, from the median of the lit ones.
TEST(FlipTest, HdrExposureRangeComesFromTheMaskedPixels) {
  Image ref(32, 32, 3, 0.0f), mask(32, 32, 1, 0.0f);
  // Masked: a 10 x 10 block; 60 of its pixels at luminance 0.25, 39 at 0.0625, one at 8.
  int k = 0;
  for (int y = 10; y < 20; ++y) {
    for (int x = 10; x < 20; ++x, ++k) {
      const float v = k == 0 ? 8.0f : k <= 60 ? 0.25f : 0.0625f;
      for (int c = 0; c < 3; ++c) ref.at(x, y, c) = v;  // Grey: luminance = v.
      mask.at(x, y, 0) = 1.0f;
    }
  }
  for (int c = 0; c < 3; ++c) ref.at(0, 0, c) = 50.0f;  // Outside the mask: not in the range.
  const double x85 = AcesInputFor085();
  FlipParameters p;
  p.mask = &mask;
  FlipResult r = FlipHdr(ref, ref, p);
  EXPECT_NEAR(r.start_exposure, std::log2(x85 / 8.0), 1e-4);
  EXPECT_NEAR(r.stop_exposure, std::log2(x85 / 0.25), 1e-4);  // The masked median.
  EXPECT_EQ(r.num_exposures, 5);                              // ceil(5 stops).
  // More than half of the masked pixels black (51): the lit ones' median (0.25 of 3 x 0.001,
  // 45 x 0.25, 1 x 8), not the darkest lit pixel (0.001).
  k = 0;
  for (int y = 10; y < 20; ++y) {
    for (int x = 10; x < 20; ++x, ++k) {
      float v = ref.at(x, y, 0);
      if (k >= 61 && k <= 63) v = 0.001f;
      if (k >= 64 || (k >= 1 && k <= 15)) v = 0.0f;
      for (int c = 0; c < 3; ++c) ref.at(x, y, c) = v;
    }
  }
  r = FlipHdr(ref, ref, p);
  std::vector<float> lit_values;
  for (int y = 10; y < 20; ++y) {
    for (int x = 10; x < 20; ++x) {
      if (ref.at(x, y, 0) > 0.0f) lit_values.push_back(ref.at(x, y, 0));
    }
  }
  std::sort(lit_values.begin(), lit_values.end());
  ASSERT_EQ(lit_values.size(), 49u);
  EXPECT_NEAR(r.stop_exposure, std::log2(x85 / 0.25), 1e-4);
  // Without the mask, the whole frame: its median is 0, so the lit pixels' median again (0.25
  // of 50 lit values), and the brightest pixel is the background's.
  r = FlipHdr(ref, ref);
  EXPECT_NEAR(r.start_exposure, std::log2(x85 / 50.0), 1e-4);
  EXPECT_NEAR(r.stop_exposure, std::log2(x85 / 0.25), 1e-4);
}

// The reference's half kept in a cache gives the same bytes as computing it every time, and is
// found again for the same reference only.
TEST(FlipTest, ReferenceCacheGivesTheSameMaps) {
  const Image ref = testing::HdrScene(48, 40);
  const Image test_a = testing::HdrDistorted(ref, 0.1f, 3);
  const Image test_b = testing::HdrDistorted(ref, 0.3f, 4);
  ReferenceCache cache(std::size_t{64} << 20);
  FlipParameters cached;
  cached.reference_cache = &cache;
  for (const Image* test : {&test_a, &test_b, &test_a}) {
    Image plain_map, cached_map;
    const FlipResult plain = FlipHdr(ref, *test, {}, &plain_map);
    const FlipResult hit = FlipHdr(ref, *test, cached, &cached_map);
    EXPECT_EQ(plain.mean, hit.mean);
    ASSERT_EQ(plain_map.data.size(), cached_map.data.size());
    EXPECT_EQ(0, std::memcmp(plain_map.data.data(), cached_map.data.data(),
                             plain_map.data.size() * sizeof(float)));
    EXPECT_EQ(FlipLdr(Clamped(ref), Clamped(*test)).mean,
              FlipLdr(Clamped(ref), Clamped(*test), cached).mean);
  }
  const int exposures = FlipHdr(ref, test_a).num_exposures;
  ReferenceCache::Stats s = cache.stats();
  EXPECT_EQ(s.misses, static_cast<std::uint64_t>(exposures + 1));   // First call: HDR + LDR.
  EXPECT_EQ(s.hits, static_cast<std::uint64_t>(2 * (exposures + 1)));
  // Another reference (one value changed: the first, one in the middle at an odd index, the
  // last) finds nothing.
  for (const std::size_t i : {std::size_t{0}, std::size_t{5 * 48 * 3 + 17}, ref.data.size() - 1}) {
    Image other = ref;
    other.data[i] += 0.5f;
    FlipHdr(other, test_a, cached);
    EXPECT_EQ(cache.stats().hits, s.hits) << "value " << i;
  }
  // A budget below one entry keeps only the newest.
  ReferenceCache tiny(1);
  cached.reference_cache = &tiny;
  FlipHdr(ref, test_a, cached);
  EXPECT_GT(tiny.stats().bytes, 0u);
  EXPECT_LT(tiny.stats().bytes, std::size_t{48} * 40 * 24);
}

// Without a map to return, FLIP computes only what the masked pixels read (the filters' supports
// around them): every pooled statistic has the same bits as the whole frame's map pooled over the
// same mask. The mask has a disc, lone pixels, pixels on the frame's edges and empty rows.
TEST(FlipTest, MaskedPixelsOnlyGiveTheWholeFramesBits) {
  const int w = 96, h = 80;
  const Image ref = testing::HdrScene(w, h);
  const Image test = testing::HdrDistorted(ref, 0.2f, 5);
  Image mask(w, h, 1, 0.0f);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const float dx = x - 40.0f, dy = y - 38.0f;
      if (dx * dx + dy * dy < 22.0f * 22.0f) mask.at(x, y, 0) = 1.0f;
    }
  }
  for (const auto& [x, y] : {std::pair{0, 0}, {95, 3}, {90, 79}, {70, 70}, {3, 60}, {88, 40}}) {
    mask.at(x, y, 0) = 1.0f;
  }
  FlipParameters p;
  p.mask = &mask;
  const auto expect_same = [](const FlipResult& a, const FlipResult& b, const char* what) {
    EXPECT_EQ(a.mean, b.mean) << what;
    EXPECT_EQ(a.median, b.median) << what;
    EXPECT_EQ(a.p95, b.p95) << what;
    EXPECT_EQ(a.p99, b.p99) << what;
    EXPECT_EQ(a.max, b.max) << what;
    EXPECT_EQ(a.weighted_median, b.weighted_median) << what;
    EXPECT_EQ(a.weighted_q1, b.weighted_q1) << what;
    EXPECT_EQ(a.weighted_q3, b.weighted_q3) << what;
    EXPECT_EQ(a.histogram, b.histogram) << what;
  };
  Image map;
  expect_same(FlipLdr(Clamped(ref), Clamped(test), p, &map),
              FlipLdr(Clamped(ref), Clamped(test), p), "LDR");
  const FlipResult hdr_whole = FlipHdr(ref, test, p, &map);
  const FlipResult hdr_masked = FlipHdr(ref, test, p);
  expect_same(hdr_whole, hdr_masked, "HDR");
  EXPECT_GE(hdr_masked.num_exposures, 3);
  EXPECT_GT(hdr_masked.mean, 0.01);
  // The reference cache keeps halves per wanted pixels: a whole frame's half is not handed to a
  // masked call, nor the other way round.
  ReferenceCache cache(std::size_t{64} << 20);
  FlipParameters cached = p;
  cached.reference_cache = &cache;
  expect_same(FlipHdr(ref, test, cached, &map), hdr_whole, "HDR, cache cold");
  expect_same(FlipHdr(ref, test, cached), hdr_masked, "HDR, cache warm with the whole frame");
}

// One exposure of HDR-FLIP is LDR-FLIP of the two images scaled by 2^c and tone mapped. With the
// range pinned to a single exposure c, HDR-FLIP must equal LDR-FLIP of images tone mapped here,
// by the published curves written out independently: ACES as Narkowicz's x(2.51x + 0.03) /
// (x(2.43x + 0.59) + 0.14) of 0.6 x (HDR-FLIP cancels the fit's 0.6 pre-exposure), and Reinhard's
// global operator c / (1 + L) with L the Rec. 709 luminance.
TEST(FlipTest, OneExposureIsLdrFlipOfTheToneMappedImages) {
  const Image ref = testing::HdrScene(64, 48);
  const Image test = testing::HdrDistorted(ref, 0.2f, 9);
  const auto aces = [](const Image& image, double c) {
    Image out = image;
    for (float& v : out.data) {
      const double x = 0.6 * std::exp2(c) * v;
      v = static_cast<float>(
          std::clamp(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0));
    }
    return out;
  };
  const auto reinhard = [](const Image& image, double c) {
    Image out = image;
    for (std::size_t i = 0; i < out.PixelCount(); ++i) {
      float* p = &out.data[3 * i];
      const double s = std::exp2(c);
      const double l = s * (0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]);
      for (int ch = 0; ch < 3; ++ch) p[ch] = static_cast<float>(std::clamp(s * p[ch] / (1.0 + l), 0.0, 1.0));
    }
    return out;
  };
  for (const double c : {-1.5, 0.0, 2.0}) {
    FlipParameters p;
    p.start_exposure = p.stop_exposure = c;  // Two exposures, both c.
    p.tone_mapper = FlipToneMapper::kAces;
    EXPECT_NEAR(FlipHdr(ref, test, p).mean, FlipLdr(aces(ref, c), aces(test, c)).mean, 2e-4)
        << "ACES, exposure " << c;
    p.tone_mapper = FlipToneMapper::kReinhard;
    EXPECT_NEAR(FlipHdr(ref, test, p).mean, FlipLdr(reinhard(ref, c), reinhard(test, c)).mean,
                2e-4)
        << "Reinhard, exposure " << c;
  }
}

// HDR-FLIP's map is, bit for bit, each pixel's largest LDR-FLIP value over the exposures (the
// first exposure that reaches it gives the exposure map's index), as the separate halves and
// their combination give it at each exposure.
TEST(FlipTest, HdrMapIsEachPixelsLargestValueOverTheExposures) {
  for (const auto& [tone_mapper, noise, seed] :
       {std::tuple{FlipToneMapper::kAces, 0.2f, 3}, std::tuple{FlipToneMapper::kAces, 0.02f, 5},
        std::tuple{FlipToneMapper::kReinhard, 0.3f, 8}}) {
    const Image ref = testing::HdrScene(72, 56);
    Image test = testing::HdrDistorted(ref, noise, seed);
    // A left third without error: values of 0 at every exposure, whose index is the first's.
    for (int y = 0; y < ref.height; ++y) {
      for (int x = 0; x < ref.width / 3; ++x) {
        for (int c = 0; c < ref.channels; ++c) test.at(x, y, c) = ref.at(x, y, c);
      }
    }
    FlipParameters p;
    p.tone_mapper = tone_mapper;
    p.start_exposure = -6.0;
    p.stop_exposure = 5.0;
    p.num_exposures = 23;  // Half-stop steps: neighbouring exposures' values are close.
    Image map, index;
    FlipHdr(ref, test, p, &map, &index);

    const internal::RowSpans all = internal::FullSpans(ref.width, ref.height);
    const std::size_t n = ref.PixelCount();
    std::vector<float> worst(n, 0.0f), worst_index(n, 0.0f);
    const double step = (p.stop_exposure - p.start_exposure) / (p.num_exposures - 1);
    for (int e = 0; e < p.num_exposures; ++e) {
      const internal::Exposure exposure{
          true, static_cast<float>(std::exp2(p.start_exposure + e * step)), tone_mapper};
      const internal::Plane values = internal::CombineSides(
          internal::ComputeSide(ref, p.ppd, all, exposure),
          internal::ComputeSide(test, p.ppd, all, exposure), ref.width, ref.height, all);
      for (std::size_t i = 0; i < n; ++i) {
        if (values[i] > worst[i]) {
          worst[i] = values[i];
          worst_index[i] = static_cast<float>(e) / (p.num_exposures - 1);
        }
      }
    }
    ASSERT_EQ(map.PixelCount(), n);
    int differ = 0;
    for (std::size_t i = 0; i < n; ++i) {
      differ += std::bit_cast<std::uint32_t>(map.data[i]) !=
                    std::bit_cast<std::uint32_t>(worst[i]) ||
                std::bit_cast<std::uint32_t>(index.data[i]) !=
                    std::bit_cast<std::uint32_t>(worst_index[i]);
    }
    EXPECT_EQ(differ, 0) << "pixels of " << n << ", noise " << noise;
  }
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

// The filters' inner loop (metrics/src/weighted_sum.h, FLIP's float passes and SSIM's double
// ones) keeps 8 vectors of sums in registers, then 1, then one pixel at a time. Every pixel must
// get the bits of its own sum, 0 + taps[0] in(0) + taps[1] in(1) + ..., in that order (what the
// passes computed before, one tap at a time over the row): widths across each block's edges, tap
// counts of FLIP's and SSIM's filters, rows (in + k) and columns (a row per tap).
template <typename T>
void ExpectSumsPerPixel() {
  std::mt19937 rng(46);
  std::uniform_real_distribution<T> value(-2, 2);
  for (const int ntaps : {1, 11, 21}) {
    std::vector<T> taps(ntaps);
    for (T& t : taps) t = value(rng);
    taps[ntaps / 2] = -T(0);  // A derivative filter's centre tap.
    for (int n = 0; n <= 150; ++n) {
      std::vector<T> row(n + ntaps);
      for (T& v : row) v = value(rng);
      std::vector<std::vector<T>> columns(ntaps, std::vector<T>(n));
      std::vector<const T*> column_rows;
      for (auto& c : columns) {
        for (T& v : c) v = value(rng);
        column_rows.push_back(c.data());
      }
      std::vector<T> along(n, T(7)), down(n, T(7));
      internal::WeightedSum(along.data(), taps.data(), ntaps, n,
                            [&](int k) { return row.data() + k; });
      internal::WeightedSum(down.data(), taps.data(), ntaps, n,
                            [&](int k) { return column_rows[k]; });
      for (int x = 0; x < n; ++x) {
        T want_along = T(0), want_down = T(0);
        for (int k = 0; k < ntaps; ++k) {
          want_along += taps[k] * row[x + k];
          want_down += taps[k] * columns[k][x];
        }
        using Bits = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>;
        ASSERT_EQ(std::bit_cast<Bits>(along[x]), std::bit_cast<Bits>(want_along))
            << "row, " << ntaps << " taps, width " << n << ", pixel " << x;
        ASSERT_EQ(std::bit_cast<Bits>(down[x]), std::bit_cast<Bits>(want_down))
            << "column, " << ntaps << " taps, width " << n << ", pixel " << x;
      }
    }
  }
}

TEST(WeightedSumTest, EachPixelGetsTheBitsOfItsOwnSumInTapOrder) {
  ExpectSumsPerPixel<float>();
  ExpectSumsPerPixel<double>();
}

}  // namespace
}  // namespace shadefit::metrics
