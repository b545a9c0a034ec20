// The problem the bounded Levenberg-Marquardt solves (internal to fit/): the shading points and
// their targets, the model, the loss and the parametrization. Below the solver (bounded_lm.h)
// and its passes over the pixels (lm_geometry.h, lm_evaluator.h), which all take it.
#pragma once

#include <memory>
#include <vector>

#include "box_coordinates.h"
#include "model_structure.h"
#include "shadefit/fit/fit_types.h"
#include "shadefit/fit/residuals.h"
#include "shadefit/render/gbuffer.h"

namespace shadefit::fit::internal {

// A run of shading points with 3 compressed targets each.
struct PixelSpan {
  const ShadingPoint* points = nullptr;
  const double* targets = nullptr;
  int count = 0;
};

// How the Jacobian pass carries derivatives: one Jet slot per table row where the model is
// channel-separable (ChannelSeparable; the default), or one per entry (tests compare the two).
enum class JetLayout { kPerRow, kPerEntry };

// The dot products of every lit sample of a problem's points, computed by the first pass over
// the problem and reused by the next ones (every start, the polish and its start cost, the
// uncertainty); lm_geometry.cpp. Shared by copies of the problem, and recomputed when its spans
// differ from those it was computed for.
struct GeometryCache;
std::shared_ptr<GeometryCache> NewGeometryCache();

struct BoundedLmProblem {
  ModelId model{};
  Loss loss = Loss::kL2;  // Non-robust losses only (L2, log, cube root).
  const Parametrization* param = nullptr;
  std::vector<PixelSpan> spans;
  bool exposure_free = false;
  int threads = 1;  // Any count gives the same bytes: partial sums per fixed chunk, summed in order.
  JetLayout derivatives = JetLayout::kPerRow;
  // Whoever changes the points' normals or lights in place after a pass (a new environment
  // quadrature: MultiStart::EnvironmentRounds) calls ForgetGeometry. One problem is not solved on
  // two threads at once (a solve's passes are threaded inside).
  std::shared_ptr<GeometryCache> geometry = NewGeometryCache();
};

// Drops the cached geometry of `problem` (and of its copies): the next pass recomputes it.
void ForgetGeometry(const BoundedLmProblem& problem);

// Whether SolveBoundedLm runs as a variable projection: the image is affine in the linear
// entries only with the L2 loss (no compression) and a fixed exposure (no product with them).
inline bool ProjectionApplies(Loss loss, bool exposure_free) {
  return loss == Loss::kL2 && !exposure_free;
}

}  // namespace shadefit::fit::internal
