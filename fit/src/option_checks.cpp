#include "shadefit/fit/option_checks.h"

#include <fmt/format.h>

#include <cmath>
#include <optional>
#include <vector>

#include "shadefit/fit/encoding_search.h"
#include "shadefit/fit/fit_types.h"

namespace shadefit::fit {
namespace {

// The value of the enum table `known` spelled `name`, or FitOptionError naming them (and the
// likely one).
template <typename T, std::size_t N>
T Choose(FitField field, const char* what, const std::string& name,
         const EnumName<T> (&known)[N]) {
  if (const std::optional<T> value = ValueOf(known, name)) return *value;
  const std::vector<std::string> names = NamesOf(known);
  throw FitOptionError(field, fmt::format("unknown {} '{}'{} (known: {})", what, name,
                                          DidYouMean(name, names), fmt::join(names, ", ")));
}

void AtLeast(FitField field, long long value, long long min) {
  if (value < min) throw FitOptionError(field, fmt::format("must be >= {}", min));
}

void AtMost(FitField field, long long value, long long max) {
  if (value > max) {
    throw FitOptionError(field, fmt::format("must be <= {} ({} is a typo, not a plan: it would "
                                            "run for days)",
                                            max, value));
  }
}

}  // namespace

FitOptionError::FitOptionError(FitField f, const std::string& p)
    : Error("", FitKeyword(f), p), field(f), problem(p) {}

std::string FitKeyword(FitField field) {
  switch (field) {
    case FitField::kLoss: return "loss";
    case FitField::kLossScale: return "loss_scale";
    case FitField::kStarts: return "starts";
    case FitField::kSeed: return "seed";
    case FitField::kExposure: return "exposure";
    case FitField::kPath: return "path";
    case FitField::kMaxIterations: return "max_iterations";
    case FitField::kThreads: return "threads";
    case FitField::kEnvironmentSamples: return "env_samples";
    case FitField::kEnvironmentPixels: return "env_pixels";
    case FitField::kEnvironmentTwinSamples: return "env_twin_samples";
    case FitField::kEnvironmentRounds: return "env_rounds";
    case FitField::kSolver: return "solver";
    case FitField::kEncoding: return "encoding";
    case FitField::kModel: return "model";
    case FitField::kReferences: return "references";
    case FitField::kFixed: return "fixed";
  }
  return "?";
}

Loss ParseLoss(const std::string& name) {
  return Choose(FitField::kLoss, "loss", name, kLossNames);
}

DerivativePath ParsePath(const std::string& name) {
  return Choose(FitField::kPath, "path", name, kPathNames);
}

Exposure ParseExposure(const std::string& name) {
  return Choose(FitField::kExposure, "exposure", name, kExposureNames);
}

Solver ParseSolver(const std::string& name) {
  return Choose(FitField::kSolver, "solver", name, kSolverNames);
}

EncodingMode ParseEncodingMode(const std::string& name) {
  return Choose(FitField::kEncoding, "encoding", name, kEncodingModeNames);
}

void CheckFitOptions(const FitOptions& o, EncodingMode encoding) {
  if (!(o.loss_scale >= 0) || !std::isfinite(o.loss_scale)) {
    throw FitOptionError(FitField::kLossScale,
                         fmt::format("{} is not a finite number >= 0", o.loss_scale));
  }
  AtLeast(FitField::kStarts, o.starts, 1);
  AtMost(FitField::kStarts, o.starts, kMaxStarts);
  AtLeast(FitField::kMaxIterations, o.max_iterations, 1);
  AtMost(FitField::kMaxIterations, o.max_iterations, kMaxIterationsLimit);
  AtLeast(FitField::kThreads, o.num_threads, 1);
  AtLeast(FitField::kEnvironmentSamples, o.environment_samples, 0);
  AtLeast(FitField::kEnvironmentPixels, o.environment_pixels, 16);
  AtLeast(FitField::kEnvironmentTwinSamples, o.environment_twin_samples, 1);
  AtLeast(FitField::kEnvironmentRounds, o.environment_rounds, 0);
  if (encoding == EncodingMode::kFit && o.exposure != Exposure::kFree) {
    throw FitOptionError(FitField::kEncoding,
                         "fit needs a free exposure (the exposure of a photograph is unknown too)");
  }
}

}  // namespace shadefit::fit
