// fit: Ceres fit of one shading model to one or more references of one material
// (docs/fitting.md). Everything is read and fitted before anything is written; a bad input is a
// one-line shadefit::Error and leaves no output file.
#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <future>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "shadefit/base/error.h"
#include "shadefit/fit/brdf_space.h"
#include "shadefit/fit/encoding_search.h"
#include "shadefit/fit/fitter.h"
#include "shadefit/fit/option_checks.h"
#include "shadefit/fit/training_pixels.h"
#include "shadefit/reference_images/measured_brdf.h"
#include "shadefit/render/gl_context.h"
#include "shadefit/render/renderer.h"

namespace shadefit::cli {

namespace {

// The command's flag for a fit setting the library names by FitKeyword.
std::string FitFlag(fit::FitField field) {
  switch (field) {
    case fit::FitField::kReferences: return "--ref";
    case fit::FitField::kFixed: return "--fix";
    default: break;
  }
  std::string flag = "--" + fit::FitKeyword(field);
  for (char& c : flag) c = c == '_' ? '-' : c;
  return flag;
}

// Loads the --ref images and fits them (with the encoding search when asked).
fit::FitResult FitImages(fit::FitProblem& problem, const std::vector<std::string>& refs,
                         const std::string& scene, const std::vector<std::string>& masks,
                         int pixel_stride, fit::FitOptions options, fit::EncodingMode encoding,
                         nlohmann::json* extra) {
  // The EGL context takes 50-75 ms with llvmpipe, several times the reading of a 256^2 EXR and
  // its sidecar, so a helper thread makes it meanwhile. A bad reference is still reported before
  // a missing EGL device, as when the two ran one after the other.
  std::future<std::unique_ptr<GlContext>> pending_context = std::async(std::launch::async, [] {
    auto made = std::make_unique<GlContext>();
    made->ReleaseCurrent();
    return made;
  });
  for (std::size_t i = 0; i < refs.size(); ++i) {
    // The pixels a fit trains on: the rule the study and Python apply (fit/training_pixels.h).
    problem.references.push_back(fit::TrainingPixels(
        fit::LoadReference(refs[i], scene, masks.empty() ? std::string() : masks[i]),
        pixel_stride));
  }
  const std::unique_ptr<GlContext> context = pending_context.get();
  context->MakeCurrent();
  Renderer renderer(*context);
  options.renderer = &renderer;
  if (encoding != fit::EncodingMode::kFit) return fit::Fit(problem, options);
  fit::EncodingSearchResult search = fit::FitWithEncodingSearch(problem, options);
  (*extra)["encoding"] = fit::EncodingSearchToJson(search);
  for (const fit::EncodingCandidate& c : search.candidates) {
    fmt::print("encoding {:<12} stored-value RMSE {:.6f} (x255: {:.3f}){}\n", c.encoding.Name(),
               c.stored_rmse, 255.0 * c.stored_rmse,
               c.encoding.kind == search.chosen.kind ? "  <- chosen" : "");
  }
  return std::move(search.fit);
}

void PrintFit(const fit::FitResult& result, const std::string& output) {
  fmt::print(
      "{} fit to {} reference(s) via the {} path: cost {:.6g}, RMSE {:.6g}, "
      "{} iterations, {}; {} of {} starts reached the best\n",
      result.model->name, result.references.size(), fit::PathName(result.path), result.final_cost,
      result.rmse, result.iterations, fit::TerminationName(result.termination),
      result.starts_reached_best, result.starts);
  for (const auto& p : result.parameters) {
    fmt::print("  {:<16} {:>12.6g}  +- {:<10.3g}{}{}{}\n", p.name, p.value, p.std_error,
               p.fixed ? " fixed" : "", p.undetermined ? " undetermined" : "",
               p.at_bound ? " at bound" : "");
  }
  if (result.exposure_free) {
    fmt::print("  {:<16} {:>12.6g}  +- {:.3g}\n", "exposure", result.exposure,
               result.exposure_std_error);
    fmt::print("  pinned: {}\n", result.exposure_pin.text);
  }
  for (const std::string& held : result.held) fmt::print("  held: {}\n", held);
  fmt::print("wrote {}\n", output);
  if (!result.converged) {
    std::fprintf(stderr,
                 "shadefit: warning: the fit did not converge (%s after %d iterations: %s); "
                 "the result is marked \"converged\": false\n",
                 fit::TerminationName(result.termination).c_str(), result.iterations,
                 result.solver_message.c_str());
  }
}

// The fit command's options, as given.
struct FitCommandOptions {
  std::vector<std::string> refs, masks, fixed;
  std::string brdf;
  std::vector<int> brdf_cells;
  double brdf_max_theta = fit::BrdfSpaceSampling{}.max_theta_deg;
  std::string scene, model, loss = "l2", exposure = "fixed", path = "auto", output;
  int starts = fit::FitOptions{}.starts, max_iterations = fit::FitOptions{}.max_iterations;
  int threads = fit::FitOptions{}.num_threads, env_samples = 0, pixel_stride = 1;
  std::string solver = "auto";
  std::string encoding = "as-imported";
  int env_pixels = fit::FitOptions{}.environment_pixels;
  int env_twin_samples = fit::FitOptions{}.environment_twin_samples;
  int env_rounds = fit::FitOptions{}.environment_rounds;
  std::uint64_t seed = 1;
  double loss_scale = 0;
  bool no_images = false, central = false;
};

// The options that say what is fitted: references or a measured BRDF, the scene, masks, model.
void AddInputOptions(CLI::App* cmd, FitCommandOptions* opt) {
  cmd->add_option("--ref", opt->refs,
                  "Reference image (EXR linear; PNG/JPEG sRGB, clipped pixels masked); "
                  "repeat for a joint fit. Its scene comes from <ref>.json (scene_file)");
  cmd->add_option("--brdf", opt->brdf,
                  "Instead of --ref: fit in BRDF space to a measured BRDF (MERL .binary or "
                  "Neural-BRDF .h5), Ngan et al. 2005's cosine-weighted L2 over directions");
  cmd->add_option("--brdf-cells", opt->brdf_cells,
                  "With --brdf: theta_h, theta_d, phi_d cell counts (default 90 45 45)")
      ->expected(3);
  cmd->add_option("--brdf-max-theta", opt->brdf_max_theta,
                  "With --brdf: cells with theta_i or theta_o above this (degrees) are left out")
      ->capture_default_str();
  cmd->add_option("--scene", opt->scene, "Scene TOML overriding the sidecar's (single --ref)");
  cmd->add_option("--mask", opt->masks,
                  "Mask image per --ref, in order (channel 0 > 0.5 = fit this pixel)");
  cmd->add_option("--model", opt->model, "Shading model (see `shadefit models`)")->required();
  cmd->add_option("--pixel-stride", opt->pixel_stride,
                  "Fit on every n-th pixel in x and y (a study's pixel_stride); measured "
                  "references train on their measured pixels only, whatever the stride")
      ->capture_default_str();
}

// The options of the fit itself: loss, starts, exposure, encoding, path and solver.
void AddSolverOptions(CLI::App* cmd, FitCommandOptions* opt) {
  cmd->add_option("--loss", opt->loss, "l2 | log | cuberoot | relative | huber | cauchy")
      ->capture_default_str();
  cmd->add_option("--loss-scale", opt->loss_scale,
                  "Huber/Cauchy scale in radiance units (default: 0.05 x p99 of the reference)");
  cmd->add_option("--starts", opt->starts, "Number of starts (0 = table defaults, then Halton)")
      ->capture_default_str();
  cmd->add_option("--seed", opt->seed, "Seed of the Halton scrambling")->capture_default_str();
  cmd->add_option("--exposure", opt->exposure,
                  "fixed | free (fit a global scale, for uncalibrated references)")
      ->capture_default_str();
  cmd->add_option("--encoding", opt->encoding,
                  "as-imported | fit (photographs: choose among sRGB, linear and a fitted gamma "
                  "by the error in stored values; needs --exposure free)")
      ->capture_default_str();
  cmd->add_option("--fix", opt->fixed, "Hold a parameter: name=value or name=r,g,b (repeatable)");
  cmd->add_option("--path", opt->path,
                  "Derivatives: auto | gbuffer (C++ twin, AutoDiff) | gl (finite differences "
                  "of GL renders; needed for environment lighting)")
      ->capture_default_str();
  cmd->add_option("--max-iterations", opt->max_iterations, "Per start")->capture_default_str();
  cmd->add_option("--threads", opt->threads, "Ceres threads (G-buffer path)")
      ->capture_default_str();
  cmd->add_option("--env-samples", opt->env_samples,
                  "GL path: environment samples per pixel instead of the scene's (0 = keep)");
  cmd->add_option("--env-pixels", opt->env_pixels,
                  "G-buffer path, environment light: valid pixels fitted per reference")
      ->capture_default_str();
  cmd->add_option("--env-twin-samples", opt->env_twin_samples,
                  "G-buffer path, environment light: quadrature samples per technique per pixel")
      ->capture_default_str();
  cmd->add_option("--env-rounds", opt->env_rounds,
                  "G-buffer path, environment light: re-solves with the proposal on the fit")
      ->capture_default_str();
  cmd->add_option("--solver", opt->solver,
                  "auto (bounded-lm for l2 with fixed exposure, else ceres) | bounded-lm "
                  "(G-buffer path, l2/log/cuberoot) | ceres (the staged Ceres solve)")
      ->capture_default_str();
  cmd->add_flag("--central-differences", opt->central,
                "GL path: central instead of forward differences (2x renders)");
}

// Rejects combinations of --ref, --brdf, --scene and --mask that do not make one fit.
void CheckInputs(const FitCommandOptions& opt) {
  if (opt.pixel_stride < 1) throw Error("", "--pixel-stride", "must be >= 1");
  if (opt.refs.empty() == opt.brdf.empty()) {
    throw Error("", "--ref",
                "give reference images (--ref) or a measured BRDF (--brdf), one of them");
  }
  if (!opt.brdf.empty() && (!opt.scene.empty() || !opt.masks.empty())) {
    throw Error("", opt.scene.empty() ? "--mask" : "--scene",
                "a BRDF-space fit (--brdf) has no scene or mask");
  }
  if (opt.brdf.empty() &&
      (!opt.brdf_cells.empty() || opt.brdf_max_theta != fit::BrdfSpaceSampling{}.max_theta_deg)) {
    throw Error("", opt.brdf_cells.empty() ? "--brdf-max-theta" : "--brdf-cells",
                "only valid with --brdf");
  }
  if (!opt.scene.empty() && opt.refs.size() != 1) {
    throw Error("", "--scene", "only valid with a single --ref (each reference has a sidecar)");
  }
  if (!opt.masks.empty() && opt.masks.size() != opt.refs.size()) {
    throw Error("", "--mask",
                fmt::format("give one mask per --ref ({} refs, {} masks)", opt.refs.size(),
                            opt.masks.size()));
  }
}

// The fitter's options from the command's, checked by the rules every front end shares
// (fit/option_checks.h); `encoding` is --encoding.
fit::FitOptions ParseFitOptions(const FitCommandOptions& opt, fit::EncodingMode* encoding) {
  fit::FitOptions options;
  options.loss = fit::ParseLoss(opt.loss);
  options.loss_scale = opt.loss_scale;
  options.starts = opt.starts;
  options.seed = opt.seed;
  options.exposure = fit::ParseExposure(opt.exposure);
  *encoding = fit::ParseEncodingMode(opt.encoding);
  options.path = fit::ParsePath(opt.path);
  options.max_iterations = opt.max_iterations;
  options.num_threads = opt.threads;
  options.environment_samples = opt.env_samples;
  options.environment_pixels = opt.env_pixels;
  options.environment_twin_samples = opt.env_twin_samples;
  options.environment_rounds = opt.env_rounds;
  options.central_differences = opt.central;
  options.solver = fit::ParseSolver(opt.solver);
  options.render_outputs = !opt.no_images;
  fit::CheckFitOptions(options, *encoding);
  return options;
}

// Fits the --brdf measured BRDF in BRDF space.
fit::FitResult FitBrdf(const FitCommandOptions& opt, const fit::FitProblem& problem,
                       const fit::FitOptions& options) {
  fit::BrdfSpaceSampling sampling;
  if (!opt.brdf_cells.empty()) {
    sampling.theta_h_cells = opt.brdf_cells[0];
    sampling.theta_d_cells = opt.brdf_cells[1];
    sampling.phi_d_cells = opt.brdf_cells[2];
  }
  sampling.max_theta_deg = opt.brdf_max_theta;
  fit::ValidateBrdfSpaceSampling(sampling, "");
  fit::CheckBrdfSpaceOptions(options);
  const std::unique_ptr<reference_images::MeasuredBrdf> brdf =
      reference_images::LoadMeasuredBrdf(opt.brdf);
  return fit::FitBrdfSpace(*problem.model, problem.fixed, fit::SampleBrdfSpace(*brdf, sampling),
                           options);
}

// Runs the command: checks, fits and writes.
void FitAndWrite(const FitCommandOptions& opt) {
  CheckInputs(opt);
  fit::EncodingMode encoding;
  const fit::FitOptions options = ParseFitOptions(opt, &encoding);
  fit::FitProblem problem;  // The model and the held values first: fail before reading anything.
  problem.model = FindModel(opt.model);
  problem.fixed = ParseFixedValues(*problem.model, opt.fixed, "--fix");
  fit::FitResult result;
  nlohmann::json extra;
  if (!opt.brdf.empty()) {
    if (encoding == fit::EncodingMode::kFit) {
      throw Error("", "--encoding", "a BRDF-space fit (--brdf) reads no stored image values");
    }
    result = FitBrdf(opt, problem, options);
  } else {
    result = FitImages(problem, opt.refs, opt.scene, opt.masks, opt.pixel_stride, options,
                       encoding, &extra);
  }
  fit::WriteFitOutputs(result, opt.output, extra);
  PrintFit(result, opt.output);
}

// The command, its settings' errors named by their flags (the library names them by FitKeyword).
void RunFitCommand(const FitCommandOptions& opt) {
  try {
    FitAndWrite(opt);
  } catch (const fit::FitOptionError& e) {
    throw Error("", FitFlag(e.field), e.problem);
  }
}

}  // namespace

void RegisterFitCommand(CLI::App& app) {
  auto* cmd =
      app.add_subcommand("fit", "Fit a shading model to reference images (jointly, one material)");
  auto opt = std::make_shared<FitCommandOptions>();
  AddInputOptions(cmd, opt.get());
  AddSolverOptions(cmd, opt.get());
  cmd->add_flag("--no-images", opt->no_images, "Write only the JSON (no fit/error images)");
  cmd->add_option("-o,--output", opt->output, "Output JSON (images go next to it)")->required();
  cmd->callback([opt] { RunFitCommand(*opt); });
}

}  // namespace shadefit::cli
