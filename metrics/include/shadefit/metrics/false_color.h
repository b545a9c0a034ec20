// False-colour rendering of one-channel metric maps, with a labelled colour bar.
#pragma once

#include <limits>
#include <string>

#include "shadefit/render/image.h"

namespace shadefit::metrics {

enum class ColorMap {
  kViridis,  // Perceptually uniform, colour-blind safe (Smith & van der Walt 2015, matplotlib).
  kMagma,    // Same family; the FLIP papers show their maps in magma.
};

struct FalseColorParameters {
  ColorMap color_map = ColorMap::kViridis;
  // Value mapped to the first / last table entry (values outside are clamped). NaN: min / max
  // of the map's finite values (min 0 when all values are >= 0).
  double min = std::numeric_limits<double>::quiet_NaN();
  double max = std::numeric_limits<double>::quiet_NaN();
  // Colour bar to the right of the map with min and max labels; false: the map alone.
  bool color_bar = true;
  // Colour of NaN pixels (masked out), display-encoded sRGB.
  float nan_gray = 0.5f;
};

// One-channel map -> display-encoded RGB in [0, 1]. Each value v selects table entry
// round(255 (v - min) / (max - min)); with a colour bar the image grows by a strip on the right
// (gradient from min at the bottom to max at the top, labelled with both values).
Image FalseColor(const Image& scalar_map, const FalseColorParameters& p = {});

// FalseColor() written as an 8-bit PNG (atomic; throws shadefit::Error naming the path).
void WriteFalseColorPng(const std::string& path, const Image& scalar_map,
                        const FalseColorParameters& p = {});

}  // namespace shadefit::metrics
