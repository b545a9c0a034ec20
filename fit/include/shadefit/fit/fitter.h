// Fitting a shading model to reference images with Ceres (docs/fitting.md): the entry point
// Fit, the fit's JSON and output files, and the evaluation of fitted parameters on a reference.
// The types they take and return are in fit_types.h.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "shadefit/base/files.h"
#include "shadefit/fit/fit_types.h"
#include "shadefit/render/image.h"
#include "shadefit/render/renderer.h"

namespace shadefit::fit {

// Fits problem.model to problem.references. Throws shadefit::Error on bad input (unknown model
// or parameter, a reference with no fittable pixel or only black ones, non-finite reference
// pixels, size mismatches). A fit that does not converge is returned with converged = false.
FitResult Fit(const FitProblem& problem, const FitOptions& options = {});

nlohmann::json FitResultToJson(const FitResult& result);

// Writes the JSON (atomically: temporary file + rename) and, per reference, next to it:
// <stem>.<ref>.fit.exr (fitted render), <stem>.<ref>.error.exr (|error|, alpha = validity) and
// <stem>.<ref>.error.png (preview). `extra` (an object, or null) adds top-level fields to the JSON
// (the encoding search's, fit/encoding_search.h). Returns the paths written.
std::vector<std::string> WriteFitOutputs(const FitResult& result, const std::string& json_path,
                                         const nlohmann::json& extra = nullptr);

// Renders `model` with `params` (natural units, flattened) under the reference's scene with GL,
// times `exposure`, and returns the RMSE (linear radiance) over the reference's valid pixels.
// `renderer` as in FitOptions; `prediction` receives the render when not null.
double EvaluateModelOnReference(const FitReference& reference, const ModelInfo& model,
                                const std::vector<double>& params, double exposure = 1.0,
                                Renderer* renderer = nullptr, Image* prediction = nullptr);

// SHA-256 (FIPS 180-4), lowercase hex: the one implementation in base/files.h.
using shadefit::Sha256File;
inline std::string Sha256(const std::string& bytes) { return Sha256String(bytes); }

}  // namespace shadefit::fit
