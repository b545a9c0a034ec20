#include "shadefit/metrics/delta_e_itp.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "internal.h"
#include "reference_cache.h"
#include "shadefit/metrics/common.h"
#include "shadefit/base/error.h"

namespace shadefit::metrics {
namespace {

// ITU-R BT.2087-0, eq. 4: linear Rec. 709 RGB -> linear Rec. 2020 RGB (both D65; the standard
// prints the matrix to four decimals, and each row sums to 1 so neutrals stay neutral).
constexpr double kRec709ToRec2020[3][3] = {
    {0.6274, 0.3293, 0.0433},
    {0.0691, 0.9195, 0.0114},
    {0.0164, 0.0880, 0.8956},
};

// ITU-R BT.2100-2, Table 6: linear Rec. 2020 RGB -> LMS (includes the 4 % crosstalk), in
// 1/4096 units; each row sums to 4096.
constexpr double kRec2020ToLms[3][3] = {
    {1688.0 / 4096.0, 2146.0 / 4096.0, 262.0 / 4096.0},
    {683.0 / 4096.0, 2951.0 / 4096.0, 462.0 / 4096.0},
    {99.0 / 4096.0, 309.0 / 4096.0, 3688.0 / 4096.0},
};

// ITU-R BT.2100-2, Table 7: PQ-encoded L'M'S' -> I, Ct, Cp; the Ct and Cp rows sum to 0.
constexpr double kLmsToIctcp[3][3] = {
    {2048.0 / 4096.0, 2048.0 / 4096.0, 0.0},
    {6610.0 / 4096.0, -13613.0 / 4096.0, 7003.0 / 4096.0},
    {17933.0 / 4096.0, -17390.0 / 4096.0, -543.0 / 4096.0},
};

void Multiply(const double m[3][3], const double in[3], double out[3]) {
  for (int row = 0; row < 3; ++row) {
    out[row] = m[row][0] * in[0] + m[row][1] * in[1] + m[row][2] * in[2];
  }
}

}  // namespace

double PqInverseEotf(double luminance_cd_m2) {
  // SMPTE ST 2084:2014, eq. 5.2; the constants are exact ratios from the standard.
  constexpr double kM1 = 2610.0 / 16384.0;
  constexpr double kM2 = 2523.0 / 4096.0 * 128.0;
  constexpr double kC1 = 3424.0 / 4096.0;  // c3 - c2 + 1.
  constexpr double kC2 = 2413.0 / 4096.0 * 32.0;
  constexpr double kC3 = 2392.0 / 4096.0 * 32.0;
  constexpr double kPeak = 10000.0;  // cd/m^2 at signal 1.
  const double y = std::clamp(luminance_cd_m2 / kPeak, 0.0, 1.0);
  const double y_m1 = std::pow(y, kM1);
  return std::pow((kC1 + kC2 * y_m1) / (1.0 + kC3 * y_m1), kM2);
}

Ictcp Rec709LuminanceToIctcp(double r, double g, double b) {
  const double rgb709[3] = {r, g, b};
  double rgb2020[3], lms[3], lms_pq[3], ictcp[3];
  Multiply(kRec709ToRec2020, rgb709, rgb2020);
  Multiply(kRec2020ToLms, rgb2020, lms);
  for (int c = 0; c < 3; ++c) lms_pq[c] = PqInverseEotf(std::max(lms[c], 0.0));
  Multiply(kLmsToIctcp, lms_pq, ictcp);
  return {ictcp[0], ictcp[1], ictcp[2]};
}

double DeltaItp(const Ictcp& reference, const Ictcp& test) {
  // BT.2124-0, eq. 1 and section 2: T = 0.5 Ct makes the tritan axis's just-noticeable steps as
  // large as the other two's; 720 makes 1 a just noticeable difference.
  const double di = test.i - reference.i;
  const double dt = 0.5 * (test.ct - reference.ct);
  const double dp = test.cp - reference.cp;
  return 720.0 * std::sqrt(di * di + dt * dt + dp * dp);
}

DeltaEItpResult DeltaEItp(const Image& reference, const Image& test,
                          const DeltaEItpParameters& p, Image* error_map) {
  ValidateInputs(reference, test, p.mask, 3);
  if (!(std::isfinite(p.white_luminance) && p.white_luminance > 0.0)) {
    throw Error("", "white_luminance", "must be a positive number of cd/m^2");
  }
  const std::size_t channels = static_cast<std::size_t>(reference.channels);
  const double scale = p.white_luminance;
  const int w = reference.width, h = reference.height;
  using Values = internal::ValidPixelValues<Ictcp>;
  const ReferenceCache::Impl::Key key{
      ReferenceCache::Impl::Kind::kIctcp, p.reference_cache ? HashPixels(reference) : 0,
      p.reference_cache && p.mask ? HashPixels(*p.mask) : 0, {scale, 0.0, 0.0}};
  const std::shared_ptr<const Values> ref_ictcp = FindOrMake<Values>(
      p.reference_cache, key,
      [&] {
        return internal::AtValidPixels<Ictcp>(w, h, p.mask, [&](std::size_t i) {
          const float* a = &reference.data[channels * i];
          return Rec709LuminanceToIctcp(scale * a[0], scale * a[1], scale * a[2]);
        });
      },
      [](const Values& v) { return v.Bytes(); });
  Image map = internal::PointWiseMap(*ref_ictcp, w, h, p.mask, [&](const Ictcp& r, std::size_t i) {
    const float* b = &test.data[channels * i];
    return DeltaItp(r, Rec709LuminanceToIctcp(scale * b[0], scale * b[1], scale * b[2]));
  });
  const internal::MapStatistics s = internal::SummarizeMap(map, p.mask);
  DeltaEItpResult result;
  result.mean = s.mean;
  result.p95 = s.p95;
  result.max = s.max;
  if (error_map) *error_map = std::move(map);
  return result;
}

}  // namespace shadefit::metrics
