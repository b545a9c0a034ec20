// The one set of rules for the fit settings a user gives. `shadefit fit`'s flags, a study's [fit]
// table (with its overrides and [quick]) and the Python module's keyword arguments say the same
// things under three spellings; each reads its text into FitOptions through the Parse functions
// (fitter.h, encoding_search.h) and checks the result with CheckFitOptions, so that a value one
// of them accepts the others accept too, with the same words when they refuse it. An error
// carries the field it is about; each caller names that field its own way (FitFlag, or a study's
// key) and, in a study, points at the line.
#pragma once

#include <string>

#include "shadefit/base/error.h"

namespace shadefit::fit {

struct FitOptions;
enum class EncodingMode;

// The settings a user can give, by meaning.
enum class FitField {
  kLoss,
  kLossScale,
  kStarts,
  kSeed,
  kExposure,
  kPath,
  kMaxIterations,
  kThreads,
  kEnvironmentSamples,
  kEnvironmentPixels,
  kEnvironmentTwinSamples,
  kEnvironmentRounds,
  kSolver,
  kEncoding,
  kModel,       // FitProblem::model
  kReferences,  // FitProblem::references
  kFixed,       // FitProblem::fixed
};

// A refused setting. what() names the field by FitKeyword; front ends that spell it otherwise
// rethrow `problem` under their own name.
class FitOptionError : public Error {
 public:
  FitOptionError(FitField field, const std::string& problem);
  FitField field;
  std::string problem;  // "must be >= 1", "unknown loss 'l3' (known: ...)".
};

// The field in the library's words: "loss_scale", "env_samples", "references" (the Python
// module's keywords; a study's keys but for environment_samples).
std::string FitKeyword(FitField field);

// Bounds beyond which a value is a typo, not a plan: it would run for days.
inline constexpr int kMaxStarts = 10000;
inline constexpr int kMaxIterationsLimit = 100000;

// Every rule on the user's fields of `o` together with the encoding mode: counts in range, a
// finite loss scale >= 0, and an encoding search only with a free exposure (the exposure of a
// photograph is unknown too). Throws FitOptionError for the first field that breaks one.
void CheckFitOptions(const FitOptions& o, EncodingMode encoding);

}  // namespace shadefit::fit
