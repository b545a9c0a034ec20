// fit and fit_brdf: the fitter (fit::Fit, fit::FitBrdfSpace) on references given as files or
// arrays, its result as a dict of plain values and arrays (python/shadefit/__init__.py wraps it
// in FitResult).
//
// Links: shadefit::fit, shadefit::reference_images.
#include <fmt/format.h>
#include <pybind11/stl.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "common.h"
#include "shadefit/base/error.h"
#include "shadefit/fit/brdf_space.h"
#include "shadefit/fit/encoding_search.h"
#include "shadefit/fit/fitter.h"
#include "shadefit/fit/option_checks.h"
#include "shadefit/fit/training_pixels.h"
#include "shadefit/reference_images/measured_brdf.h"
#include "shadefit/reference_images/reference.h"

namespace shadefit::python {
namespace {

// One reference as __init__.py normalises it: a dict with "image" (a path or an array),
// "scene_path" / "scene_text" (one may be set; a path image reads its sidecar's scene otherwise),
// "mask" (a path, an array or None) and "name".
struct RefArg {
  std::string image_path, scene_path, scene_text, scene_name, mask_path, name;
  Image image, mask;
};

RefArg RefFromPy(py::handle h, std::size_t index) {
  const py::dict d = py::reinterpret_borrow<py::dict>(h);
  const std::string what = fmt::format("references[{}]", index);
  RefArg r;
  const py::object image = d["image"];
  if (py::isinstance<py::str>(image)) {
    r.image_path = image.cast<std::string>();
  } else {
    r.image = ArrayToImage(image, what, {3, 4});
  }
  r.scene_path = d["scene_path"].cast<std::string>();
  r.scene_text = d["scene_text"].cast<std::string>();
  r.scene_name = d["scene_name"].cast<std::string>();
  r.name = d["name"].cast<std::string>();
  const py::object mask = d["mask"];
  if (py::isinstance<py::str>(mask)) {
    r.mask_path = mask.cast<std::string>();
  } else if (!mask.is_none()) {
    r.mask = MaskToImage(mask, what + ".mask");
  }
  if (r.image_path.empty() && r.scene_path.empty() && r.scene_text.empty()) {
    throw Error("", what, "an array reference needs its scene (path, TOML text or dict)");
  }
  return r;
}

// The reference as the CLI's LoadReference makes it, or in memory from an array.
reference_images::Reference MakeReference(RefArg& a, std::size_t index) {
  if (!a.image_path.empty()) {
    if (!a.scene_text.empty()) {
      throw Error(a.image_path, "scene",
                  "a reference read from a file takes a scene path, not text");
    }
    reference_images::Reference r =
        reference_images::LoadReference(a.image_path, a.scene_path, a.mask_path);
    if (!a.mask.empty()) r.mask = std::move(a.mask);
    if (!a.name.empty()) r.name = a.name;
    return r;
  }
  reference_images::Reference r;
  r.name = a.name.empty() ? fmt::format("ref{}", index) : a.name;
  r.scene = SceneFromArgs(a.scene_path, a.scene_text, a.scene_name);
  r.scene_path = a.scene_path;
  r.image = std::move(a.image);
  if (!a.mask_path.empty()) {
    r.mask = ReadImage(a.mask_path);
    r.mask_path = a.mask_path;
  } else {
    r.mask = std::move(a.mask);
  }
  if (r.image.width != r.scene.camera.width || r.image.height != r.scene.camera.height_px) {
    throw Error(r.name, "image",
                fmt::format("{} x {} pixels, but the scene renders {} x {}", r.image.width,
                            r.image.height, r.scene.camera.width, r.scene.camera.height_px));
  }
  if (!r.mask.empty() && (r.mask.width != r.image.width || r.mask.height != r.image.height)) {
    throw Error(r.name, "mask",
                fmt::format("{} x {} pixels, the image has {} x {}", r.mask.width, r.mask.height,
                            r.image.width, r.image.height));
  }
  return r;
}

template <typename T>
T Get(const py::dict& o, const char* key, T fallback) {
  return o.contains(key) && !o[key].is_none() ? o[key].cast<T>() : fallback;
}

// The fitter's options from the keyword arguments, checked by the rules every front end shares
// (fit/option_checks.h); a refused one is named by its keyword.
fit::FitOptions OptionsFromPy(const py::dict& o) {
  fit::FitOptions f;
  try {
    f.loss = fit::ParseLoss(Get<std::string>(o, "loss", "l2"));
    f.loss_scale = Get<double>(o, "loss_scale", 0.0);
    f.starts = Get<int>(o, "starts", f.starts);
    f.seed = Get<std::uint64_t>(o, "seed", 1);
    f.exposure = fit::ParseExposure(Get<std::string>(o, "exposure", "fixed"));
    f.path = fit::ParsePath(Get<std::string>(o, "path", "auto"));
    f.max_iterations = Get<int>(o, "max_iterations", f.max_iterations);
    f.num_threads = Get<int>(o, "threads", f.num_threads);
    f.environment_samples = Get<int>(o, "env_samples", 0);
    f.environment_pixels = Get<int>(o, "env_pixels", f.environment_pixels);
    f.environment_twin_samples = Get<int>(o, "env_twin_samples", f.environment_twin_samples);
    f.environment_rounds = Get<int>(o, "env_rounds", f.environment_rounds);
    f.central_differences = Get<bool>(o, "central_differences", false);
    f.solver = fit::ParseSolver(Get<std::string>(o, "solver", "auto"));
    f.render_outputs = Get<bool>(o, "render_outputs", true);
    f.compute_covariance = Get<bool>(o, "covariance", true);
    fit::CheckFitOptions(f, fit::EncodingMode::kAsImported);
  } catch (const fit::FitOptionError& e) {
    throw Error("", fit::FitKeyword(e.field), e.problem);
  }
  return f;
}

// The result as Python gets it: the CLI's fit.json record (FitResultToJson, the one schema of a
// fit result; shadefit.FitResult reads its attributes from it), the flattened parameters as an
// array, and each reference's images, which the record names but does not hold.
py::dict ResultToPy(fit::FitResult&& r) {
  py::dict d;
  d["json"] = JsonToPy(fit::FitResultToJson(r));
  d["values"] = py::array_t<double>(static_cast<py::ssize_t>(r.values.size()), r.values.data());
  py::list refs;
  for (fit::ReferenceResult& rr : r.references) {
    py::dict e;
    e["name"] = rr.name;
    e["pixels"] = rr.pixels;
    e["rmse"] = rr.rmse;
    e["prediction"] = rr.prediction.empty() ? py::object(py::none())
                                            : py::object(ImageToArray(std::move(rr.prediction)));
    e["abs_error"] = rr.abs_error.empty() ? py::object(py::none())
                                          : py::object(ImageToArray(std::move(rr.abs_error)));
    refs.append(e);
  }
  d["references"] = refs;
  return d;
}

py::dict FitArrays(py::list references, const std::string& model_name,
                   const std::vector<std::string>& fixed_text, py::dict options) {
  // The model and its held values first: fail before reading anything (the CLI's order).
  const ModelInfo& model = FindModel(model_name);
  std::vector<FixedValue> fixed = ParseFixedValues(model, fixed_text, "fixed");
  fit::FitOptions o = OptionsFromPy(options);
  const int stride = Get<int>(options, "pixel_stride", 1);
  if (stride < 1) throw Error("", "pixel_stride", "must be >= 1");
  if (references.empty()) throw Error("", "references", "at least one reference");
  std::vector<RefArg> args;
  for (std::size_t i = 0; i < references.size(); ++i) args.push_back(RefFromPy(references[i], i));
  fit::FitResult result;
  {
    py::gil_scoped_release no_gil;
    fit::FitProblem problem;
    problem.model = model;
    problem.fixed = std::move(fixed);
    for (std::size_t i = 0; i < args.size(); ++i) {
      // The pixels a fit trains on: the rule the study and the CLI apply (fit/training_pixels.h).
      problem.references.push_back(fit::TrainingPixels(MakeReference(args[i], i), stride));
    }
    result = SharedGl::With([&](Renderer& renderer, GlContext&) {
      o.renderer = &renderer;
      return fit::Fit(problem, o);
    });
  }
  return ResultToPy(std::move(result));
}

py::dict FitBrdf(const std::string& path, const std::string& model_name,
                 const std::vector<std::string>& fixed_text, std::vector<int> cells,
                 double max_theta, py::dict options) {
  const ModelInfo& model = FindModel(model_name);
  const std::vector<FixedValue> fixed = ParseFixedValues(model, fixed_text, "fixed");
  fit::FitOptions o = OptionsFromPy(options);
  fit::BrdfSpaceSampling sampling;
  if (cells.size() != 3) throw Error("", "cells", "three counts: theta_h, theta_d, phi_d");
  sampling.theta_h_cells = cells[0];
  sampling.theta_d_cells = cells[1];
  sampling.phi_d_cells = cells[2];
  sampling.max_theta_deg = max_theta;
  fit::ValidateBrdfSpaceSampling(sampling, "");
  fit::CheckBrdfSpaceOptions(o);
  fit::FitResult result;
  {
    py::gil_scoped_release no_gil;
    const std::unique_ptr<reference_images::MeasuredBrdf> brdf =
        reference_images::LoadMeasuredBrdf(path);
    result = fit::FitBrdfSpace(model, fixed, fit::SampleBrdfSpace(*brdf, sampling), o);
  }
  return ResultToPy(std::move(result));
}

}  // namespace

void RegisterFit(py::module_& m) {
  m.def("fit", &FitArrays, py::arg("references"), py::arg("model"), py::arg("fixed"),
        py::arg("options"));
  m.def("fit_brdf", &FitBrdf, py::arg("path"), py::arg("model"), py::arg("fixed"), py::arg("cells"),
        py::arg("max_theta"), py::arg("options"));
}

}  // namespace shadefit::python
