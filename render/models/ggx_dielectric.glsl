// Lambert + GGX with the exact unpolarised dielectric Fresnel of an index of refraction,
// evaluated at i . m = LoH (Walter et al. 2007, eq. 22), instead of Schlick's approximation.
SF_MODEL(GgxDielectric)
SF_INFO("ggx-dielectric", "Lambert + GGX with exact dielectric Fresnel from an IOR")

#define GGX_DIELECTRIC_PARAMS(X)                                                                   \
  X(Color, kd, 0.0, 1.0, 0.5, kDiffuseParam, "diffuse albedo (Lambert: f = kd / pi)")              \
  X(Real, ior, 1.0, 3.0, 1.5, kFresnelParam, "index of refraction")                                \
  X(Real, roughness, 0.01, 1.0, 0.5, kWidthParam | kMultiplicative,                                \
    "perceptual roughness; alpha = roughness^2")
SF_PARAMS(GGX_DIELECTRIC_PARAMS)
#undef GGX_DIELECTRIC_PARAMS

SF_FN Color Diffuse(Params p, Dots d) { return p.kd * Real(kInvPi); }
SF_FN Real Lobe(Params p, Dots d) {
  Real alpha = p.roughness * p.roughness;
  return D_GGX(d.NoH, d.one_minus_NoH2, alpha) * V_SmithGGXCorrelated(d.NoV, d.NoL, alpha) *
         Real(d.NoL);
}
SF_FN Color Fresnel(Params p, Dots d) { return Color(F_Dielectric(d.LoH, p.ior)); }
SF_FN Real LobeAlpha(Params p) { return p.roughness * p.roughness; }
SF_FN Color Ambient(Params p) { return Color(Real(0)); }

SF_END_MODEL
