// What holds the scale of a fit with a free exposure (docs/fitting.md, "Free exposure"). A
// photograph's exposure is unknown, and exposure times the reflectances is what its pixels
// determine: left both free, the fit reports the reflectances "undetermined". One value per model
// is therefore pinned, chosen from the model's structure and its parameter roles (model_dsl.h),
// and written into the fit JSON and `shadefit models`.
#pragma once

#include <string>
#include <vector>

#include "shadefit/render/models.h"

namespace shadefit::fit {

enum class PinKind {
  kNone,      // A fixed value of the user's already sets the scale (a Fresnel row, or a non-zero
              // entry the radiance is linear in): nothing is added.
  kExposure,  // The radiance is linear in its reflectances (lambert, phong, the Blinn-Phongs,
              // ward, lafortune): exposure and reflectances share one scale exactly, and the fit is
              // moved along it to exposure 1 (the pixels as radiance per unit light) or, where a
              // reflectance would then leave its box, to the nearest exposure that keeps every one
              // within 99% of its upper bound. The image and the cost do not change.
  kFresnel,   // The radiance is not linear in its reflectances (Schlick's f0 + (1 - f0)(1 - l.h)^5):
              // the rows that set the Fresnel reflectance at normal incidence (kFresnelParam) are
              // held at their defaults, a dielectric's (F0 = 0.04), colour rows in green only, so a
              // coloured highlight stays free.
  kUnitExposure,  // Neither (ggx-conductor): the exposure is held at 1.
};

struct ExposurePin {
  PinKind kind = PinKind::kNone;
  // kExposure: the entries that move with the exposure; kFresnel: the entries held.
  std::vector<int> entries;
  std::vector<double> values;  // kFresnel: the values they are held at.
  std::string text;            // What is pinned and why, one line.
};

// The pin of `model` for a fit with a free exposure and the user's `fixed` (as FitProblem::fixed).
ExposurePin ExposurePinOf(const ModelInfo& model, const std::vector<FixedValue>& fixed = {});

}  // namespace shadefit::fit
