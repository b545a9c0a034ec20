// The extension module `shadefit._shadefit`: models, render, metrics, measured BRDFs, and the
// registration of fit, probes and study (their own files). The public functions, their
// docstrings and argument handling live in python/shadefit/__init__.py; what is here takes
// already normalised arguments (docs/python.md).
//
// Links: shadefit::render, shadefit::metrics, shadefit::reference_images (and, through the other files,
// shadefit::fit, shadefit::probes, shadefit::studies), pybind11.
#include <fmt/format.h>
#include <pybind11/stl.h>

#include <cmath>
#include <optional>
#include <string>

#include "common.h"
#include "shadefit/base/error.h"
#include "shadefit/metrics/report.h"
#include "shadefit/reference_images/measured_brdf.h"
#include "shadefit/version.h"

namespace shadefit::python {
namespace {

py::list Models() {
  py::list out;
  for (const ModelInfo& m : AllModels()) {
    py::list params;
    for (const ParamSpec& p : m.params) {
      py::dict row;
      row["name"] = p.name;
      row["size"] = p.size;
      row["min"] = p.min;
      row["max"] = p.max;
      row["default"] = p.default_value;
      row["log_scale"] = p.log_scale;
      row["description"] = p.description;
      params.append(row);
    }
    py::dict model;
    model["name"] = m.name;
    model["description"] = m.description;
    model["parameters"] = params;
    model["entries"] = [&] {
      py::list names;
      for (int i = 0; i < m.ParamCount(); ++i) names.append(m.EntryName(i));
      return names;
    }();
    out.append(model);
  }
  return out;
}

py::array Render(const std::string& scene_path, const std::string& scene_text,
                 const std::string& scene_name, const std::string& model_name, py::handle params) {
  // The CLI's order: model, parameters, scene, then GL.
  const ModelInfo& model = FindModel(model_name);
  const std::vector<double> values = ParamsFromPy(model, params, "params");
  Image image;
  {
    py::gil_scoped_release no_gil;
    const Scene scene = SceneFromArgs(scene_path, scene_text, scene_name);
    image =
        SharedGl::With([&](Renderer& r, GlContext&) { return r.Render(scene, model.id, values); });
  }
  return ImageToArray(std::move(image));
}

py::dict GlInfo() {
  GlDeviceInfo i;
  {
    py::gil_scoped_release no_gil;
    i = SharedGl::With([](Renderer&, GlContext& c) { return c.info(); });
  }
  py::dict d;
  d["platform"] = i.platform;
  d["device"] = i.device;
  d["hardware"] = i.hardware;
  d["gl_vendor"] = i.gl_vendor;
  d["gl_renderer"] = i.gl_renderer;
  d["gl_version"] = i.gl_version;
  d["glsl_version"] = i.glsl_version;
  return d;
}

// An image argument: a path (read as the CLI reads it) or an array.
Image ImageArg(py::handle object, const std::string& what, std::string* name) {
  if (py::isinstance<py::str>(object)) {
    *name = object.cast<std::string>();
    py::gil_scoped_release no_gil;
    return ReadImage(*name);
  }
  return ArrayToImage(object, what, {3, 4});
}

py::dict Metrics(py::handle reference, py::handle test, py::handle mask, float exposure, double ppd,
                 double itp_white, bool maps) {
  // The CLI's checks, in its order, named by the keyword.
  if (!std::isfinite(exposure) || std::abs(exposure) > 64) {
    throw Error("", "exposure", fmt::format("{} stops is not in [-64, 64]", exposure));
  }
  if (!std::isfinite(ppd) || ppd <= 0 || ppd > 1000) {
    throw Error("", "ppd", fmt::format("{} pixels per degree is not in (0, 1000]", ppd));
  }
  if (!std::isfinite(itp_white) || itp_white <= 0 || itp_white > 10000) {
    throw Error("", "itp_white", fmt::format("{} cd/m^2 is not in (0, 10000]", itp_white));
  }
  metrics::MetricsParameters p;
  p.exposure_stops = exposure;
  p.ppd = ppd;
  p.itp_white_luminance = itp_white;
  std::string ref_name, test_name, mask_name;
  const Image r = ImageArg(reference, "reference", &ref_name);
  const Image t = ImageArg(test, "test", &test_name);
  std::optional<Image> m;
  if (py::isinstance<py::str>(mask)) {
    mask_name = mask.cast<std::string>();
    py::gil_scoped_release no_gil;
    m = ReadImage(mask_name);
  } else if (!mask.is_none()) {
    m = MaskToImage(mask, "mask");
  }
  p.names = {ref_name.empty() ? "reference" : ref_name, test_name.empty() ? "test" : test_name,
             mask_name.empty() ? "mask" : mask_name};
  metrics::MetricsMaps out_maps;
  metrics::MetricsReport report;
  {
    py::gil_scoped_release no_gil;
    report = metrics::ComputeMetrics(r, t, m ? &*m : nullptr, p, maps ? &out_maps : nullptr);
  }
  nlohmann::json j = metrics::MetricsToJson(report);
  if (!ref_name.empty()) j["reference"] = ref_name;
  if (!test_name.empty()) j["test"] = test_name;
  if (!mask_name.empty()) j["mask"] = mask_name;
  py::dict d = JsonToPy(j);
  if (maps) {
    py::dict a;
    a["absolute_error"] = ImageToArray(std::move(out_maps.absolute_error), true);
    a["relative_error"] = ImageToArray(std::move(out_maps.relative_error), true);
    a["ssim"] = ImageToArray(std::move(out_maps.ssim), true);
    a["ciede2000"] = ImageToArray(std::move(out_maps.ciede2000), true);
    a["delta_e_itp"] = ImageToArray(std::move(out_maps.delta_e_itp), true);
    a["flip_ldr"] = ImageToArray(std::move(out_maps.flip_ldr), true);
    a["flip_hdr"] = ImageToArray(std::move(out_maps.flip_hdr), true);
    d["maps"] = a;
  }
  return d;
}

py::array ReadImageArray(const std::string& path) {
  Image image;
  {
    py::gil_scoped_release no_gil;
    image = ReadImage(path);
  }
  return ImageToArray(std::move(image));
}

void WriteExrArray(const std::string& path, py::handle array) {
  const Image image = ArrayToImage(array, "image", {1, 3, 4});
  py::gil_scoped_release no_gil;
  WriteExr(path, image);
}

// f(wi, wo) for N direction pairs: (N, 3) float64 each -> (N, 3) float64, 1/sr.
py::array_t<double> EvalBrdf(const reference_images::MeasuredBrdf& brdf,
                             const py::array_t<double>& wi, const py::array_t<double>& wo) {
  const py::ssize_t n = wi.shape(0);
  py::array_t<double> out({n, py::ssize_t{3}});
  const double* a = wi.data();
  const double* b = wo.data();
  double* o = out.mutable_data();
  {
    py::gil_scoped_release no_gil;
    for (py::ssize_t k = 0; k < n; ++k) {
      const Vec3d f =
          brdf.Eval({a[3 * k], a[3 * k + 1], a[3 * k + 2]}, {b[3 * k], b[3 * k + 1], b[3 * k + 2]});
      o[3 * k] = f.x;
      o[3 * k + 1] = f.y;
      o[3 * k + 2] = f.z;
    }
  }
  return out;
}

}  // namespace
}  // namespace shadefit::python

PYBIND11_MODULE(_shadefit, m) {
  using namespace shadefit::python;
  namespace sf = shadefit;
  m.doc() = "shadefit's C++ core; use the package `shadefit` (docs/python.md).";
  m.attr("__version__") = SHADEFIT_VERSION_STRING;
  m.attr("SOURCE_DIR") = SHADEFIT_SOURCE_DIR;

  // shadefit::Error -> shadefit.Error(ValueError), with what() as the message: the CLI's line.
  static py::exception<sf::Error> error(m, "Error", PyExc_ValueError);
  static py::exception<sf::GlContextLostError> lost(m, "GlContextLostError", error.ptr());
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const sf::GlContextLostError& e) {
      lost(e.what());
    } catch (const sf::Error& e) {
      error(e.what());
    }
  });

  m.def("models", &Models);
  m.def("render", &Render, py::arg("scene_path"), py::arg("scene_text"), py::arg("scene_name"),
        py::arg("model"), py::arg("params"));
  m.def("gl_info", &GlInfo);
  m.def("gl_contexts_created", &SharedGl::ContextsCreated);
  m.def("close_gl", [] {
    py::gil_scoped_release no_gil;
    SharedGl::Close();
  });
  m.def("metrics", &Metrics, py::arg("reference"), py::arg("test"), py::arg("mask"),
        py::arg("exposure"), py::arg("ppd"), py::arg("itp_white"), py::arg("maps"));
  m.def("read_image", &ReadImageArray, py::arg("path"));
  m.def("write_exr", &WriteExrArray, py::arg("path"), py::arg("image"));

  py::class_<sf::reference_images::MeasuredBrdf,
             std::shared_ptr<sf::reference_images::MeasuredBrdf>>(m, "MeasuredBrdf")
      .def("eval", &EvalBrdf, py::arg("wi"), py::arg("wo"))
      .def_property_readonly("format", &sf::reference_images::MeasuredBrdf::Format)
      .def_property_readonly("files", &sf::reference_images::MeasuredBrdf::SourceFiles);
  m.def("load_brdf", [](const std::string& path) {
    std::unique_ptr<sf::reference_images::MeasuredBrdf> b;
    {
      py::gil_scoped_release no_gil;
      b = sf::reference_images::LoadMeasuredBrdf(path);
    }
    return std::shared_ptr<sf::reference_images::MeasuredBrdf>(std::move(b));
  });

  RegisterFit(m);
  RegisterProbes(m);
  RegisterStudy(m);
}
