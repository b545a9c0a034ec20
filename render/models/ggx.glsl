// Cook-Torrance with GGX: f = kd / pi + D_GGX V_SmithGGXCorrelated F_Schlick(f0).
// Cook and Torrance 1982 (the microfacet form); Walter et al. 2007, eq. 33 (D); Heitz 2014,
// eq. 99 (height-correlated Smith V); Schlick 1994, eq. 15 (F). Terms in brdf.h.
// Variant ggx-separable (SF_VARIANT_GGX_SEPARABLE, render/CMakeLists.txt): the separable Smith
// masking-shadowing G1(v) G1(l) (Walter et al. 2007, eq. 34) in place of the height-correlated
// one, the form Cycles 3.4's Principled BSDF uses.
#ifdef SF_VARIANT_GGX_SEPARABLE
SF_MODEL(GgxSeparable)
SF_INFO("ggx-separable", "ggx with separable Smith G (Walter 2007)")
#define GGX_SMITH_V V_SmithGGXSeparable
#else
SF_MODEL(Ggx)
SF_INFO("ggx", "Cook-Torrance: Lambert + D_GGX V_SmithGGXCorrelated F_Schlick(f0)")
#define GGX_SMITH_V V_SmithGGXCorrelated
#endif

#define GGX_PARAMS(X)                                                                              \
  X(Color, kd, 0.0, 1.0, 0.5, kDiffuseParam, "diffuse albedo (Lambert: f = kd / pi)")              \
  X(Color, f0, 0.0, 1.0, 0.04, kSpecularParam | kMultiplicative | kFresnelParam,                   \
    "Fresnel reflectance at normal incidence")                                                     \
  X(Real, roughness, 0.01, 1.0, 0.5, kWidthParam | kMultiplicative,                                \
    "perceptual roughness; alpha = roughness^2")
SF_PARAMS(GGX_PARAMS)
#undef GGX_PARAMS

SF_FN Color Diffuse(Params p, Dots d) { return p.kd * Real(kInvPi); }
SF_FN Real Lobe(Params p, Dots d) {
  Real alpha = p.roughness * p.roughness;
  return D_GGX(d.NoH, d.one_minus_NoH2, alpha) * GGX_SMITH_V(d.NoV, d.NoL, alpha) *
         Real(d.NoL);
}
SF_FN Color Fresnel(Params p, Dots d) {
  return F_SchlickColor(p.f0, d.LoH);
}
SF_FN Real LobeAlpha(Params p) { return p.roughness * p.roughness; }
SF_FN Color Ambient(Params p) { return Color(Real(0)); }

SF_END_MODEL
#undef GGX_SMITH_V
