// The pixels a fit trains on: one rule for the study runner, `shadefit fit` and shadefit.fit()
// (docs/fitting.md, "Training pixels").
#pragma once

#include "shadefit/reference_images/reference.h"

namespace shadefit::fit {

// `ref` with its mask narrowed to the pixels a fit trains on: those its own mask keeps (all
// without one), in its measured domain (a measured reference: reference_images::IsMeasuredPixel,
// so that no fit chases values its BRDF only extrapolates; docs/measured_and_imported.md, "The
// measured domain"), on every stride-th row and column from (0, 0). A mask, never a resampling:
// metrics still see every pixel. Unchanged when stride is 1 and the reference has no domain.
// Coverage and clipped pixels are left to the fitter's own valid-pixel test. stride >= 1.
reference_images::Reference TrainingPixels(reference_images::Reference ref, int stride);

}  // namespace shadefit::fit
