// What a ComputeMetrics call keeps of its inputs for a later call (KeptTerms::inputs, report.h):
// defined here for report.cpp and the tests (not installed).
#pragma once

#include "flip_map.h"
#include "shadefit/render/image.h"

namespace shadefit::metrics::internal {

// The keeping call's images over its window, their display encodings (RGB and luminance, as
// ComputeMetrics encodes them) and its test's FLIP halves.
struct KeptInputs {
  int x0 = 0, y0 = 0;  // The window's corner in the frame.
  float exposure_stops = 0.0f;
  Image ref, tst;
  Image ref_display, tst_display, ref_y, tst_y;
  FlipTestHalves flip;
};

}  // namespace shadefit::metrics::internal
