// Synthetic references for the probe tests: small renders of known models under the reference
// lightings (reference_images/cycles/scenes, scaled down), plus the GL context.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "../render/test_util.h"
#include "shadefit/probes/probes.h"
#include "shadefit/render/models.h"

namespace shadefit::testing {

// Scene text for a lighting: sphere key/camera/side/rim (the camera light sits exactly at the
// camera, so l = v and theta_d = 0 everywhere), plane mirrorNN (light at the camera's mirror
// position: the centre pixel is the specular peak at theta_i = theta_o = NN deg), or the white
// furnace "uniform".
inline std::string ProbeSceneToml(const std::string& lighting, int res) {
  const std::string pt = "[[lights]]\ntype = \"point\"\npower = 1000.0\nposition = ";
  if (lighting.rfind("mirror", 0) == 0) {
    const double deg = std::stod(lighting.substr(6));
    const double t = deg * 3.14159265358979323846 / 180.0;
    const std::string cam = std::to_string(5.0 * std::cos(t));
    const std::string s = std::to_string(5.0 * std::sin(t));
    return "[camera]\nposition = [0.0, -" + s + ", " + cam +
           "]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nfov_y = 30.0\nresolution = [" +
           std::to_string(res) + ", " + std::to_string(res) +
           "]\n[[objects]]\ntype = \"plane\"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n"
           "half_size = [2.0, 2.0]\n" +
           pt + "[0.0, " + s + ", " + cam + "]\n";
  }
  std::string light;
  if (lighting == "key")
    light = pt + "[2.5, -3.5355339, 2.5]\n";
  else if (lighting == "camera")
    light = pt + "[0.0, -6.0, 0.0]\n";
  else if (lighting == "side")
    light = pt + "[4.9240388, 0.0, 0.8682409]\n";
  else if (lighting == "rim")
    light = pt + "[1.7677670, 4.3301270, 1.7677670]\n";
  else
    light = "[[lights]]\ntype = \"uniform\"\nradiance = 1.0\nsamples = 256\n";
  return SphereSceneToml(res, res, light);
}

inline probes::ModelUnderTest MakeModel(const std::string& label, const std::string& model,
                                        const std::vector<std::string>& sets) {
  const ModelInfo& info = FindModel(model);
  probes::ModelUnderTest m;
  m.label = label;
  m.model = info;
  m.params = DefaultParams(info);
  for (const auto& s : sets) SetParamFromString(info, s, "test", &m.params);
  return m;
}

// A reference rendered by GL from `truth` (times its exposure).
inline probes::ProbeReference MakeReference(const probes::ModelUnderTest& truth,
                                            const std::string& lighting, int res = 64) {
  Renderer& r = SharedRenderer();
  probes::ProbeReference ref;
  ref.name = truth.label + "-" + lighting;
  ref.lighting = lighting;
  ref.scene = ParseScene(ProbeSceneToml(lighting, res), ref.name + ".toml");
  ref.gbuffer = r.RenderGBuffer(ref.scene);
  ref.image = r.Render(ref.scene, truth.model->id, truth.params);
  for (std::size_t i = 0; i < ref.image.PixelCount(); ++i) {
    for (int c = 0; c < 3; ++c) ref.image.data[i * 4 + c] *= static_cast<float>(truth.exposure);
  }
  return ref;
}

// The curve of `kind` for `series` (on `reference`; empty: pooled); throws when there is none, so
// that the test fails naming it.
inline const probes::ProbeCurve& CurveOf(const probes::ProbeResult& r, probes::CurveKind kind,
                                         const std::string& series,
                                         const std::string& reference = "") {
  const probes::ProbeCurve* c = probes::FindCurve(r, kind, series, reference);
  if (c == nullptr) {
    throw std::runtime_error("no curve '" + std::string(probes::CurveKindName(kind)) + "' of " +
                             series + (reference.empty() ? "" : " @ " + reference));
  }
  return *c;
}

// Points of a curve as (x, y) pairs (non-finite ones, written as null, skipped).
inline std::vector<std::pair<double, double>> CurvePoints(const probes::ProbeCurve& curve) {
  std::vector<std::pair<double, double>> out;
  for (std::size_t i = 0; i < curve.x.size(); ++i) {
    if (!std::isfinite(curve.x[i]) || !std::isfinite(curve.y[i])) continue;
    out.emplace_back(curve.x[i], curve.y[i]);
  }
  return out;
}

}  // namespace shadefit::testing
