#include "shadefit/fit/option_checks.h"

#include <fmt/format.h>

#include <cmath>
#include <vector>

#include "shadefit/fit/encoding_search.h"
#include "shadefit/fit/fit_types.h"

namespace shadefit::fit {
namespace {

// The value among `known` spelled `name`, or FitOptionError naming them (and the likely one).
template <typename T>
T Choose(FitField field, const char* what, const std::string& name,
         const std::vector<std::pair<std::string, T>>& known) {
  std::vector<std::string> names;
  for (const auto& [n, value] : known) {
    if (n == name) return value;
    names.push_back(n);
  }
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
    : Error("", FitFlag(f), p), field(f), problem(p) {}

std::string FitFlag(FitField field) {
  switch (field) {
    case FitField::kLoss:
      return "--loss";
    case FitField::kLossScale:
      return "--loss-scale";
    case FitField::kStarts:
      return "--starts";
    case FitField::kSeed:
      return "--seed";
    case FitField::kExposure:
      return "--exposure";
    case FitField::kPath:
      return "--path";
    case FitField::kMaxIterations:
      return "--max-iterations";
    case FitField::kThreads:
      return "--threads";
    case FitField::kEnvironmentSamples:
      return "--env-samples";
    case FitField::kEnvironmentPixels:
      return "--env-pixels";
    case FitField::kEnvironmentTwinSamples:
      return "--env-twin-samples";
    case FitField::kEnvironmentRounds:
      return "--env-rounds";
    case FitField::kSolver:
      return "--solver";
    case FitField::kEncoding:
      return "--encoding";
  }
  return "?";
}

std::string FitKeyword(FitField field) {
  std::string k = FitFlag(field).substr(2);
  for (char& c : k) c = c == '-' ? '_' : c;
  return k;
}

Loss ParseLoss(const std::string& name) {
  return Choose<Loss>(FitField::kLoss, "loss", name,
                      {{"l2", Loss::kL2},
                       {"log", Loss::kLog},
                       {"cuberoot", Loss::kCubeRoot},
                       {"huber", Loss::kHuber},
                       {"cauchy", Loss::kCauchy},
                       {"relative", Loss::kRelative}});
}

DerivativePath ParsePath(const std::string& name) {
  return Choose<DerivativePath>(FitField::kPath, "path", name,
                                {{"auto", DerivativePath::kAuto},
                                 {"gbuffer", DerivativePath::kGBuffer},
                                 {"gl", DerivativePath::kGl}});
}

Exposure ParseExposure(const std::string& name) {
  return Choose<Exposure>(FitField::kExposure, "exposure", name,
                          {{"fixed", Exposure::kFixed}, {"free", Exposure::kFree}});
}

Solver ParseSolver(const std::string& name) {
  return Choose<Solver>(
      FitField::kSolver, "solver", name,
      {{"auto", Solver::kAuto}, {"bounded-lm", Solver::kBoundedLm}, {"ceres", Solver::kCeres}});
}

EncodingMode ParseEncodingMode(const std::string& name) {
  return Choose<EncodingMode>(
      FitField::kEncoding, "encoding", name,
      {{"as-imported", EncodingMode::kAsImported}, {"fit", EncodingMode::kFit}});
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
