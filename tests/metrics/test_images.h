// Deterministic synthetic images shared by the metrics tests (and used once to write the FLIP
// inputs committed in tests/metrics/data/, see flip_test.cpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>

#include "shadefit/render/image.h"

namespace shadefit::metrics::testing {

// Portable per-pixel noise in [-1, 1] (integer hash; independent of the standard library).
inline float HashNoise(std::uint32_t x, std::uint32_t y, std::uint32_t c, std::uint32_t seed) {
  std::uint32_t h = x * 374761393u + y * 668265263u + c * 2246822519u + seed * 3266489917u;
  h = (h ^ (h >> 13)) * 1274126177u;
  h ^= h >> 16;
  return static_cast<float>(h & 0xFFFFFFu) / static_cast<float>(0xFFFFFF) * 2.0f - 1.0f;
}

// Display-referred scene in linear [0, 1]: a diagonal colour gradient, a checkerboard block with
// sharp edges, a saturated disk and a thin line.
inline Image LdrScene(int w, int h) {
  Image img(w, h, 3);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const float u = (x + 0.5f) / w, v = (y + 0.5f) / h;
      float rgb[3] = {0.15f + 0.6f * u, 0.2f + 0.5f * v, 0.6f - 0.4f * u * v};
      if (x < w / 2 && y < h / 2 && ((x / 4 + y / 4) % 2 == 0)) rgb[0] = rgb[1] = rgb[2] = 0.9f;
      const float dx = u - 0.7f, dy = v - 0.65f;
      if (dx * dx + dy * dy < 0.04f) {
        rgb[0] = 0.8f;
        rgb[1] = 0.1f;
        rgb[2] = 0.05f;
      }
      if (x == w / 4 + y / 3) rgb[0] = rgb[1] = rgb[2] = 0.02f;
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = rgb[c];
    }
  }
  return img;
}

// The LDR test image: the scene with a hue shift in the disk, a slight blur-free brightness
// change and +-amplitude noise.
inline Image LdrDistorted(const Image& ref, float amplitude, std::uint32_t seed) {
  Image img = ref;
  for (int y = 0; y < ref.height; ++y) {
    for (int x = 0; x < ref.width; ++x) {
      for (int c = 0; c < 3; ++c) {
        float v = ref.at(x, y, c) * (c == 1 ? 1.05f : 0.97f);
        v += amplitude * HashNoise(x, y, c, seed);
        img.at(x, y, c) = std::clamp(v, 0.0f, 1.0f);
      }
    }
  }
  return img;
}

// HDR scene in linear radiance: dim background (~0.02-0.3), a mid-grey block, a bright
// emitter (~20) and a gradient sky band (~1-4).
inline Image HdrScene(int w, int h) {
  Image img(w, h, 3);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const float u = (x + 0.5f) / w, v = (y + 0.5f) / h;
      float rgb[3] = {0.02f + 0.3f * u, 0.03f + 0.2f * v, 0.05f + 0.1f * u * v};
      if (y < h / 4) {
        rgb[0] = 1.0f + 3.0f * u;
        rgb[1] = 1.5f + 2.0f * u;
        rgb[2] = 2.5f + 1.5f * u;
      }
      if (x > w / 2 && y > h / 2 && x < w - 8 && y < h - 8) rgb[0] = rgb[1] = rgb[2] = 0.18f;
      const float dx = u - 0.25f, dy = v - 0.7f;
      if (dx * dx + dy * dy < 0.006f) {
        rgb[0] = 22.0f;
        rgb[1] = 18.0f;
        rgb[2] = 12.0f;
      }
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = rgb[c];
    }
  }
  return img;
}

// The HDR test image: 10 % brighter, multiplicative noise and two fireflies.
inline Image HdrDistorted(const Image& ref, float amplitude, std::uint32_t seed) {
  Image img = ref;
  for (int y = 0; y < ref.height; ++y) {
    for (int x = 0; x < ref.width; ++x) {
      for (int c = 0; c < 3; ++c) {
        img.at(x, y, c) = ref.at(x, y, c) * 1.1f * (1.0f + amplitude * HashNoise(x, y, c, seed));
      }
    }
  }
  // Fireflies only where the image has the pixel: ssim_test passes a 48 x 48 scene, and the
  // write at row 50 landed past the end of the buffer (AddressSanitizer, heap-buffer-overflow;
  // the image itself was never changed by it, so skipping it keeps every golden value).
  auto firefly = [&](int x, int y, float v) {
    if (x >= img.width || y >= img.height) return;
    for (int c = 0; c < 3; ++c) img.at(x, y, c) = v;
  };
  firefly(40, 20, 50.0f);
  firefly(10, 50, 8.0f);
  return img;
}

// Gaussian noise image of standard deviation sigma around `base` (std::mt19937 fixed seed).
inline Image AddGaussianNoise(const Image& base, double sigma, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, sigma);
  Image out = base;
  for (float& v : out.data) v = static_cast<float>(v + normal(rng));
  return out;
}

}  // namespace shadefit::metrics::testing
