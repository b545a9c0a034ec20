// Uncertainty (internal to fit/): standard errors from ceres::Covariance at the best start, and
// which entries the data does not determine.
#pragma once

#include "problem.h"
#include "shadefit/fit/fit_types.h"
#include "shadefit/fit/residuals.h"

namespace shadefit::fit::internal {

// At problems.u / log_exposure (the winner): sets every free, determined entry's std_error, the
// undetermined flags, exposure_std_error and covariance_status ("ok", "rank deficient",
// "failed: ..."). Needs result->parameters (at_bound) and final_cost filled in. Never throws: a
// failure is the status.
void EstimateUncertainty(const Parametrization& param, CeresProblems& problems, FitResult* result);

}  // namespace shadefit::fit::internal
