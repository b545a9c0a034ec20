// The shading models: their registry and everything derived from their definitions.
//
// Each model is defined once, in render/models/<name>.glsl (the model language of model_dsl.h):
// its parameter table and its terms. This header derives from them what the rest of shadefit
// uses: the table (ModelInfo, for the fitter's bounds and the CLI's --set names) and the C++
// twin of the GLSL program, templated on the parameter scalar and the geometry scalar.
//
// Every model exposes the same quantity, the reflected radiance per unit irradiance of a light
// arriving from l, seen from v:  Reflect(l, v) = Diffuse (n . l) + Fresnel Lobe.  For the
// physically based models that is f(l, v) (n . l); for the classic ones (Phong 1975; Blinn 1977)
// it is kd (n . l) + ks spec(l, v), whose light colours multiply the whole expression (no 1/pi,
// no normalisation: that is the point of the comparison; see docs/models.md). Point lights
// contribute E = I / d^2, directional lights their irradiance, environments integrate Reflect
// against their radiance; the ambient light adds ambient * Ambient (the classic models' ka).
#pragma once

#include <string>
#include <vector>

#include "shadefit/render/brdf.h"
#include "shadefit/render/model_dsl.h"
#include "shadefit/render/model_registry.h"
#include "shadefit/render/vec.h"

namespace shadefit {

struct ModelInfo {
  ModelId id;
  std::string name;         // CLI name, e.g. "blinn-phong-normalized".
  std::string description;
  std::vector<ParamSpec> params;
  std::string glsl_file;    // Key of the model's source among the embedded shaders.

  int ParamCount() const;                     // Flattened length (colours count 3).
  int Offset(const std::string& name) const;  // Flattened index of a row; -1 when absent.
  const ParamSpec* Find(const std::string& name) const;
  // Flattened name of entry i: "kd.r", "roughness", ...
  std::string EntryName(int i) const;
  const ParamSpec& SpecOfEntry(int i) const;
  // The row with the kWidthParam role (roughness, shininess); nullptr for Lambert.
  const ParamSpec* WidthParam() const;
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

// A model resolved once, where its name enters the program (a study file, a command line, a
// sidecar or a job record read back): what travels from there on, so that no later stage looks
// the name up again with an error path of its own. A pointer into AllModels(), cheap to copy.
class ModelRef {
 public:
  ModelRef() = default;                              // None yet: a record being filled.
  ModelRef(const ModelInfo& info) : info_(&info) {}  // NOLINT(google-explicit-constructor)
  const ModelInfo& operator*() const { return *info_; }
  const ModelInfo* operator->() const { return info_; }
  explicit operator bool() const { return info_ != nullptr; }
  friend bool operator==(ModelRef a, ModelRef b) { return a.info_ == b.info_; }

 private:
  const ModelInfo* info_ = nullptr;
};

// A parameter held at a value: one row of a model's table and its natural values, one per entry
// of the row (a scalar given for a colour is already spread). `given` is the text as the user
// wrote it ("ka=0"), kept for provenance records only.
struct FixedValue {
  const ParamSpec* param = nullptr;  // A row of the model it was made for.
  std::vector<double> values;
  std::string given;
};
// "name=v" or "name=v1,v2,v3" (--fix, a study's `fixed`) checked against `model`'s table as
// SetParamFromString checks it, errors naming `context`.
FixedValue ParseFixedValue(const ModelInfo& model, const std::string& assignment,
                           const std::string& context);
std::vector<FixedValue> ParseFixedValues(const ModelInfo& model,
                                         const std::vector<std::string>& assignments,
                                         const std::string& context);
// The texts as given, in order (provenance: a fit's inputs, a job's hash).
std::vector<std::string> FixedTexts(const std::vector<FixedValue>& fixed);

// Width of the GGX lobe that best stands for the model's specular lobe (its LobeAlpha term), used
// only to importance sample environment lighting (any proposal is unbiased; a close one
// converges faster). Returns 0 for models without a specular lobe.
double SpecularLobeAlpha(ModelId id, const double* params);

// The defaults with every kDiffuseParam row at 0 and every kSpecularParam row at 1 (clamped to
// its bounds): the model's specular lobe alone at unit scale, Fresnel 1 where the model has one.
std::vector<double> SpecularOnlyParams(const ModelInfo& model);
// Sets the kWidthParam row of `params` so that SpecularLobeAlpha is `alpha`, by bisection over
// the row's range (LobeAlpha is monotonic in the width), clamped to the range. Returns the value
// set; throws shadefit::Error for a model without a width row.
double SetWidthForAlpha(const ModelInfo& model, double alpha, std::vector<double>* params);

// The terms of one shading configuration; valid = false (all zero) when l or v is below the
// surface, where every model reflects nothing.
template <typename T, typename G>
struct ModelTerms {
  bool valid = false;
  G NoL = G(0);
  Rgb<T> diffuse;  // Diffuse factor per channel, without n . l.
  T lobe = T(0);   // Specular lobe with unit Fresnel and unit coefficient (n . l included).
  Rgb<T> fresnel;  // Specular colour (Fresnel, or the classic models' constant ks).
};

// One term alone, as the GL program renders it with SHADEFIT_TERM (the twin test's handle).
enum class ModelTerm { kReflect = 0, kDiffuse = 1, kLobe = 2, kFresnel = 3 };

// n, l, v are unit vectors (world space). T is double or ceres::Jet; G (geometry) is double or
// float, or equal to T.
template <typename T, typename G>
ModelTerms<T, G> EvaluateTerms(ModelId id, const T* p, const Vec3<G>& n, const Vec3<G>& l,
                               const Vec3<G>& v) {
  ModelTerms<T, G> t;
  const G NoL = Dot(n, l);
  const G NoV = Dot(n, v);
  if (!(NoL > G(0)) || !(NoV > G(0))) return t;
  const ShadingDots<G> d = ComputeShadingDots(n, l, v);
  VisitModel(id, [&](auto tag) {
    using M = typename decltype(tag)::template Of<T, G>;
    const typename M::Params q = M::Load(p);
    t.diffuse = M::Diffuse(q, d);
    t.lobe = M::Lobe(q, d);
    t.fresnel = M::Fresnel(q, d);
  });
  t.valid = true;
  t.NoL = d.NoL;
  return t;
}

// Reflect(l, v) of the model (or one of its terms), written to out[0..2]; 0 when l or v is below
// the surface.
template <typename T, typename G>
void Reflect(ModelId id, const T* p, const Vec3<G>& n, const Vec3<G>& l, const Vec3<G>& v,
             T* out, ModelTerm term = ModelTerm::kReflect) {
  const ModelTerms<T, G> t = EvaluateTerms(id, p, n, l, v);
  Rgb<T> r;
  if (t.valid) {
    switch (term) {
      case ModelTerm::kDiffuse: r = t.diffuse * T(t.NoL); break;
      case ModelTerm::kLobe: r = Rgb<T>(t.lobe); break;
      case ModelTerm::kFresnel: r = t.fresnel; break;
      case ModelTerm::kReflect: r = t.diffuse * T(t.NoL) + t.fresnel * t.lobe; break;
    }
  }
  out[0] = r.r;
  out[1] = r.g;
  out[2] = r.b;
}

// The model's Ambient term (the classic models' ka; the caller scales it by the ambient light's
// radiance), else 0.
template <typename T>
void AmbientReflectance(ModelId id, const T* p, T* out) {
  VisitModel(id, [&](auto tag) {
    using M = typename decltype(tag)::template Of<T, double>;
    const Rgb<T> a = M::Ambient(M::Load(p));
    out[0] = a.r;
    out[1] = a.g;
    out[2] = a.b;
  });
}

}  // namespace shadefit
