// A fit job's outcome: results.csv's `status` column and the job JSON's "status". All but the
// first two leave no fitted parameters; the study carries on without that fit.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace shadefit::studies::internal {

enum class FitStatus {
  kOk,
  kNotConverged,
  kDegenerateReference,
  kNanResiduals,
  kNonFiniteRender,  // finite cost, but the fit renders NaN/Inf under one of its references
  kGlContextLost,
};

inline const char* FitStatusName(FitStatus s) {
  switch (s) {
    case FitStatus::kOk: return "ok";
    case FitStatus::kNotConverged: return "not-converged";
    case FitStatus::kDegenerateReference: return "degenerate-reference";
    case FitStatus::kNanResiduals: return "nan-residuals";
    case FitStatus::kNonFiniteRender: return "non-finite-render";
    case FitStatus::kGlContextLost: return "gl-context-lost";
  }
  return "";
}

// The status a job JSON records; nullopt for a name this version does not write.
inline std::optional<FitStatus> ParseFitStatus(std::string_view name) {
  for (FitStatus s : {FitStatus::kOk, FitStatus::kNotConverged, FitStatus::kDegenerateReference,
                      FitStatus::kNanResiduals, FitStatus::kNonFiniteRender,
                      FitStatus::kGlContextLost}) {
    if (name == FitStatusName(s)) return s;
  }
  return std::nullopt;
}

// Whether a fit with this status left parameters (an unknown status did not).
inline bool HasFit(std::optional<FitStatus> s) {
  return s == FitStatus::kOk || s == FitStatus::kNotConverged;
}

}  // namespace shadefit::studies::internal
