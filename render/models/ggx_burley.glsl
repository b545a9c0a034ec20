// ggx with Burley's retro-reflective diffuse (Burley 2012, "Physically-Based Shading at
// Disney", section 5.3) in place of Lambert.
SF_MODEL(GgxBurley)
SF_INFO("ggx-burley", "ggx with Burley 2012 diffuse")

#define GGX_BURLEY_PARAMS(X)                                                                       \
  X(Color, kd, 0.0, 1.0, 0.5, kDiffuseParam, "diffuse albedo (Lambert: f = kd / pi)")              \
  X(Color, f0, 0.0, 1.0, 0.04, kSpecularParam | kMultiplicative | kFresnelParam,                   \
    "Fresnel reflectance at normal incidence")                                                     \
  X(Real, roughness, 0.01, 1.0, 0.5, kWidthParam | kMultiplicative,                                \
    "perceptual roughness; alpha = roughness^2")
SF_PARAMS(GGX_BURLEY_PARAMS)
#undef GGX_BURLEY_PARAMS

SF_FN Color Diffuse(Params p, Dots d) { return p.kd * Fd_Burley(d.NoV, d.NoL, d.LoH, p.roughness); }
SF_FN Real Lobe(Params p, Dots d) {
  Real alpha = p.roughness * p.roughness;
  return D_GGX(d.NoH, d.one_minus_NoH2, alpha) * V_SmithGGXCorrelated(d.NoV, d.NoL, alpha) *
         Real(d.NoL);
}
SF_FN Color Fresnel(Params p, Dots d) {
  return F_SchlickColor(p.f0, d.LoH);
}
SF_FN Real LobeAlpha(Params p) { return p.roughness * p.roughness; }
SF_FN Color Ambient(Params p) { return Color(Real(0)); }

SF_END_MODEL
