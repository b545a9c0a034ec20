#include "shadefit/metrics/ciede2000.h"

#include <cmath>
#include <limits>
#include <numbers>

#include "internal.h"
#include "reference_cache.h"
#include "shadefit/metrics/common.h"

namespace shadefit::metrics {
namespace {

constexpr double kPi = std::numbers::pi;
double Radians(double degrees) { return degrees * kPi / 180.0; }
double Degrees(double radians) { return radians * 180.0 / kPi; }

// Hue angle in degrees, [0, 360); 0 for a neutral colour (Sharma et al. Eq. 4).
double HueDegrees(double b, double a_prime) {
  if (b == 0.0 && a_prime == 0.0) return 0.0;
  const double h = Degrees(std::atan2(b, a_prime));
  return h < 0.0 ? h + 360.0 : h;
}

// CIELAB companding f(t) (CIE 15:2004): cube root above (6/29)^3, linear segment below.
double LabF(double t) {
  constexpr double kDelta = 6.0 / 29.0;
  return t > kDelta * kDelta * kDelta ? std::cbrt(t) : t / (3.0 * kDelta * kDelta) + 4.0 / 29.0;
}

}  // namespace

double Ciede2000(const Lab& reference, const Lab& test, const Ciede2000Parameters& p) {
  const double pow25_7 = 6103515625.0;  // 25^7 (Eq. 2 and 17).
  // Eq. 2-3: a* rescaled by G so neutral colours keep their hue stable.
  const double c1 = std::hypot(reference.a, reference.b);
  const double c2 = std::hypot(test.a, test.b);
  const double c_mean = 0.5 * (c1 + c2);
  const double c_mean7 = std::pow(c_mean, 7.0);
  const double g = 0.5 * (1.0 - std::sqrt(c_mean7 / (c_mean7 + pow25_7)));
  const double a1 = (1.0 + g) * reference.a;
  const double a2 = (1.0 + g) * test.a;
  // Eq. 3-4: C'_i, h'_i.
  const double cp1 = std::hypot(a1, reference.b);
  const double cp2 = std::hypot(a2, test.b);
  const double h1 = HueDegrees(reference.b, a1);
  const double h2 = HueDegrees(test.b, a2);
  // Eq. 5-8: differences.
  const double dl = test.l - reference.l;
  const double dc = cp2 - cp1;
  double dh = 0.0;
  if (cp1 * cp2 != 0.0) {
    dh = h2 - h1;
    if (dh > 180.0) dh -= 360.0;
    if (dh < -180.0) dh += 360.0;
  }
  const double d_big_h = 2.0 * std::sqrt(cp1 * cp2) * std::sin(Radians(dh) / 2.0);
  // Eq. 9-14: means; the hue mean takes the short way round the circle.
  const double l_mean = 0.5 * (reference.l + test.l);
  const double cp_mean = 0.5 * (cp1 + cp2);
  double h_mean = h1 + h2;
  if (cp1 * cp2 != 0.0) {
    if (std::abs(h1 - h2) <= 180.0) {
      h_mean = 0.5 * (h1 + h2);
    } else if (h1 + h2 < 360.0) {
      h_mean = 0.5 * (h1 + h2 + 360.0);
    } else {
      h_mean = 0.5 * (h1 + h2 - 360.0);
    }
  }
  const double t = 1.0 - 0.17 * std::cos(Radians(h_mean - 30.0)) +
                   0.24 * std::cos(Radians(2.0 * h_mean)) +
                   0.32 * std::cos(Radians(3.0 * h_mean + 6.0)) -
                   0.20 * std::cos(Radians(4.0 * h_mean - 63.0));  // Eq. 15
  const double d_theta = 30.0 * std::exp(-std::pow((h_mean - 275.0) / 25.0, 2.0));  // Eq. 16
  const double cp_mean7 = std::pow(cp_mean, 7.0);
  const double r_c = 2.0 * std::sqrt(cp_mean7 / (cp_mean7 + pow25_7));  // Eq. 17
  const double l50 = (l_mean - 50.0) * (l_mean - 50.0);
  const double s_l = 1.0 + 0.015 * l50 / std::sqrt(20.0 + l50);  // Eq. 18
  const double s_c = 1.0 + 0.045 * cp_mean;                       // Eq. 19
  const double s_h = 1.0 + 0.015 * cp_mean * t;                   // Eq. 20
  const double r_t = -std::sin(Radians(2.0 * d_theta)) * r_c;     // Eq. 21
  const double tl = dl / (p.k_l * s_l);
  const double tc = dc / (p.k_c * s_c);
  const double th = d_big_h / (p.k_h * s_h);
  return std::sqrt(tl * tl + tc * tc + th * th + r_t * tc * th);  // Eq. 22
}

Lab LinearSrgbToLab(double r, double g, double b) {
  // IEC 61966-2-1 linear sRGB -> XYZ (D65); the white is the matrix row sums.
  const double x = 0.4124 * r + 0.3576 * g + 0.1805 * b;
  const double y = 0.2126 * r + 0.7152 * g + 0.0722 * b;
  const double z = 0.0193 * r + 0.1192 * g + 0.9505 * b;
  constexpr double kXn = 0.4124 + 0.3576 + 0.1805;
  constexpr double kYn = 1.0;
  constexpr double kZn = 0.0193 + 0.1192 + 0.9505;
  const double fx = LabF(x / kXn), fy = LabF(y / kYn), fz = LabF(z / kZn);
  return {116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)};
}

DeltaE2000Result DeltaE2000(const Image& reference, const Image& test,
                            const DeltaE2000Parameters& p, Image* error_map) {
  ValidateInputs(reference, test, p.mask, 3);
  const int w = reference.width, h = reference.height;
  using Values = internal::ValidPixelValues<Lab>;
  const ReferenceCache::Impl::Key key{
      ReferenceCache::Impl::Kind::kLab, p.reference_cache ? HashPixels(reference) : 0,
      p.reference_cache && p.mask ? HashPixels(*p.mask) : 0, {p.exposure_stops, 0.0, 0.0}};
  const std::shared_ptr<const Values> ref_lab = FindOrMake<Values>(
      p.reference_cache, key,
      [&] {
        const Image r = ExposeAndClip(reference, p.exposure_stops);
        return internal::AtValidPixels<Lab>(w, h, p.mask, [&](std::size_t i) {
          const float* a = &r.data[3 * i];
          return LinearSrgbToLab(a[0], a[1], a[2]);
        });
      },
      [](const Values& v) { return v.Bytes(); });
  const Image t = ExposeAndClip(test, p.exposure_stops);
  Image map = internal::PointWiseMap(*ref_lab, w, h, p.mask, [&](const Lab& r, std::size_t i) {
    const float* b = &t.data[3 * i];
    return Ciede2000(r, LinearSrgbToLab(b[0], b[1], b[2]), p.weights);
  });
  const internal::MapStatistics s = internal::SummarizeMap(map, p.mask);
  DeltaE2000Result result;
  result.mean = s.mean;
  result.p95 = s.p95;
  result.max = s.max;
  if (error_map) *error_map = std::move(map);
  return result;
}

}  // namespace shadefit::metrics
