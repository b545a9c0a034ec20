// The C++ side of the small language every shading model in render/models/ is written in once.
//
// A model file (render/models/<name>.glsl, docs/adding-a-model.md) is valid GLSL after
// render/shaders/model_dsl.glsl and valid C++ after this header: the renderer compiles it into
// the fragment program, and render/CMakeLists.txt includes it here, where SF_MODEL opens a class
// template on the parameter scalar `Real` (double or ceres::Jet) and the geometry scalar `Geo`
// (double or float). Geometry arrives as plain numbers (ShadingDots), so AutoDiff carries the
// parameters only. The subset both languages accept:
//   - scalars `Real` and `Geo`, the colour `Color` (GLSL vec3, C++ Rgb<Real>) with + - * /,
//     splat `Color(x)` and `Color(r, g, b)`, channels `.r .g .b`;
//   - functions prefixed `SF_FN` (C++: static members), locals without `const`, explicit
//     `Real(x)` wherever a geometry value or a literal meets a parameter;
//   - unqualified `sqrt exp log pow max min` (std:: for double, ceres:: through ADL for Jet), the
//     terms of brdf.h / brdf.glsl (D_GGX, F_Schlick, ...), and PowCos below.
// Each model declares its parameter table (SF_PARAMS) and five terms with one signature, from
// which everything else is derived (models.h: Reflect, the probes' split, the sampling width,
// the energy sweep's specular-only parameters):
//   Diffuse(p, d)  diffuse factor per channel, without n.l     Reflect = Diffuse * NoL
//   Lobe(p, d)     specular lobe with unit Fresnel and unit              + Fresnel * Lobe
//                  coefficient, with n.l where the model has it    (+ Ambient * ambient light)
//   Fresnel(p, d)  specular colour: Fresnel term, or the constant ks of the classic models
//   LobeAlpha(p)   GGX width that best stands for the lobe (environment importance sampling)
//   Ambient(p)     ambient reflectance (classic models), else 0
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "shadefit/render/brdf.h"
#include "shadefit/render/vec.h"

namespace shadefit {

// Role flags of a parameter-table row (SF_PARAMS' sixth field, combined with |). The roles let
// code that must set a model up generically (the energy sweep's specular-only lobe, start
// heuristics) do so from the table instead of from positions.
inline constexpr unsigned kPlainParam = 0;
inline constexpr unsigned kDiffuseParam = 1u << 0;   // 0 switches the diffuse term off.
inline constexpr unsigned kSpecularParam = 1u << 1;  // 1 makes the specular term unit (F = 1).
inline constexpr unsigned kWidthParam = 1u << 2;     // The lobe width (roughness, shininess).
inline constexpr unsigned kLogScale = 1u << 3;       // Spans decades: fitted in log space.
// Acts multiplicatively on the image (a lobe width, a specular scale): fitted in log space
// although its range is linear (fit/src/residuals.cpp, LogSpaceOf, says why).
inline constexpr unsigned kMultiplicative = 1u << 4;
// Sets the Fresnel reflectance at normal incidence (f0, rs, ior, metallic, ...), with a
// dielectric's value (F0 = 0.04) as its default. With a free exposure, a model whose radiance is
// not linear in its reflectances keeps its scale by pinning these rows at their defaults, colour
// rows in green only (fit/src/exposure_pin.cpp, docs/fitting.md "Free exposure").
inline constexpr unsigned kFresnelParam = 1u << 5;

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
  unsigned roles = kPlainParam;  // k*Param flags above.
};

// RGB of a parameter scalar: GLSL's vec3 for the model language (element-wise operators, a
// scalar on either side). Not Vec3: colours and directions never mix.
template <typename T>
struct Rgb {
  T r, g, b;
  Rgb() : r(0), g(0), b(0) {}
  explicit Rgb(const T& s) : r(s), g(s), b(s) {}
  Rgb(const T& r_, const T& g_, const T& b_) : r(r_), g(g_), b(b_) {}
  const T& operator[](int c) const { return c == 0 ? r : (c == 1 ? g : b); }
};

#define SHADEFIT_RGB_OPERATOR(op)                                                           \
  template <typename T>                                                                     \
  Rgb<T> operator op(const Rgb<T>& a, const Rgb<T>& b) {                                    \
    return {a.r op b.r, a.g op b.g, a.b op b.b};                                            \
  }                                                                                         \
  template <typename T>                                                                     \
  Rgb<T> operator op(const Rgb<T>& a, const T& s) {                                         \
    return {a.r op s, a.g op s, a.b op s};                                                  \
  }                                                                                         \
  template <typename T>                                                                     \
  Rgb<T> operator op(const T& s, const Rgb<T>& a) {                                         \
    return {s op a.r, s op a.g, s op a.b};                                                  \
  }
SHADEFIT_RGB_OPERATOR(+)
SHADEFIT_RGB_OPERATOR(-)
SHADEFIT_RGB_OPERATOR(*)
SHADEFIT_RGB_OPERATOR(/)
#undef SHADEFIT_RGB_OPERATOR

// The dot products of one shading configuration (n, l, v unit vectors, both above the surface):
// everything a model may read of the geometry. Squared sines come from cross products: 1 - c^2
// cancels catastrophically in float near a peak (models.glsl's PowCos, D_GGX).
template <typename G>
struct ShadingDots {
  G NoL, NoV, NoH, LoH, LoV;
  G one_minus_NoH2;  // |n x h|^2
  G RoV;             // r . v, r = 2 (n . l) n - l the mirror direction of l (Phong 1975)
  G one_minus_RoV2;  // |r x v|^2
};

template <typename G>
ShadingDots<G> ComputeShadingDots(const Vec3<G>& n, const Vec3<G>& l, const Vec3<G>& v) {
  ShadingDots<G> d;
  d.NoL = Dot(n, l);
  d.NoV = Dot(n, v);
  // Callers return early when NoL or NoV <= 0, so l + v != 0 here.
  const Vec3<G> h = Normalize(l + v);
  d.NoH = Dot(n, h);
  d.LoH = Dot(l, h);
  d.LoV = Dot(l, v);
  const Vec3<G> nxh = Cross(n, h);
  d.one_minus_NoH2 = Dot(nxh, nxh);
  const Vec3<G> r = n * (G(2) * d.NoL) - l;
  d.RoV = Dot(r, v);
  const Vec3<G> rxv = Cross(r, v);
  d.one_minus_RoV2 = Dot(rxv, rxv);
  return d;
}

// cos^n from a cosine and its squared sine; 0 for cos <= 0. In double pow(cos, n) is exact
// enough; the GLSL twin (model_dsl.glsl) uses the squared sine to keep float precision.
template <typename T, typename G>
T PowCos(const G& cos_x, const G& sin2_x, const T& n) {
  using std::pow;
  (void)sin2_x;
  return cos_x > G(0) ? T(pow(T(cos_x), n)) : T(0);
}

// F_Schlick (brdf.h) per channel of a colour f0.
template <typename T, typename G>
Rgb<T> F_SchlickColor(const Rgb<T>& f0, const G& LoH) {
  return {F_Schlick(f0.r, LoH), F_Schlick(f0.g, LoH), F_Schlick(f0.b, LoH)};
}

template <typename T>
void LoadParam(const T* flat, int& i, T& x) {
  x = flat[i];
  i += 1;
}
template <typename T>
void LoadParam(const T* flat, int& i, Rgb<T>& x) {
  x = Rgb<T>(flat[i], flat[i + 1], flat[i + 2]);
  i += 3;
}

// Tag naming a model's class template, for VisitModel (model_registry.h).
template <template <typename, typename> class M>
struct ModelTag {
  template <typename Real, typename Geo>
  using Of = M<Real, Geo>;
};

// The model language's functions for both scalars, found by unqualified lookup from the model
// classes in namespace shadefit::models (Jet's overloads by ADL).
namespace models {
using std::exp;
using std::log;
using std::max;
using std::min;
using std::pow;
using std::sqrt;
}  // namespace models

}  // namespace shadefit

// Opens a model's class template; SF_END_MODEL closes it.
#define SF_MODEL(Name)                                  \
  template <typename Real, typename Geo>                \
  struct Name {                                         \
    using Color = ::shadefit::Rgb<Real>;                \
    using Dots = ::shadefit::ShadingDots<Geo>;
#define SF_END_MODEL \
  }                  \
  ;
#define SF_FN static
// The model's CLI name and one-line description.
#define SF_INFO(name, description)                    \
  static const char* Name() { return name; }         \
  static const char* Description() { return description; }

// SF_PARAMS(LIST): LIST(X) calls X(type, name, min, max, default, roles, description) per row,
// type being Color or Real. Declares the named Params struct, its loader from the flattened
// vector (rows in table order, colours as 3 entries), the entry and row counts and the table.
#define SF_PARAM_FIELD_(type, name, lo, hi, def, roles, desc) type name;
#define SF_PARAM_LOAD_(type, name, lo, hi, def, roles, desc) LoadParam(flat, i, p.name);
#define SF_PARAM_COUNT_(type, name, lo, hi, def, roles, desc) +int(sizeof(type) / sizeof(Real))
#define SF_PARAM_ROWS_(type, name, lo, hi, def, roles, desc) +1
#define SF_PARAM_ROW_(type, name, lo, hi, def, roles, desc)                                \
  ::shadefit::ParamSpec{#name, int(sizeof(type) / sizeof(Real)), lo, hi, def,             \
                        ((roles) & ::shadefit::kLogScale) != 0, desc, (roles)},
#define SF_PARAMS(LIST)                                               \
  struct Params {                                                     \
    LIST(SF_PARAM_FIELD_)                                             \
  };                                                                  \
  static constexpr int kParamCount = 0 LIST(SF_PARAM_COUNT_);         \
  static constexpr int kRowCount = 0 LIST(SF_PARAM_ROWS_);            \
  static Params Load(const Real* flat) {                              \
    Params p;                                                         \
    int i = 0;                                                        \
    LIST(SF_PARAM_LOAD_)                                              \
    return p;                                                         \
  }                                                                   \
  static std::vector<::shadefit::ParamSpec> Table() { return {LIST(SF_PARAM_ROW_)}; }
