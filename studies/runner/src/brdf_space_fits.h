// The BRDF-space fits of a run (fit/brdf_space.h), made once per material, model and settings and
// shared by every job that needs one: each image fit that starts from it ([fit] start = "brdf":
// one per training set and loss) and the BRDF-space training set itself. The fit is a
// deterministic function of its inputs, so a job's results are the same bytes whether it made
// the fit or found it here; the study just stops making the same fit up to seven times.
#pragma once

#include <memory>
#include <string>

#include "shadefit/base/made_once.h"
#include "shadefit/fit/brdf_space.h"
#include "shadefit/fit/fit_types.h"

namespace shadefit::studies::internal {

class BrdfSpaceFits {
 public:
  // The BRDF-space fit of `model` (held values `fixed`) to the measured BRDF at `brdf_path`,
  // with `options` (l2, fixed exposure, no start points; the caller's). `key` names everything
  // the options depend on besides the material and the model (the study's settings).
  // `solved_here`: the fit's seconds (FitResult::seconds) when this call made it, else 0 (found,
  // or made by another job): what the caller's timing counts as its solver's.
  fit::FitResult Get(const std::string& brdf_path, const ModelInfo& model,
                     const std::vector<FixedValue>& fixed, const fit::FitOptions& options,
                     const std::string& key, double* solved_here);

 private:
  MadeOnce<fit::FitResult> fits_;
  // The BRDF sampled on MERL's cells (fit::SampleBrdfSpace): read and sampled once per material
  // while its jobs run; the last three materials' are kept.
  MadeOnce<std::shared_ptr<const fit::BrdfSpaceData>> samples_{3};
};

}  // namespace shadefit::studies::internal
