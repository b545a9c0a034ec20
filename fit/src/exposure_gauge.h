// The free exposure's pin inside a fit (internal to fit/; exposure_pin.h says what is pinned).
#pragma once

#include "multistart.h"
#include "problem.h"
#include "shadefit/fit/exposure_pin.h"
#include "shadefit/fit/residuals.h"

namespace shadefit::fit::internal {

// PinKind::kExposure: moves every start along its line exposure * x (x: pin.entries; the image
// is the same all along it) to the exposure 1, or to the nearest exposure that keeps every x
// within 99% of its upper bound; sets problems' u and log exposure to the winner's new point
// and holds the exposure there, so that the covariance is that of the pinned problem.
void MoveToExposureGauge(const Parametrization& param, const ExposurePin& pin,
                         MultiStartResult* solved, CeresProblems* problems);

}  // namespace shadefit::fit::internal
