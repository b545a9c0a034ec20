// Multi-start (internal to fit/): start generation, the coarse and full solves with a staged
// working set for the bounds, and the environment rounds that re-centre the quadrature.
#pragma once

#include <ceres/ceres.h>

#include <string>
#include <vector>

#include "prepared_reference.h"
#include "problem.h"
#include "shadefit/fit/fit_types.h"
#include "shadefit/fit/residuals.h"

namespace shadefit::fit::internal {

struct MultiStartResult {
  std::vector<StartResult> starts;  // One per start, in start order.
  int best = 0;                     // The winner (start 0 when every start failed).
  std::string solver_message;       // Ceres' message of the winner's last solve.
  long residual_evaluations = 0;    // Summed over every solve.
  long jacobian_evaluations = 0;
};

// Solves from FitOptions::starts start points (Parametrization::Start) and, under environment
// light on the twin path (`environment`), re-solves the winner on re-centred quadratures. Leaves
// problems->u and log_exposure at the winner's end point.
MultiStartResult RunMultiStart(const ModelInfo& model, const Parametrization& param,
                               const FitOptions& options, bool environment,
                               std::vector<PreparedReference>& refs, CeresProblems* problems);

}  // namespace shadefit::fit::internal
