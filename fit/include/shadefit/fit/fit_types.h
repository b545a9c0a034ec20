// The fitter's public types (docs/fitting.md): the problem, the options, the results and their
// enums. Below the driver (fitter.h: Fit, the outputs, the evaluation on a reference), so that
// the solver's own files (fit/src/) and the other entry points (brdf_space.h,
// encoding_search.h) use them without including the driver that includes them.
//
// One material, one or more references: every reference brings its image (linear radiance,
// RGBA with alpha = coverage, premultiplied), its scene and an optional mask, and all of them are
// fitted JOINTLY with one set of material parameters (plus an optional global exposure scale).
// Residuals are per valid pixel and per channel, in linear radiance or a compressed version of it
// (Loss). Two derivative paths evaluate the same residuals:
//   kGBuffer: GL renders each reference's G-buffer once; the residuals run on the templated C++
//             twin of the shading code (ShadePoint<ceres::Jet>): exact derivatives by AutoDiff,
//             multi-threaded. Point/directional/ambient lights are exact; environment and
//             uniform light are a fixed per-pixel quadrature (FitOptions::environment_*).
//   kGl:      Ceres drives the GL renderer; the Jacobian comes from forward differences of GL
//             renders (one render per free parameter and evaluation point, shared by every
//             residual block through a cache). Under environment light its GGX proposal moves
//             with the roughness, which makes the renders non-smooth in it (docs/fitting.md).
#pragma once

#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "shadefit/fit/defaults.h"
#include "shadefit/fit/exposure_pin.h"
#include "shadefit/reference_images/reference.h"
#include "shadefit/base/enum_names.h"
#include "shadefit/base/error.h"
#include "shadefit/render/image.h"

namespace shadefit {
class Renderer;  // render/renderer.h: FitOptions may lend one.
}  // namespace shadefit

namespace shadefit::fit {

// How a pixel's residual is formed from the prediction x and the reference y (per channel).
enum class Loss {
  kL2,        // r = x - y: linear radiance; highlights dominate.
  kLog,       // r = log(1 + x) - log(1 + y): compresses values above ~1.
  kCubeRoot,  // r = cbrt(x + eps) - cbrt(y + eps), eps = kCubeRootEpsilon (Fores et al. 2012).
  kHuber,     // r = x - y per channel, ceres::HuberLoss(scale) on each pixel's RGB norm^2.
  kCauchy,    // r = x - y per channel, ceres::CauchyLoss(scale) on each pixel's RGB norm^2.
  kRelative,  // r = log(x + eps) - log(y + eps), eps = kRelativeEpsilon: relative error, the
              // loss relative RMSE (mean |x - y| / (y + 0.01)) and log RMSE judge by.
};
// Each enum's names (base/enum_names.h), the one table the Parse and Name functions read.
inline constexpr EnumName<Loss> kLossNames[] = {
    {Loss::kL2, "l2"},           {Loss::kLog, "log"},       {Loss::kCubeRoot, "cuberoot"},
    {Loss::kHuber, "huber"},     {Loss::kCauchy, "cauchy"}, {Loss::kRelative, "relative"}};

// Offset inside the cube root: keeps the Jet derivative 1 / (3 (x + eps)^(2/3)) finite at x = 0
// (bounded by 155) while changing values above ~0.01 radiance by under 1%.
inline constexpr double kCubeRootEpsilon = 1e-4;

// Offset inside the relative loss's log: the same 0.01 radiance that relative RMSE adds to its
// denominator (metrics/), so that dark pixels, whose relative error is noise, weigh as a pixel
// of radiance 0.01 would; derivative 1 / (x + eps) <= 100.
inline constexpr double kRelativeEpsilon = 1e-2;

enum class DerivativePath { kAuto, kGBuffer, kGl };
inline constexpr EnumName<DerivativePath> kPathNames[] = {{DerivativePath::kAuto, "auto"},
                                                          {DerivativePath::kGBuffer, "gbuffer"},
                                                          {DerivativePath::kGl, "gl"}};
enum class Exposure { kFixed, kFree };
inline constexpr EnumName<Exposure> kExposureNames[] = {{Exposure::kFixed, "fixed"},
                                                        {Exposure::kFree, "free"}};

// The Parse functions throw FitOptionError (option_checks.h) on unknown names.
Loss ParseLoss(const std::string& name);
std::string LossName(Loss loss);
DerivativePath ParsePath(const std::string& name);
std::string PathName(DerivativePath path);
Exposure ParseExposure(const std::string& name);
std::string ExposureName(Exposure exposure);

// The scale of the robust losses when FitOptions::loss_scale is 0, as a fraction of the
// reference's 99th-percentile value over valid pixels (RGB norm): residual norms above
// 0.05 * p99 count as outliers (Huber: linear growth; Cauchy: logarithmic).
inline constexpr double kRobustScaleFraction = 0.05;

// References and their loading live with the references (reference_images/, reference_images/reference.h);
// the fitter's names for them:
using FitReference = reference_images::Reference;
using reference_images::LoadReference;

// A reference the fit cannot use: no valid pixel, every valid pixel black, or non-finite pixels
// on the object. A property of the data, not of the fitter: the study runner records it as the
// fit's status ("degenerate-reference") and carries on.
class DegenerateReferenceError : public Error {
 public:
  using Error::Error;
};

struct FitProblem {
  ModelRef model;                        // Resolved where its name was given (FindModel).
  std::vector<FitReference> references;  // Fitted jointly with one parameter set.
  std::vector<FixedValue> fixed;         // Rows held constant, made for `model`.
};

// kBoundedLm: the bounded Levenberg-Marquardt of fit/src/bounded_lm.h (box bounds held by an
// active set, one pass over the pixels per Jacobian; a variable projection with the l2 loss and
// a fixed exposure) on the G-buffer path with a non-robust loss (l2, log, cuberoot). kCeres:
// Ceres on the sine-transformed entries in stages (the solver before issue 11). Without the
// projection the bounded LM stopped in wrong basins (masked gold ggx-metallic with the cube-root
// loss: cost 28.9 against Ceres' 2.4e-5; a free-exposure photo fit at exposure 2.84 of 4:
// docs/fitting.md), so kAuto leaves those fits to Ceres.
enum class Solver { kAuto, kBoundedLm, kCeres };
inline constexpr EnumName<Solver> kSolverNames[] = {
    {Solver::kAuto, "auto"}, {Solver::kBoundedLm, "bounded-lm"}, {Solver::kCeres, "ceres"}};
// Throws FitOptionError on a name kSolverNames lacks.
Solver ParseSolver(const std::string& name);

struct FitOptions {
  Loss loss = Loss::kL2;
  double loss_scale = 0.0;           // Huber/Cauchy scale a (radiance units); 0 = automatic
                                     // (kRobustScaleFraction of the references' p99).
  int starts = kDefaultStarts;       // Start 0 = table defaults; 1.. = scrambled Halton points.
                                     // Fit() takes 0 when start_points are given.
  std::uint64_t seed = 1;            // Scrambles the Halton starts (Cranley-Patterson shift).
  // More starts after those: natural parameters, flattened as FitResult::values (a measured
  // material's BRDF-space fit, a study's [fit] start = "brdf"; Parametrization::StartAt).
  std::vector<std::vector<double>> start_points;
  Exposure exposure = Exposure::kFixed;  // kFree: fit a global scale exp(e).
  DerivativePath path = DerivativePath::kAuto;
  int max_iterations = kDefaultMaxIterations;  // Per start.
  int num_threads = 2;               // Ceres threads (G-buffer path; the GL path uses 1).
  int pixels_per_block = 128;        // Pixels per residual block (non-robust losses).
  double function_tolerance = 1e-9;   // Ceres' convergence tests (relative cost change,
  double gradient_tolerance = 1e-10;  // max-norm of the gradient, relative step): far below
  double parameter_tolerance = 1e-8;  // the 1% the acceptance tests ask of parameters.
  // GL path: forward-difference step in the internal (reparametrised) coordinates; see
  // docs/fitting.md for why 1e-3 (float shading: ~1e-6 relative noise).
  double fd_step = 1e-3;
  bool central_differences = false;  // GL path: central differences (2 renders per parameter).
  int environment_samples = 0;       // GL path: override the scenes' environment sample count
                                     // (0 = keep). Renders cost ~linear in samples.
  // G-buffer path under environment or uniform light: the twin shades a quadrature whose
  // directions never move with the parameters (render/gbuffer.h, AttachEnvironmentSamples), on a
  // stratified subsample of each reference's valid pixels (the RMSE is still over all of them,
  // from a GL render). After the multi-start, environment_rounds more solves re-centre the GGX
  // proposal on the fitted lobe width (the estimate is unbiased for any proposal; this cuts its
  // variance where the fit ends up).
  int environment_pixels = 2048;      // Fitted pixels per reference.
  int environment_twin_samples = 24;  // Samples per technique per pixel (round 1; x2 after).
  int environment_rounds = 1;
  bool compute_covariance = true;
  // G-buffer path with > 16384 valid pixels: run every start on a ~4096-pixel subsample (all
  // highlight pixels + a stride through the rest), then polish the best ones on all pixels.
  bool coarse_to_fine = true;
  // Which solver runs the G-buffer path (the GL path and robust losses always use Ceres).
  // kAuto, the default of the CLI and the study runner alike: the bounded LM where its variable
  // projection applies (l2 loss, fixed exposure), else the staged Ceres solve.
  Solver solver = Solver::kAuto;
  bool render_outputs = true;        // Fill ReferenceResult::prediction/abs_error (GL renders).
  // A renderer whose GL context is current on the calling thread. nullptr: Fit creates a
  // context and renderer of its own for the duration of the call.
  Renderer* renderer = nullptr;
};

struct ParameterEstimate {
  std::string name;    // Flattened entry name: "kd.r", "roughness".
  double value = 0;    // Natural units (after undoing the log reparametrisation).
  double std_error = std::numeric_limits<double>::quiet_NaN();  // NaN: fixed or undetermined.
  bool fixed = false;
  // Why a fixed entry is fixed when the user did not fix it: "free exposure" (the exposure pin,
  // exposure_pin.h) or "no ambient light" (an ambient-only entry); empty otherwise.
  std::string fixed_by;
  bool undetermined = false;  // In the numerical null space of the Jacobian at the optimum.
  bool at_bound = false;      // On a box bound: the std error is not meaningful there.
  // Among the starts that reached the best cost: min, max, standard deviation.
  double spread_min = 0, spread_max = 0, spread_std = 0;
};

// How a solve ended: Ceres' three termination types, onto which the bounded LM's reasons map
// (LmTermination). The fit JSON writes them by TerminationName.
enum class Termination { kConvergence, kNoConvergence, kFailure };
// Ceres' words, as the JSON has always had them.
inline constexpr EnumName<Termination> kTerminationNames[] = {
    {Termination::kConvergence, "CONVERGENCE"},
    {Termination::kNoConvergence, "NO_CONVERGENCE"},
    {Termination::kFailure, "FAILURE"}};
std::string TerminationName(Termination termination);

// Whether the parameters' standard errors were computed (fit/src/uncertainty.h).
enum class CovarianceStatus { kOk, kRankDeficient, kFailed, kSkipped };

struct StartResult {
  std::vector<double> start;   // Natural units, flattened.
  std::vector<double> params;  // Natural units, flattened.
  double exposure = 1.0;
  double initial_cost = 0, final_cost = 0;
  int iterations = 0;
  Termination termination = Termination::kFailure;
  bool converged = false;
  bool reached_best = false;
  // Coarse-to-fine (FitOptions::coarse_to_fine): the cost on the pixel subsample, and whether the
  // start was polished on all pixels (only those near the best coarse cost are; the others have
  // final_cost NaN and params from the coarse stage).
  double coarse_cost = std::numeric_limits<double>::quiet_NaN();
  bool polished = false;
};

struct ReferenceResult {
  std::string name;
  int pixels = 0;       // Valid pixels used.
  double rmse = 0;      // Linear radiance, over valid pixels and channels, at the best fit.
  Image prediction;     // GL render of the fit times exposure (when render_outputs).
  Image abs_error;      // |prediction - reference|, RGB + alpha = validity (when render_outputs).
};

struct FitResult {
  ModelRef model;
  Loss loss = Loss::kL2;           // Written by name (LossName).
  double loss_scale = 0;           // 0 for losses without a scale.
  DerivativePath path = DerivativePath::kGBuffer;  // The path that ran (never kAuto).
  std::vector<ParameterEstimate> parameters;
  std::vector<double> values;      // Natural units, flattened (for Renderer::Render).
  bool exposure_free = false;
  ExposurePin exposure_pin;        // With a free exposure: what holds the scale.
  // Entries the fit held although not fixed by the user, each with why: an ambient reflectance
  // (classic Blinn-Phong's ka) when no reference has ambient light, where it has no effect.
  std::vector<std::string> held;
  double exposure = 1.0;
  double exposure_std_error = std::numeric_limits<double>::quiet_NaN();
  double initial_cost = 0, final_cost = 0;  // Best start, Ceres' 0.5 * sum rho(r^2).
  double rmse = 0;                  // Over all references' valid pixels, linear radiance.
  std::vector<ReferenceResult> references;
  int iterations = 0;
  Termination termination = Termination::kFailure;
  bool converged = false;
  std::string solver_message;
  std::string solver_name;          // "bounded-lm", "bounded-lm (variable projection)", "ceres".
  double seconds = 0;               // Wall time of Fit().
  double solve_seconds = 0;         // Of which the solves (every start), nothing else.
  int starts = 1;
  int given_starts = 0;             // Of which the last ones: FitOptions::start_points.
  std::uint64_t seed = 1;
  int starts_reached_best = 0;
  // The best end point among the starts that did not reach the best cost and were solved on every
  // pixel (another basin): -1 when every such start reached the best. A study flags a fit whose
  // second basin costs little more than its best (the optimum is not clearly separated).
  int second_basin_start = -1;
  double second_basin_cost = std::numeric_limits<double>::quiet_NaN();
  bool coarse_to_fine = false;      // Whether the coarse stage ran.
  std::vector<StartResult> start_results;
  CovarianceStatus covariance_status = CovarianceStatus::kSkipped;
  std::string covariance_failure;   // Why, when covariance_status is kFailed.
  // "ok", "rank deficient", "failed: <why>", "skipped": the JSON's words.
  std::string CovarianceStatusText() const;
  std::string covariance_method;    // How the standard errors were computed (the JSON says).
  long renders = 0;                 // GL renders of the model (not counting G-buffers/outputs).
  long gbuffer_renders = 0;
  long residual_evaluations = 0;    // Ceres evaluations without Jacobian (whole problem).
  long jacobian_evaluations = 0;    // Ceres evaluations with Jacobian (whole problem).
  nlohmann::json inputs;            // Paths and SHA-256 of every file read.
};

}  // namespace shadefit::fit
