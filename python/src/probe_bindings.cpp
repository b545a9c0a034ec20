// The phenomenon probes (docs/probes.md) as `shadefit probe` runs them
// (studies/cli/probe_command.cpp): references from files with their sidecar scenes, their
// G-buffers rendered here; models as dicts; the result as the probe's JSON.
//
// Links: shadefit::probes, shadefit::reference_images.
#include <fmt/format.h>
#include <pybind11/stl.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common.h"
#include "shadefit/base/error.h"
#include "shadefit/probes/brdf_space.h"
#include "shadefit/probes/probes.h"
#include "shadefit/reference_images/measured_brdf.h"
#include "shadefit/reference_images/reference.h"
#include "shadefit/reference_images/sidecar.h"

namespace shadefit::python {
namespace {

// {"model", "params", "label", "exposure", "trained_on"} (normalised by __init__.py).
probes::ModelUnderTest ModelFromPy(py::handle h) {
  const py::dict d = py::reinterpret_borrow<py::dict>(h);
  probes::ModelUnderTest m;
  const ModelInfo& info = FindModel(d["model"].cast<std::string>());
  m.model = info;
  m.label = d["label"].is_none() ? info.name : d["label"].cast<std::string>();
  m.params = ParamsFromPy(info, d["params"], m.label);
  m.exposure = d["exposure"].cast<double>();
  m.trained_on = d["trained_on"].cast<std::vector<std::string>>();
  return m;
}

py::object Probe(const std::string& name, const std::vector<std::string>& references,
                 py::list models_in, bool truth_from_sidecar, const std::string& brdf_path) {
  const std::optional<probes::ProbeKind> kind = probes::ParseProbeKind(name);
  if (!kind) {
    const std::vector<std::string> names = probes::ProbeNames();
    std::string all;
    for (const auto& n : names) all += (all.empty() ? "" : ", ") + n;
    throw Error(
        "", "probe",
        fmt::format("unknown probe '{}'{} (one of {})", name, DidYouMean(name, names), all));
  }
  std::vector<probes::ModelUnderTest> models;
  for (auto h : models_in) models.push_back(ModelFromPy(h));
  nlohmann::json j;
  {
    py::gil_scoped_release no_gil;
    if (*kind == probes::ProbeKind::kBrdf) {
      if (brdf_path.empty()) throw Error("", "brdf", "the brdf probe needs a measured BRDF file");
      if (!references.empty()) throw Error("", "references", "not read by the brdf probe");
      if (truth_from_sidecar) throw Error("", "truth_from_sidecar", "not used by the brdf probe");
      const std::unique_ptr<reference_images::MeasuredBrdf> brdf =
          reference_images::LoadMeasuredBrdf(brdf_path);
      j = probes::ProbeResultToJson(probes::BrdfSpaceProbe(*brdf, models));
    } else {
      if (!brdf_path.empty()) throw Error("", "brdf", "only the brdf probe reads a measured BRDF");
      if (references.empty() && *kind != probes::ProbeKind::kEnergy) {
        throw Error("", "references", "at least one reference");
      }
      if (truth_from_sidecar && references.empty()) {
        throw Error("", "truth_from_sidecar", "needs a reference");
      }
      j = SharedGl::With([&](Renderer& renderer, GlContext&) {
        probes::ProbeInputs in;
        in.renderer = &renderer;
        for (const std::string& path : references) {
          in.references.push_back(probes::LoadProbeReference(path, renderer));
        }
        in.models = models;
        if (truth_from_sidecar) {
          const std::string sidecar = reference_images::SidecarPathFor(references.front());
          std::string why_not;
          in.truth = probes::TruthOfReference(sidecar, &why_not);
          if (!in.truth) {
            throw Error(sidecar, "material", why_not + " (needed by truth_from_sidecar)");
          }
        }
        return probes::ProbeResultToJson(probes::RunProbe(*kind, in));
      });
    }
  }
  return JsonToPy(j);
}

}  // namespace

void RegisterProbes(py::module_& m) {
  m.def("probe", &Probe, py::arg("name"), py::arg("references"), py::arg("models"),
        py::arg("truth_from_sidecar"), py::arg("brdf"));
  m.def("probe_names", &probes::ProbeNames);
}

}  // namespace shadefit::python
