// A probe's reference read from its files (image, sidecar, scene): shared by `shadefit probe`
// and the Python module's probes.
#include <string>
#include <utility>

#include "shadefit/probes/probes.h"
#include "shadefit/reference_images/reference.h"
#include "shadefit/reference_images/sidecar.h"

namespace shadefit::probes {

std::string LightingOfReference(const std::string& name) {
  const auto dash = name.rfind('-');
  return dash == std::string::npos ? name : name.substr(dash + 1);
}

ProbeReference LoadProbeReference(const std::string& path, Renderer& renderer) {
  reference_images::Reference fr = reference_images::LoadReference(path);
  ProbeReference r;
  r.name = fr.name;
  r.lighting = LightingOfReference(fr.name);
  r.scene = fr.scene;
  r.gbuffer = renderer.RenderGBuffer(r.scene);
  r.image = std::move(fr.image);
  if (r.image.channels == 3) {  // No alpha in the file: coverage from the G-buffer.
    Image rgba(r.image.width, r.image.height, 4);
    for (int y = 0; y < rgba.height; ++y) {
      for (int x = 0; x < rgba.width; ++x) {
        for (int c = 0; c < 3; ++c) rgba.at(x, y, c) = r.image.at(x, y, c);
        if (x < r.gbuffer.width && y < r.gbuffer.height)
          rgba.at(x, y, 3) = r.gbuffer.Coverage(x, y);
      }
    }
    r.image = std::move(rgba);
  }
  return r;
}

std::optional<ModelUnderTest> TruthOfReference(const std::string& sidecar_path,
                                               std::string* why_not) {
  const std::optional<reference_images::SidecarTruth> truth =
      reference_images::TruthOfSidecar(sidecar_path, why_not);
  if (!truth) return std::nullopt;
  ModelUnderTest t;
  t.label = "truth";
  t.model = truth->model;
  t.params = truth->params;
  return t;
}

}  // namespace shadefit::probes
