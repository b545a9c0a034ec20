// BRDF terms, templated on the scalar so that the same code runs with double and ceres::Jet.
//
// Every term here has a GLSL twin of the same name in render/shaders/brdf.glsl; the test
// tests/render/glsl_twin_test.cpp renders with the GL copy and holds the two to 1e-3 relative.
// Naming follows Filament's surface_brdf.fs: D_*, V_* (visibility = G / (4 NoL NoV)), F_*, Fd_*.
// Arguments are cosines clamped by the caller to (0, 1]; alpha is the GGX/Beckmann width.
#pragma once

#include <cmath>

namespace shadefit {

// Smallest alpha the terms accept: alpha = roughness^2 and roughness >= 0.01 in every parameter
// table, so alpha >= 1e-4; the clamp keeps D finite if a caller passes less.
inline constexpr double kMinAlpha = 1e-4;
inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kInvPi = 1.0 / kPi;

template <typename T>
T Pow5(const T& x) {
  const T x2 = x * x;
  return x2 * x2 * x;
}

// Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces", eq. 33.
// one_minus_NoH2 = |n x h|^2 is passed separately: 1 - NoH^2 cancels catastrophically in float
// near the peak, and the GL copy must agree with this one at alpha = 1e-4 (Filament does the same).
template <typename T, typename G>
T D_GGX(const G& NoH, const G& one_minus_NoH2, const T& alpha) {
  using std::max;
  const T a = alpha < T(kMinAlpha) ? T(kMinAlpha) : alpha;
  const T a2 = a * a;
  const T d = T(one_minus_NoH2) + T(NoH * NoH) * a2;
  return a2 / (T(kPi) * d * d);
}

// Beckmann 1963 distribution, as written in Walter et al. 2007, eq. 25.
template <typename T, typename G>
T D_Beckmann(const G& NoH, const G& one_minus_NoH2, const T& alpha) {
  using std::exp;
  const T a = alpha < T(kMinAlpha) ? T(kMinAlpha) : alpha;
  const T a2 = a * a;
  const G cos2 = NoH * NoH;
  const G tan2 = one_minus_NoH2 / cos2;
  return exp(-T(tan2) / a2) / (T(kPi) * a2 * T(cos2 * cos2));
}

// Heitz 2014, "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs", eq. 99
// (height-correlated Smith for GGX), written as V = G2 / (4 NoL NoV). The sqrt arguments are
// >= alpha^2 > 0, so Jet derivatives stay finite.
template <typename T, typename G>
T V_SmithGGXCorrelated(const G& NoV, const G& NoL, const T& alpha) {
  using std::sqrt;
  const T a = alpha < T(kMinAlpha) ? T(kMinAlpha) : alpha;
  const T a2 = a * a;
  const T lambda_v = T(NoL) * sqrt(T(NoV * NoV) * (T(1) - a2) + a2);
  const T lambda_l = T(NoV) * sqrt(T(NoL * NoL) * (T(1) - a2) + a2);
  return T(0.5) / (lambda_v + lambda_l);
}

// Separable Smith GGX, G2 = G1(v) G1(l) with G1 from Walter et al. 2007, eq. 34, folded into
// V = G2 / (4 NoL NoV) = 1 / ((NoV + sqrt(a2 + (1 - a2) NoV^2)) (NoL + sqrt(...))).
// This is what Cycles 3.4's Principled BSDF uses.
template <typename T, typename G>
T V_SmithGGXSeparable(const G& NoV, const G& NoL, const T& alpha) {
  using std::sqrt;
  const T a = alpha < T(kMinAlpha) ? T(kMinAlpha) : alpha;
  const T a2 = a * a;
  const T gv = T(NoV) + sqrt(a2 + (T(1) - a2) * T(NoV * NoV));
  const T gl = T(NoL) + sqrt(a2 + (T(1) - a2) * T(NoL * NoL));
  return T(1) / (gv * gl);
}

// Smith G1 for Beckmann with the rational approximation of Walter et al. 2007, eq. 27
// (maximum error about 0.35% against the erf form).
template <typename T, typename G>
T G1_SmithBeckmann(const G& NoX, const T& alpha) {
  using std::sqrt;
  const T a = alpha < T(kMinAlpha) ? T(kMinAlpha) : alpha;
  const G sin_x = sqrt(G(1) - NoX * NoX > G(0) ? G(1) - NoX * NoX : G(0));
  if (!(sin_x > G(0))) return T(1);  // Normal incidence: no masking.
  const T c = T(NoX / sin_x) / a;
  if (c >= T(1.6)) return T(1);  // Walter: the approximation is 1 beyond c = 1.6.
  const T c2 = c * c;
  return (T(3.535) * c + T(2.181) * c2) / (T(1) + T(2.276) * c + T(2.577) * c2);
}

template <typename T, typename G>
T V_SmithBeckmannSeparable(const G& NoV, const G& NoL, const T& alpha) {
  return G1_SmithBeckmann(NoV, alpha) * G1_SmithBeckmann(NoL, alpha) / T(4.0 * NoV * NoL);
}

// Schlick 1994, "An Inexpensive BRDF Model for Physically-based Rendering", eq. 15.
template <typename T, typename G>
T F_Schlick(const T& f0, const G& VoH) {
  return f0 + (T(1) - f0) * T(Pow5(G(1) - VoH));
}

// Exact unpolarised Fresnel reflectance of a dielectric interface, light arriving from the
// outside medium (index 1) onto index eta (Walter et al. 2007, eq. 22).
template <typename T, typename G>
T F_Dielectric(const G& cos_i, const T& eta) {
  using std::sqrt;
  const T g2 = eta * eta - T(1) + T(cos_i * cos_i);
  if (!(g2 > T(0))) return T(1);  // Total internal reflection (eta < 1 only).
  const T g = sqrt(g2);
  const T a = (g - T(cos_i)) / (g + T(cos_i));
  const T b = (T(cos_i) * (g + T(cos_i)) - T(1)) / (T(cos_i) * (g - T(cos_i)) + T(1));
  return T(0.5) * a * a * (T(1) + b * b);
}

// Exact unpolarised Fresnel reflectance of a conductor with complex index eta + i k, from air.
// Formulation of Lazanyi and Szirmay-Kalos 2005 as written in pbrt-v3 (FrConductor), derived from
// Born and Wolf's Principles of Optics, section 14.2.
template <typename T, typename G>
T F_Conductor(const G& cos_i, const T& eta, const T& k) {
  using std::sqrt;
  const T c2 = T(cos_i * cos_i);
  const T s2 = T(1) - c2;
  const T eta2 = eta * eta;
  const T k2 = k * k;
  const T t0 = eta2 - k2 - s2;
  const T a2b2 = sqrt(t0 * t0 + T(4) * eta2 * k2);  // > 0 whenever eta > 0.
  const T a = sqrt(T(0.5) * (a2b2 + t0) + T(1e-12));
  const T t1 = a2b2 + c2;
  const T t2 = T(2) * T(cos_i) * a;
  const T rs = (t1 - t2) / (t1 + t2);
  const T t3 = c2 * a2b2 + s2 * s2;
  const T t4 = t2 * s2;
  const T rp = rs * (t3 - t4) / (t3 + t4);
  return T(0.5) * (rp + rs);
}

// Cycles 3.4 Principled BSDF Fresnel (intern/cycles/kernel/closure/bsdf_util.h,
// interpolate_fresnel_color): the dielectric Fresnel curve of the IOR implied by `specular`,
// remapped so that it runs from cspec0 at normal incidence to 1 at grazing.
template <typename T, typename G>
T F_CyclesPrincipled(const T& cspec0, const T& ior, const G& LoH) {
  const T f0 = F_Dielectric(G(1), ior);
  const T fh = (F_Dielectric(LoH, ior) - f0) / (T(1) - f0);
  return cspec0 * (T(1) - fh) + fh;
}

// Lambert 1760: a constant 1/pi.
template <typename T>
T Fd_Lambert() {
  return T(kInvPi);
}

// Burley 2012, "Physically-Based Shading at Disney", section 5.3: the retro-reflective diffuse
// with f_d90 = 0.5 + 2 roughness LoH^2. Roughness is the artist roughness (not alpha), as in
// Cycles' principled diffuse.
template <typename T, typename G>
T Fd_Burley(const G& NoV, const G& NoL, const G& LoH, const T& roughness) {
  const T f90 = T(0.5) + T(2) * roughness * T(LoH * LoH);
  const T light = T(1) + (f90 - T(1)) * T(Pow5(G(1) - NoL));
  const T view = T(1) + (f90 - T(1)) * T(Pow5(G(1) - NoV));
  return light * view * T(kInvPi);
}

}  // namespace shadefit
