// FitResult assembly (internal to fit/): the winner's facts, the parameter estimates, the
// per-reference RMSE and output renders, and the provenance of the inputs.
#pragma once

#include <nlohmann/json.hpp>
#include <vector>

#include "multistart.h"
#include "prepared_reference.h"
#include "problem.h"
#include "shadefit/fit/fit_types.h"
#include "shadefit/fit/residuals.h"

namespace shadefit::fit::internal {

// The starts' records and the winner's solve facts, which starts reached the best cost, and per
// entry its value, at_bound (from problems.u, the winner) and its spread over those starts.
void RecordStarts(const Parametrization& param, const CeresProblems& problems,
                  MultiStartResult multistart, FitResult* result);

// Per reference the RMSE at result->values (the fitting path's own predictions: the twin, or a
// GL render where the fit ran on GL or on an environment subsample) and, when
// options.render_outputs, the GL prediction and |error| images; the GL path's render count.
// `renderer` may be null when none of the three needs it.
void RecordReferences(const ModelInfo& model, bool gl, const FitOptions& options,
                      Renderer* renderer, std::vector<PreparedReference>& refs, FitResult* result);

// Paths and SHA-256 of every file read, per reference, and the fixed assignments.
nlohmann::json Provenance(const FitProblem& problem, const FitOptions& options,
                          const std::vector<PreparedReference>& refs);

}  // namespace shadefit::fit::internal
