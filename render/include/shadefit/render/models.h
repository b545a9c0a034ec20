// The shading models: parameter tables and the C++ twin of the GLSL shading code.
//
// Every model exposes the same quantity, the reflected radiance per unit irradiance of a light
// arriving from l, seen from v:  Reflect(l, v) = f(l, v) * (n . l)  for the physically based
// models, and  kd (n . l) + ks spec(l, v)  for the classic ones (Phong 1975; Blinn 1977), whose
// light colours multiply the whole expression (no 1/pi, no normalisation: that is the point of
// the comparison; see docs/models.md). Point lights contribute E = I / d^2, directional lights
// their irradiance, environments integrate Reflect against their radiance; the ambient light
// adds ambient * ka for models that have a `ka` parameter.
#pragma once

#include <string>
#include <vector>

#include "shadefit/render/brdf.h"
#include "shadefit/render/vec.h"

namespace shadefit {

enum class ModelId {
  kLambert,
  kPhong,
  kBlinnPhong,
  kBlinnPhongNormalized,
  kGgx,                // raw: kd, f0, roughness; Lambert + GGX, correlated Smith, Schlick.
  kGgxMetallic,        // metallic-roughness parametrisation of kGgx.
  kGgxSeparable,       // kGgx with separable Smith G.
  kGgxDielectric,      // exact dielectric Fresnel from an IOR.
  kGgxConductor,       // conductor Fresnel from a complex IOR per channel, no diffuse.
  kGgxBurley,          // kGgx with Burley diffuse.
  kBeckmann,           // Beckmann D, separable Smith-Beckmann G, Schlick.
  kCyclesPrincipled,   // Cycles 3.4 Principled BSDF, single scattering.
};

// One row of a model's parameter table (as the `[type name min max default]` blocks of the Disney
// BRDF Explorer). Colours have size 3 and share the row's bounds and default.
struct ParamSpec {
  std::string name;
  int size = 1;             // 1 (scalar) or 3 (RGB).
  double min = 0.0;         // Inclusive bounds; the fitter uses them as box constraints.
  double max = 1.0;
  double default_value = 0.0;
  bool log_scale = false;   // Fit in log space (spans decades: shininess, classic ks).
  std::string description;
};

struct ModelInfo {
  ModelId id;
  std::string name;         // CLI name, e.g. "blinn-phong-normalized".
  std::string description;
  std::vector<ParamSpec> params;

  int ParamCount() const;                     // Flattened length (colours count 3).
  int Offset(const std::string& name) const;  // Flattened index of a row; -1 when absent.
  const ParamSpec* Find(const std::string& name) const;
  // Flattened name of entry i: "kd.r", "roughness", ...
  std::string EntryName(int i) const;
  const ParamSpec& SpecOfEntry(int i) const;
};

const std::vector<ModelInfo>& AllModels();
// Throws shadefit::Error("", "model", ...) listing the known names when `name` is unknown.
const ModelInfo& FindModel(const std::string& name);
const ModelInfo& GetModel(ModelId id);

std::vector<double> DefaultParams(const ModelInfo& model);
// Sets row `name` from 1 or `size` values (a scalar fills a colour). Throws shadefit::Error naming
// `context` (a file or "--set") and the parameter on unknown names, wrong counts and values
// outside [min, max].
void SetParam(const ModelInfo& model, const std::string& name, const std::vector<double>& values,
              const std::string& context, std::vector<double>* params);
// "name=v" or "name=v1,v2,v3" as given on the command line.
void SetParamFromString(const ModelInfo& model, const std::string& assignment,
                        const std::string& context, std::vector<double>* params);

// Width of the GGX lobe that best stands for the model's specular lobe, used only to importance
// sample environment lighting (any proposal is unbiased; a close one converges faster).
// Returns 0 for models without a specular lobe.
double SpecularLobeAlpha(ModelId id, const double* params);

namespace internal {

template <typename T>
struct Rgb {
  T r, g, b;
};

// Microfacet building blocks shared by the GGX family.
enum class Distribution { kGgx, kBeckmann };
enum class Visibility { kSmithGgxCorrelated, kSmithGgxSeparable, kSmithBeckmannSeparable };

}  // namespace internal

// Reflect(l, v) of the model, written to out[0..2]. n, l, v are unit vectors (world space);
// returns 0 when l or v is below the surface. T is double or ceres::Jet; G (geometry) is double
// or float, or equal to T.
template <typename T, typename G>
void Reflect(ModelId id, const T* p, const Vec3<G>& n, const Vec3<G>& l, const Vec3<G>& v,
             T* out);

// ka for models that have it (scaled by the ambient light's radiance by the caller), else 0.
template <typename T>
void AmbientReflectance(ModelId id, const T* p, T* out) {
  const bool has_ka = id == ModelId::kPhong || id == ModelId::kBlinnPhong;
  for (int c = 0; c < 3; ++c) out[c] = has_ka ? p[c] : T(0);
}

}  // namespace shadefit

#include "shadefit/render/models_inl.h"
