// The stages of a fit after its references are prepared (internal to fit/): problems, the
// multi-start, uncertainty and the per-reference record. Fit() runs them on images,
// FitBrdfSpace() on the cells of a measured BRDF.
#pragma once

#include <vector>

#include "prepared_reference.h"
#include "shadefit/fit/fit_types.h"
#include "shadefit/fit/residuals.h"

namespace shadefit::fit::internal {

// Fills `result` (everything but inputs, seconds and the fields Fit() sets before preparing).
// `renderer` may be null when nothing needs GL: not `gl`, no environment reference and
// options.render_outputs false.
void SolvePrepared(const ModelInfo& model, const Parametrization& param, const FitOptions& options,
                   bool gl, bool environment, Renderer* renderer,
                   std::vector<PreparedReference>& refs, FitResult* result);

}  // namespace shadefit::fit::internal
