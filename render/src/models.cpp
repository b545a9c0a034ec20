#include "shadefit/render/models.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "shadefit/render/error.h"

namespace shadefit {
namespace {

// Shared rows. Roughness >= 0.01 keeps alpha = roughness^2 >= 1e-4 (kMinAlpha); classic ks spans
// decades because without normalisation a sharp highlight needs a huge ks to be bright.
ParamSpec Rgb(const std::string& name, double min, double max, double def, const char* what,
              bool log_scale = false) {
  return ParamSpec{name, 3, min, max, def, log_scale, what};
}
ParamSpec Scalar(const std::string& name, double min, double max, double def, const char* what,
                 bool log_scale = false) {
  return ParamSpec{name, 1, min, max, def, log_scale, what};
}

const ParamSpec kRoughness = Scalar("roughness", 0.01, 1.0, 0.5,
                                    "perceptual roughness; alpha = roughness^2");
const ParamSpec kShininess = Scalar("shininess", 1.0, 100000.0, 32.0,
                                    "specular exponent n", /*log_scale=*/true);

std::vector<ModelInfo> BuildModels() {
  const ParamSpec kd = Rgb("kd", 0.0, 1.0, 0.5, "diffuse albedo (Lambert: f = kd / pi)");
  const ParamSpec f0 = Rgb("f0", 0.0, 1.0, 0.04, "Fresnel reflectance at normal incidence");
  const std::vector<ParamSpec> classic = {
      Rgb("ka", 0.0, 1.0, 0.0, "ambient reflectance (times the ambient light)"),
      Rgb("kd", 0.0, 1.0, 0.5, "diffuse coefficient: kd (n.l) per unit light"),
      Rgb("ks", 0.0, 100000.0, 0.5, "specular coefficient (unnormalised)", true),
      kShininess};
  const std::vector<ParamSpec> raw = {kd, f0, kRoughness};
  return {
      {ModelId::kLambert, "lambert", "Lambert diffuse, f = kd / pi", {kd}},
      {ModelId::kPhong, "phong", "classic Phong 1975: ka amb + kd (n.l) + ks (r.v)^n", classic},
      {ModelId::kBlinnPhong, "blinn-phong",
       "classic Blinn-Phong: ka amb + kd (n.l) + ks (n.h)^n, unnormalised", classic},
      {ModelId::kBlinnPhongNormalized, "blinn-phong-normalized",
       "f = kd/pi + ks (n+8)/(8 pi) (n.h)^n",
       {kd, Rgb("ks", 0.0, 1.0, 0.04, "specular reflectance (normalised lobe)"), kShininess}},
      {ModelId::kGgx, "ggx",
       "Cook-Torrance: Lambert + D_GGX V_SmithGGXCorrelated F_Schlick(f0)", raw},
      {ModelId::kGgxMetallic, "ggx-metallic",
       "ggx in metallic-roughness form: kd = base (1-m), f0 = mix(f0_dielectric, base, m)",
       {Rgb("base_color", 0.0, 1.0, 0.8, "base colour"),
        Scalar("metallic", 0.0, 1.0, 0.0, "0 dielectric, 1 metal"), kRoughness,
        Scalar("f0_dielectric", 0.0, 1.0, 0.04, "F0 of the dielectric part")}},
      {ModelId::kGgxSeparable, "ggx-separable", "ggx with separable Smith G (Walter 2007)", raw},
      {ModelId::kGgxDielectric, "ggx-dielectric",
       "Lambert + GGX with exact dielectric Fresnel from an IOR",
       {kd, Scalar("ior", 1.0, 3.0, 1.5, "index of refraction"), kRoughness}},
      {ModelId::kGgxConductor, "ggx-conductor",
       "GGX with conductor Fresnel from a complex IOR (n, k) per channel, no diffuse",
       {Rgb("eta", 0.01, 10.0, 0.2, "real part of the IOR"),
        Rgb("k", 0.0, 10.0, 3.0, "extinction coefficient"), kRoughness}},
      {ModelId::kGgxBurley, "ggx-burley", "ggx with Burley 2012 diffuse", raw},
      {ModelId::kBeckmann, "beckmann",
       "Lambert + Beckmann D, separable Smith-Beckmann G (Walter approx.), Schlick", raw},
      {ModelId::kCyclesPrincipled, "cycles-principled",
       "Cycles 3.4 Principled BSDF, single scattering (separable Smith, Burley, Cycles Fresnel)",
       {Rgb("base_color", 0.0, 1.0, 0.8, "base colour"),
        Scalar("metallic", 0.0, 1.0, 0.0, "0 dielectric, 1 metal"),
        Scalar("specular", 0.0, 1.0, 0.5, "Cycles specular; F0 = 0.08 specular"),
        kRoughness}},
  };
}

}  // namespace

int ModelInfo::ParamCount() const {
  int n = 0;
  for (const auto& p : params) n += p.size;
  return n;
}

int ModelInfo::Offset(const std::string& name) const {
  int offset = 0;
  for (const auto& p : params) {
    if (p.name == name) return offset;
    offset += p.size;
  }
  return -1;
}

const ParamSpec* ModelInfo::Find(const std::string& name) const {
  for (const auto& p : params) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

const ParamSpec& ModelInfo::SpecOfEntry(int i) const {
  for (const auto& p : params) {
    if (i < p.size) return p;
    i -= p.size;
  }
  throw Error("", "parameter", fmt::format("index {} out of range for model {}", i, name));
}

std::string ModelInfo::EntryName(int i) const {
  for (const auto& p : params) {
    if (i < p.size) return p.size == 1 ? p.name : p.name + "." + "rgb"[i];
    i -= p.size;
  }
  return "?";
}

const std::vector<ModelInfo>& AllModels() {
  static const std::vector<ModelInfo> models = BuildModels();
  return models;
}

const ModelInfo& FindModel(const std::string& name) {
  std::string known;
  std::vector<std::string> names;
  for (const auto& m : AllModels()) {
    if (m.name == name) return m;
    known += (known.empty() ? "" : ", ") + m.name;
    names.push_back(m.name);
  }
  throw Error("", "model",
              fmt::format("unknown model '{}'{} (known: {})", name, DidYouMean(name, names), known));
}

const ModelInfo& GetModel(ModelId id) {
  for (const auto& m : AllModels()) {
    if (m.id == id) return m;
  }
  throw Error("", "model", "internal: model id not registered");
}

std::vector<double> DefaultParams(const ModelInfo& model) {
  std::vector<double> values;
  for (const auto& p : model.params) values.insert(values.end(), p.size, p.default_value);
  // Sensible colour defaults differ per row only through default_value; nothing else to do.
  return values;
}

void SetParam(const ModelInfo& model, const std::string& name, const std::vector<double>& values,
              const std::string& context, std::vector<double>* params) {
  const ParamSpec* spec = model.Find(name);
  if (!spec) {
    std::string known;
    std::vector<std::string> names;
    for (const auto& p : model.params) {
      known += (known.empty() ? "" : ", ") + p.name;
      names.push_back(p.name);
    }
    throw Error(context, name,
                fmt::format("unknown parameter for model {}{} (known: {})", model.name,
                            DidYouMean(name, names), known));
  }
  if (values.size() != 1 && static_cast<int>(values.size()) != spec->size) {
    throw Error(context, name, fmt::format("expected {} value(s), got {}", spec->size,
                                           values.size()));
  }
  const int offset = model.Offset(name);
  for (int c = 0; c < spec->size; ++c) {
    const double v = values.size() == 1 ? values[0] : values[c];
    if (!std::isfinite(v) || v < spec->min || v > spec->max) {
      throw Error(context, name, fmt::format("value {} outside [{}, {}]", v, spec->min,
                                             spec->max));
    }
    (*params)[offset + c] = v;
  }
}

void SetParamFromString(const ModelInfo& model, const std::string& assignment,
                        const std::string& context, std::vector<double>* params) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) {
    throw Error(context, assignment, "expected name=value or name=v1,v2,v3");
  }
  const std::string name = assignment.substr(0, eq);
  std::vector<double> values;
  std::stringstream ss(assignment.substr(eq + 1));
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      std::size_t used = 0;
      values.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw Error(context, name, fmt::format("'{}' is not a number", item));
    }
  }
  if (values.empty()) throw Error(context, name, "no value given");
  SetParam(model, name, values, context, params);
}

double SpecularLobeAlpha(ModelId id, const double* p) {
  switch (id) {
    case ModelId::kLambert:
      return 0.0;
    case ModelId::kPhong:
    case ModelId::kBlinnPhong:
      // Walter et al. 2007, section 5.2: Phong exponent n ~ 2 / alpha_b^2 - 2 (Beckmann width),
      // close enough to a GGX alpha for a sampling proposal.
      return std::sqrt(2.0 / (p[9] + 2.0));
    case ModelId::kBlinnPhongNormalized:
      return std::sqrt(2.0 / (p[6] + 2.0));
    case ModelId::kGgxMetallic:
      return p[4] * p[4];
    case ModelId::kGgxDielectric:
      return p[4] * p[4];
    case ModelId::kCyclesPrincipled:
      return p[5] * p[5];
    default:
      return p[6] * p[6];  // kd, f0 | eta, k, roughness layouts.
  }
}

}  // namespace shadefit
