#include "shadefit/probes/probe_kind.h"

#include "shadefit/probes/brdf_space.h"
#include "shadefit/probes/probes.h"
#include "shadefit/base/error.h"

namespace shadefit::probes {

const std::vector<ProbeKind>& AllProbeKinds() {
  static const std::vector<ProbeKind> kAll = {ProbeKind::kFresnel, ProbeKind::kHighlight,
                                              ProbeKind::kEnergy, ProbeKind::kPortability,
                                              ProbeKind::kBrdf};
  return kAll;
}

const char* ProbeName(ProbeKind kind) {
  switch (kind) {
    case ProbeKind::kFresnel: return "fresnel";
    case ProbeKind::kHighlight: return "highlight";
    case ProbeKind::kEnergy: return "energy";
    case ProbeKind::kPortability: return "portability";
    case ProbeKind::kBrdf: return "brdf";
  }
  return "";
}

std::optional<ProbeKind> ParseProbeKind(std::string_view name) {
  for (ProbeKind kind : AllProbeKinds()) {
    if (name == ProbeName(kind)) return kind;
  }
  return std::nullopt;
}

std::vector<std::string> ProbeNames() {
  std::vector<std::string> names;
  for (ProbeKind kind : AllProbeKinds()) names.emplace_back(ProbeName(kind));
  return names;
}

const char* CurveKindName(CurveKind kind) {
  switch (kind) {
    case CurveKind::kSpecularVsThetaV: return "specular vs theta_v";
    case CurveKind::kFresnelVsThetaD: return "F vs theta_d";
    case CurveKind::kFalloff: return "falloff";
    case CurveKind::kAlbedo: return "albedo (quadrature)";
    case CurveKind::kWhiteFurnace: return "white furnace (GL)";
    case CurveKind::kLobeWidthSweep: return "sweep of the lobe width";
    case CurveKind::kRmsePerReference: return "RMSE per reference";
    case CurveKind::kFresnelRise: return "Fresnel rise";
    case CurveKind::kSpecularPeak: return "specular peak";
    case CurveKind::kHighlightF: return "highlight f";
    case CurveKind::kHighlightSpecular: return "highlight specular";
    case CurveKind::kBrdfAlbedo: return "directional albedo";
  }
  return "";
}

const ProbeCurve* FindCurve(const ProbeResult& result, CurveKind kind, std::string_view series,
                            std::string_view reference) {
  for (const ProbeCurve& c : result.curves) {
    if (c.kind == kind && c.series == series && c.reference == reference) return &c;
  }
  return nullptr;
}

ProbeResult RunProbe(ProbeKind kind, const ProbeInputs& inputs) {
  switch (kind) {
    case ProbeKind::kFresnel: return FresnelProbe(inputs);
    case ProbeKind::kHighlight: return HighlightProbe(inputs);
    case ProbeKind::kEnergy: return EnergyProbe(inputs);
    case ProbeKind::kPortability: return PortabilityProbe(inputs);
    case ProbeKind::kBrdf:
      if (!inputs.measured_brdf) throw Error("brdf", "measured_brdf", "the brdf probe needs one");
      return BrdfSpaceProbe(*inputs.measured_brdf, inputs.models);
  }
  throw Error("", "probe", "unknown probe kind");
}

}  // namespace shadefit::probes
