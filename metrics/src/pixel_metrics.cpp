#include "shadefit/metrics/pixel_metrics.h"

#include <cmath>
#include <limits>

#include "internal.h"
#include "shadefit/metrics/common.h"

namespace shadefit::metrics {
namespace {

// mean over valid pixels and all channels of term(r, t), accumulated in double.
template <typename Term>
double MaskedMean(const Image& reference, const Image& test, const Image* mask, Term term) {
  ValidateInputs(reference, test, mask, 0);
  const int c = reference.channels;
  double sum = 0.0;
  std::size_t count = 0;
  for (std::size_t i = 0; i < reference.PixelCount(); ++i) {
    if (!internal::IsValid(mask, i)) continue;
    for (int k = 0; k < c; ++k) {
      sum += term(static_cast<double>(reference.data[i * c + k]),
                  static_cast<double>(test.data[i * c + k]));
    }
    count += c;
  }
  return sum / static_cast<double>(count);
}

template <typename Term>
Image MaskedMap(const Image& reference, const Image& test, const Image* mask, Term term) {
  ValidateInputs(reference, test, mask, 0);
  const int c = reference.channels;
  Image map(reference.width, reference.height, 1);
  for (std::size_t i = 0; i < reference.PixelCount(); ++i) {
    if (!internal::IsValid(mask, i)) {
      map.data[i] = std::numeric_limits<float>::quiet_NaN();
      continue;
    }
    double sum = 0.0;
    for (int k = 0; k < c; ++k) sum += term(reference.data[i * c + k], test.data[i * c + k]);
    map.data[i] = static_cast<float>(sum / c);
  }
  return map;
}

}  // namespace

double Rmse(const Image& reference, const Image& test, const PixelMetricParameters& p) {
  return std::sqrt(MaskedMean(reference, test, p.mask, [](double r, double t) {
    return (t - r) * (t - r);
  }));
}

double RelativeRmse(const Image& reference, const Image& test, const PixelMetricParameters& p) {
  const double eps = p.relative_epsilon;
  return std::sqrt(MaskedMean(reference, test, p.mask, [eps](double r, double t) {
    const double e = (t - r) / (std::abs(r) + eps);
    return e * e;
  }));
}

double LogRmse(const Image& reference, const Image& test, const PixelMetricParameters& p) {
  return std::sqrt(MaskedMean(reference, test, p.mask, [](double r, double t) {
    const double d = std::log1p(std::max(t, 0.0)) - std::log1p(std::max(r, 0.0));
    return d * d;
  }));
}

double MeanAbsoluteError(const Image& reference, const Image& test,
                         const PixelMetricParameters& p) {
  return MaskedMean(reference, test, p.mask, [](double r, double t) { return std::abs(t - r); });
}

double Psnr(const Image& reference, const Image& test, const PsnrParameters& p) {
  ValidateInputs(reference, test, p.mask, 0);
  return internal::PsnrOfEncoded(DisplayEncode(reference, p.exposure_stops),
                                 DisplayEncode(test, p.exposure_stops), p.mask);
}

double internal::PsnrOfEncoded(const Image& reference, const Image& test, const Image* mask) {
  const double mse = MaskedMean(reference, test, mask,
                                [](double a, double b) { return (b - a) * (b - a); });
  if (mse == 0.0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(1.0 / mse);  // Peak value 1 after the display transform.
}

Image AbsoluteErrorMap(const Image& reference, const Image& test, const Image* mask) {
  return MaskedMap(reference, test, mask, [](double r, double t) { return std::abs(t - r); });
}

Image RelativeErrorMap(const Image& reference, const Image& test, float relative_epsilon,
                       const Image* mask) {
  const double eps = relative_epsilon;
  return MaskedMap(reference, test, mask, [eps](double r, double t) {
    return std::abs(t - r) / (std::abs(r) + eps);
  });
}

}  // namespace shadefit::metrics
