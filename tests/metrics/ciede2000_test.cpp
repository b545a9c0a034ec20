// CIEDE2000 on the published test pairs, and the image-level statistics.
#include "shadefit/metrics/ciede2000.h"

#include <gtest/gtest.h>

#include <cmath>

#include "test_images.h"

namespace shadefit::metrics {
namespace {

// Sharma, Wu, Dalal 2005, Table 1: the 34 CIEDE2000 test pairs (L1 a1 b1, L2 a2 b2, Delta E_00),
// typed from the paper. Pairs 7-16 probe the hue-angle wrap-around and the mean-hue cases.
struct Pair {
  Lab first, second;
  double delta_e;
};
constexpr Pair kSharmaPairs[34] = {
    {{50.0000, 2.6772, -79.7751}, {50.0000, 0.0000, -82.7485}, 2.0425},
    {{50.0000, 3.1571, -77.2803}, {50.0000, 0.0000, -82.7485}, 2.8615},
    {{50.0000, 2.8361, -74.0200}, {50.0000, 0.0000, -82.7485}, 3.4412},
    {{50.0000, -1.3802, -84.2814}, {50.0000, 0.0000, -82.7485}, 1.0000},
    {{50.0000, -1.1848, -84.8006}, {50.0000, 0.0000, -82.7485}, 1.0000},
    {{50.0000, -0.9009, -85.5211}, {50.0000, 0.0000, -82.7485}, 1.0000},
    {{50.0000, 0.0000, 0.0000}, {50.0000, -1.0000, 2.0000}, 2.3669},
    {{50.0000, -1.0000, 2.0000}, {50.0000, 0.0000, 0.0000}, 2.3669},
    {{50.0000, 2.4900, -0.0010}, {50.0000, -2.4900, 0.0009}, 7.1792},
    {{50.0000, 2.4900, -0.0010}, {50.0000, -2.4900, 0.0010}, 7.1792},
    {{50.0000, 2.4900, -0.0010}, {50.0000, -2.4900, 0.0011}, 7.2195},
    {{50.0000, 2.4900, -0.0010}, {50.0000, -2.4900, 0.0012}, 7.2195},
    {{50.0000, -0.0010, 2.4900}, {50.0000, 0.0009, -2.4900}, 4.8045},
    {{50.0000, -0.0010, 2.4900}, {50.0000, 0.0010, -2.4900}, 4.8045},
    {{50.0000, -0.0010, 2.4900}, {50.0000, 0.0011, -2.4900}, 4.7461},
    {{50.0000, 2.5000, 0.0000}, {50.0000, 0.0000, -2.5000}, 4.3065},
    {{50.0000, 2.5000, 0.0000}, {73.0000, 25.0000, -18.0000}, 27.1492},
    {{50.0000, 2.5000, 0.0000}, {61.0000, -5.0000, 29.0000}, 22.8977},
    {{50.0000, 2.5000, 0.0000}, {56.0000, -27.0000, -3.0000}, 31.9030},
    {{50.0000, 2.5000, 0.0000}, {58.0000, 24.0000, 15.0000}, 19.4535},
    {{50.0000, 2.5000, 0.0000}, {50.0000, 3.1736, 0.5854}, 1.0000},
    {{50.0000, 2.5000, 0.0000}, {50.0000, 3.2972, 0.0000}, 1.0000},
    {{50.0000, 2.5000, 0.0000}, {50.0000, 1.8634, 0.5757}, 1.0000},
    {{50.0000, 2.5000, 0.0000}, {50.0000, 3.2592, 0.3350}, 1.0000},
    {{60.2574, -34.0099, 36.2677}, {60.4626, -34.1751, 39.4387}, 1.2644},
    {{63.0109, -31.0961, -5.8663}, {62.8187, -29.7946, -4.0864}, 1.2630},
    {{61.2901, 3.7196, -5.3901}, {61.4292, 2.2480, -4.9620}, 1.8731},
    {{35.0831, -44.1164, 3.7933}, {35.0232, -40.0716, 1.5901}, 1.8645},
    {{22.7233, 20.0904, -46.6940}, {23.0331, 14.9730, -42.5619}, 2.0373},
    {{36.4612, 47.8580, 18.3852}, {36.2715, 50.5065, 21.2231}, 1.4146},
    {{90.8027, -2.0831, 1.4410}, {91.1528, -1.6435, 0.0447}, 1.4441},
    {{90.9257, -0.5406, -0.9208}, {88.6381, -0.8985, -0.7239}, 1.5381},
    {{6.7747, -0.2908, -2.4247}, {5.8714, -0.0985, -2.2286}, 0.6377},
    {{2.0776, 0.0795, -1.1350}, {0.9033, -0.0636, -0.5514}, 0.9082},
};

TEST(Ciede2000Test, SharmaTable1PairsWithin1e4) {
  double worst = 0.0;
  for (int i = 0; i < 34; ++i) {
    const Pair& p = kSharmaPairs[i];
    const double d = Ciede2000(p.first, p.second);
    EXPECT_NEAR(d, p.delta_e, 1e-4) << "pair " << i + 1;
    // The formula is symmetric (Sharma et al., Sec. "Mathematical observations").
    EXPECT_NEAR(Ciede2000(p.second, p.first), d, 1e-12) << "pair " << i + 1;
    worst = std::max(worst, std::abs(d - p.delta_e));
  }
  std::printf("max |deviation| over the 34 pairs: %.3g\n", worst);
}

TEST(Ciede2000Test, WhiteAndBlackAreNeutral) {
  const Lab white = LinearSrgbToLab(1, 1, 1);
  EXPECT_NEAR(white.l, 100.0, 1e-9);
  EXPECT_NEAR(white.a, 0.0, 1e-9);
  EXPECT_NEAR(white.b, 0.0, 1e-9);
  const Lab black = LinearSrgbToLab(0, 0, 0);
  EXPECT_NEAR(black.l, 0.0, 1e-9);
  // Middle grey 0.18 -> L* = 116 * 0.18^(1/3) - 16 = 49.496.
  EXPECT_NEAR(LinearSrgbToLab(0.18, 0.18, 0.18).l, 116.0 * std::cbrt(0.18) - 16.0, 1e-9);
}

TEST(Ciede2000Test, ImageStatistics) {
  const Image ref = testing::LdrScene(32, 32);
  Image map;
  const DeltaE2000Result same = DeltaE2000(ref, ref, {}, &map);
  EXPECT_EQ(same.mean, 0.0);
  EXPECT_EQ(same.p95, 0.0);
  // A uniform grey change: every pixel has the same Delta E_00 as the Lab pair.
  const Image a(8, 8, 3, 0.18f), b(8, 8, 3, 0.2f);
  const double expected = Ciede2000(LinearSrgbToLab(0.18f, 0.18f, 0.18f),
                                    LinearSrgbToLab(0.2f, 0.2f, 0.2f));
  const DeltaE2000Result r = DeltaE2000(a, b);
  EXPECT_NEAR(r.mean, expected, 1e-6);
  EXPECT_NEAR(r.p95, expected, 1e-6);
  // Exposure +1 stop doubles the linear values before conversion.
  DeltaE2000Parameters p;
  p.exposure_stops = 1.0f;
  EXPECT_NEAR(DeltaE2000(a, b, p).mean,
              Ciede2000(LinearSrgbToLab(0.36, 0.36, 0.36), LinearSrgbToLab(0.4, 0.4, 0.4)),
              1e-5);
}

TEST(Ciede2000Test, MoreNoiseGivesLargerDifference) {
  const Image ref = testing::LdrScene(32, 32);
  double previous = 0.0;
  for (float amplitude : {0.01f, 0.05f, 0.2f}) {
    const double mean = DeltaE2000(ref, testing::LdrDistorted(ref, amplitude, 2)).mean;
    EXPECT_GT(mean, previous);
    previous = mean;
  }
}

}  // namespace
}  // namespace shadefit::metrics
