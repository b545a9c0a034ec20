// Delta E_ITP (ITU-R BT.2124) against values derived without the code under test: a hand
// computation for neutral pairs and an independent numpy script for chromatic ones.
#include "shadefit/metrics/delta_e_itp.h"

#include <gtest/gtest.h>

#include <cmath>

#include "shadefit/base/error.h"

namespace shadefit::metrics {
namespace {

// SMPTE ST 2084 typed again here (not the library's PqInverseEotf), for the neutral pairs.
double PqByHand(double cd_m2) {
  const double m1 = 0.1593017578125, m2 = 78.84375;  // 2610/16384, 2523/4096 * 128
  const double c1 = 0.8359375, c2 = 18.8515625, c3 = 18.6875;
  const double y = std::pow(cd_m2 / 10000.0, m1);
  return std::pow((c1 + c2 * y) / (1.0 + c3 * y), m2);
}

// PQ(100 cd/m^2) by hand: y = 0.01^m1 = exp(-4.605170 * 0.159302) = 0.480150;
// (0.835938 + 18.851563 y) / (1 + 18.6875 y) = 9.887523 / 9.972803 = 0.991449;
// 0.991449^78.84375 = exp(-0.0085877 * 78.84375) = 0.50808. ITU-R BT.2408 Table 1 lists
// 100 cd/m^2 at 51 % PQ signal and 203 cd/m^2 (HDR reference white) at 58 %. The script in
// data/delta_e_itp_reference.py gives 0.508078421517399 and 0.440281573420461 for 50 cd/m^2.
TEST(DeltaEItpTest, PqKnownValues) {
  EXPECT_NEAR(PqInverseEotf(100.0), 0.508078421517399, 1e-12);
  EXPECT_NEAR(PqInverseEotf(50.0), 0.440281573420461, 1e-12);
  EXPECT_NEAR(PqInverseEotf(203.0), 0.58, 0.005);
  EXPECT_NEAR(PqInverseEotf(10000.0), 1.0, 1e-12);
  EXPECT_NEAR(PqInverseEotf(20000.0), 1.0, 1e-12);  // Clamped at PQ's peak.
  EXPECT_NEAR(PqInverseEotf(0.0), std::pow(0.8359375, 78.84375), 1e-15);  // c1^m2, not 0.
}

// A neutral colour has R = G = B in Rec. 709 and Rec. 2020 (BT.2087's rows sum to 1) and
// L = M = S (BT.2100's LMS rows sum to 4096/4096), so Ct = Cp = 0 (those rows sum to 0) and
// I = PQ(Y): Delta E_ITP = 720 |PQ(Y1) - PQ(Y2)|. White 1.0 vs grey 0.5 at 100 cd/m^2:
// 720 (0.508078 - 0.440282) = 48.8137.
TEST(DeltaEItpTest, NeutralPairIsTheIntensityDifference) {
  const Ictcp white = Rec709LuminanceToIctcp(100.0, 100.0, 100.0);
  EXPECT_NEAR(white.i, PqByHand(100.0), 1e-12);
  EXPECT_NEAR(white.ct, 0.0, 1e-12);
  EXPECT_NEAR(white.cp, 0.0, 1e-12);
  const Ictcp grey = Rec709LuminanceToIctcp(50.0, 50.0, 50.0);
  EXPECT_NEAR(DeltaItp(white, grey), 720.0 * (PqByHand(100.0) - PqByHand(50.0)), 1e-9);
  EXPECT_NEAR(DeltaItp(white, grey), 48.8137, 1e-4);

  // Through the image function, with the white luminance: at 203 cd/m^2 per 1.0 the same pair
  // is 203 vs 101.5 cd/m^2.
  const Image a(4, 3, 3, 1.0f), b(4, 3, 3, 0.5f);
  EXPECT_NEAR(DeltaEItp(a, b).mean, 48.8137, 1e-4);
  DeltaEItpParameters p;
  p.white_luminance = 203.0;
  // The map is stored as float: 1e-4.
  EXPECT_NEAR(DeltaEItp(a, b, p).mean, 720.0 * (PqByHand(203.0) - PqByHand(101.5)), 1e-4);
}

// Chromatic pairs (linear Rec. 709, 1.0 = 100 cd/m^2) against data/delta_e_itp_reference.py,
// which derives the Rec. 709 -> 2020 matrix from the primaries' chromaticities instead of using
// BT.2087's four-decimal table. Its output (numpy 1.24.2):
//   (0.8, 0.2, 0.1) (0.7, 0.25, 0.1) 19.624577
//   (0.1, 0.3, 0.9) (0.1, 0.3, 0.6) 18.642684
//   (0.5, 0.5, 0.5) (0.5, 0.45, 0.55) 8.836787
//   (4.0, 3.0, 1.0) (3.0, 3.0, 1.5) 24.447665
// The tolerance covers the table's rounding (entries differ by up to 6e-5 from the derived
// matrix); a swapped matrix entry or a missing 0.5 on Ct moves these values by far more.
TEST(DeltaEItpTest, ChromaticPairsMatchIndependentScript) {
  struct Pair {
    double a[3], b[3], expected;
  };
  constexpr Pair kPairs[] = {
      {{0.8, 0.2, 0.1}, {0.7, 0.25, 0.1}, 19.624577},
      {{0.1, 0.3, 0.9}, {0.1, 0.3, 0.6}, 18.642684},
      {{0.5, 0.5, 0.5}, {0.5, 0.45, 0.55}, 8.836787},
      {{4.0, 3.0, 1.0}, {3.0, 3.0, 1.5}, 24.447665},
  };
  for (const Pair& pair : kPairs) {
    const Ictcp a = Rec709LuminanceToIctcp(100 * pair.a[0], 100 * pair.a[1], 100 * pair.a[2]);
    const Ictcp b = Rec709LuminanceToIctcp(100 * pair.b[0], 100 * pair.b[1], 100 * pair.b[2]);
    EXPECT_NEAR(DeltaItp(a, b), pair.expected, 5e-3) << pair.a[0] << " " << pair.b[0];
    EXPECT_DOUBLE_EQ(DeltaItp(a, b), DeltaItp(b, a));  // Symmetric.
  }
}

TEST(DeltaEItpTest, ImageStatisticsMaskAndMap) {
  // Two pixels differ (the first and second chromatic pairs above), the rest are equal.
  Image a(10, 10, 3, 0.3f), b = a;
  const float pair1[2][3] = {{0.8f, 0.2f, 0.1f}, {0.7f, 0.25f, 0.1f}};
  const float pair2[2][3] = {{0.1f, 0.3f, 0.9f}, {0.1f, 0.3f, 0.6f}};
  for (int c = 0; c < 3; ++c) {
    a.at(2, 3, c) = pair1[0][c];
    b.at(2, 3, c) = pair1[1][c];
    a.at(7, 7, c) = pair2[0][c];
    b.at(7, 7, c) = pair2[1][c];
  }
  Image map;
  const DeltaEItpResult r = DeltaEItp(a, b, {}, &map);
  EXPECT_NEAR(r.mean, (19.624577 + 18.642684) / 100.0, 1e-4);
  EXPECT_NEAR(r.max, 19.624577, 5e-3);
  EXPECT_EQ(r.p95, 0.0);  // 98 of 100 pixels are equal.
  EXPECT_EQ(map.channels, 1);
  EXPECT_NEAR(map.at(7, 7, 0), 18.642684, 5e-3);

  // Masked: only the first pair's pixel and one equal pixel count.
  Image mask(10, 10, 1, 0.0f);
  mask.at(2, 3, 0) = 1.0f;
  mask.at(0, 0, 0) = 1.0f;
  DeltaEItpParameters p;
  p.mask = &mask;
  const DeltaEItpResult m = DeltaEItp(a, b, p, &map);
  EXPECT_NEAR(m.mean, 19.624577 / 2.0, 5e-3);
  EXPECT_TRUE(std::isnan(map.at(7, 7, 0)));
  EXPECT_EQ(DeltaEItp(a, a).max, 0.0);
}

TEST(DeltaEItpTest, RejectsBadInputs) {
  const Image a(4, 4, 3, 0.5f), b(4, 5, 3, 0.5f);
  EXPECT_THROW(DeltaEItp(a, b), Error);
  DeltaEItpParameters p;
  p.white_luminance = 0.0;
  EXPECT_THROW(DeltaEItp(a, a, p), Error);
}

}  // namespace
}  // namespace shadefit::metrics
