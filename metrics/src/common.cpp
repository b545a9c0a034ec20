#include "shadefit/metrics/common.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cstdint>
#include <cmath>

#include "internal.h"
#include "shadefit/base/cpus.h"
#include "shadefit/base/error.h"

namespace shadefit::metrics {
namespace {

std::string SizeString(const Image& image) {
  return std::to_string(image.width) + "x" + std::to_string(image.height);
}

// A float is NaN or infinite when its exponent bits are all set.
bool AllFinite(const Image& image) {
  std::uint32_t non_finite = 0;  // One pass without a branch, which the compiler vectorises.
  for (const float v : image.data) {
    non_finite |= (~std::bit_cast<std::uint32_t>(v) & 0x7F800000u) == 0 ? 1u : 0u;
  }
  return non_finite == 0;
}

void CheckFinite(const Image& image, const std::string& name) {
  if (AllFinite(image)) return;
  for (std::size_t i = 0; i < image.data.size(); ++i) {
    if (!std::isfinite(image.data[i])) {
      const std::size_t pixel = i / image.channels;
      throw Error(name, "pixels",
                  std::string(std::isnan(image.data[i]) ? "NaN" : "infinite") + " value at (" +
                      std::to_string(pixel % image.width) + ", " +
                      std::to_string(pixel / image.width) + ") channel " +
                      std::to_string(i % image.channels));
    }
  }
}

// Set by internal::CheckedInputs.
thread_local bool inputs_checked = false;

}  // namespace

namespace internal {
CheckedInputs::CheckedInputs() : was_(inputs_checked) { inputs_checked = true; }
CheckedInputs::~CheckedInputs() { inputs_checked = was_; }
}  // namespace internal

void ValidateInputs(const Image& reference, const Image& test, const Image* mask,
                    int min_channels, const InputNames& names) {
  if (reference.empty()) throw Error(names.reference, "resolution", "image has no pixels");
  if (test.empty()) throw Error(names.test, "resolution", "image has no pixels");
  if (test.width != reference.width || test.height != reference.height) {
    throw Error(names.test, "resolution",
                SizeString(test) + " differs from the reference's " + SizeString(reference) +
                    " (" + names.reference + ")");
  }
  if (reference.channels < min_channels) {
    throw Error(names.reference, "channels",
                "has " + std::to_string(reference.channels) + ", needs at least " +
                    std::to_string(min_channels));
  }
  if (test.channels < min_channels) {
    throw Error(names.test, "channels",
                "has " + std::to_string(test.channels) + ", needs at least " +
                    std::to_string(min_channels));
  }
  if (min_channels == 0 && test.channels != reference.channels) {
    throw Error(names.test, "channels",
                "has " + std::to_string(test.channels) + ", the reference has " +
                    std::to_string(reference.channels));
  }
  // Inside ComputeMetrics these images are windows or clipped encodings of inputs it checked
  // (internal::CheckedInputs): scanning them again was ~2% of a photo job's time.
  const bool checked = inputs_checked;
  if (!checked) {
    CheckFinite(reference, names.reference);
    CheckFinite(test, names.test);
  }
  if (mask == nullptr) return;
  if (mask->empty()) throw Error(names.mask, "resolution", "mask has no pixels");
  if (mask->width != reference.width || mask->height != reference.height) {
    throw Error(names.mask, "resolution",
                SizeString(*mask) + " differs from the reference's " + SizeString(reference));
  }
  if (mask->channels != 1) {
    throw Error(names.mask, "channels",
                "mask must have 1 channel, has " + std::to_string(mask->channels));
  }
  if (checked) return;
  CheckFinite(*mask, names.mask);
  if (CountValidPixels(mask, mask->width, mask->height) == 0) {
    throw Error(names.mask, "pixels", "empty mask (no pixel > 0.5)");
  }
}

namespace {
std::atomic<int> metrics_threads{0};
}  // namespace

void SetMetricsThreads(int threads) { metrics_threads = std::max(0, threads); }

int MetricsThreads() {
  const int set = metrics_threads.load();
  if (set > 0) return std::min(set, 16);
  return std::clamp(UsableCpus(), 1, 16);
}

std::size_t CountValidPixels(const Image* mask, int width, int height) {
  const std::size_t n = static_cast<std::size_t>(width) * height;
  if (mask == nullptr) return n;
  std::size_t count = 0;
  for (std::size_t i = 0; i < n; ++i) count += mask->data[i] > 0.5f ? 1 : 0;
  return count;
}

Image Luminance(const Image& linear_rgb) {
  Image out(linear_rgb.width, linear_rgb.height, 1);
  const int c = linear_rgb.channels;
  for (std::size_t i = 0; i < out.PixelCount(); ++i) {
    const float* p = &linear_rgb.data[i * c];
    // Rec. 709 / sRGB luminance weights (the Y row of the RGB -> XYZ matrix).
    out.data[i] = 0.2126f * p[0] + 0.7152f * p[1] + 0.0722f * p[2];
  }
  return out;
}

Image DisplayEncode(const Image& linear, float exposure_stops) {
  const float scale = std::exp2(exposure_stops);
  Image out = linear;
  for (float& v : out.data) v = std::min(1.0f, SrgbOetf(v * scale));  // OETF maps <= 0 to 0.
  return out;
}

Image ExposeAndClip(const Image& linear_rgb, float exposure_stops) {
  const float scale = std::exp2(exposure_stops);
  Image out = linear_rgb.channels == 3 ? linear_rgb : linear_rgb.Channels(0, 3);
  for (float& v : out.data) v = std::clamp(v * scale, 0.0f, 1.0f);
  return out;
}

}  // namespace shadefit::metrics
