#include "shadefit/fit/training_pixels.h"

#include <algorithm>
#include <utility>

namespace shadefit::fit {

reference_images::Reference TrainingPixels(reference_images::Reference ref, int stride) {
  stride = std::max(1, stride);
  if (stride == 1 && ref.extrapolated_share.empty() && ref.shadow_edge.empty() &&
      ref.interreflection.empty()) {
    return ref;
  }
  Image mask(ref.image.width, ref.image.height, 1, 0.0f);
  for (int y = 0; y < mask.height; y += stride) {
    for (int x = 0; x < mask.width; x += stride) {
      const bool use = (ref.mask.empty() || ref.mask.at(x, y, 0) > 0.5f) &&
                       reference_images::IsMeasuredPixel(ref, x, y);
      mask.at(x, y, 0) = use ? 1.f : 0.f;
    }
  }
  ref.mask = std::move(mask);
  return ref;
}

}  // namespace shadefit::fit
