// Directional albedo E(v) = integral over the hemisphere of Reflect(l, v) dl: the fraction of
// light arriving from one direction that a model sends back out (white furnace with one view).
#pragma once

#include <vector>

#include "shadefit/render/models.h"

namespace shadefit {

struct AlbedoOptions {
  int strata_per_axis = 128;  // samples per technique = strata_per_axis^2
  unsigned seed = 7;          // jitter inside the strata (fixed: results are reproducible)
};

struct AlbedoEstimate {
  double value[3] = {0, 0, 0};
  double std_error[3] = {0, 0, 0};  // Standard error of the estimate (one sigma).
};

// Integrates Reflect(l, v) over l for a view at cos(theta_v) = cos_theta_v (isotropic models:
// the azimuth of v does not matter). Deterministic, stratified, and importance sampled with two
// techniques (cosine-weighted and the model's GGX-equivalent specular lobe) combined by the
// balance heuristic (Veach and Guibas 1995), the same scheme as the environment lighting.
// Estimates are kept per process (the probes ask for the same ones): a call with the inputs of an
// earlier one returns its result, the same bits it would compute.
AlbedoEstimate DirectionalAlbedo(ModelId model, const std::vector<double>& params,
                                 double cos_theta_v, const AlbedoOptions& options = {});

}  // namespace shadefit
