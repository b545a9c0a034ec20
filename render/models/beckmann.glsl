// Cook-Torrance with the Beckmann distribution (Beckmann 1963, as written in Walter et al.
// 2007, eq. 25), separable Smith-Beckmann G with Walter's rational G1 (eq. 27) and Schlick F.
SF_MODEL(Beckmann)
SF_INFO("beckmann", "Lambert + Beckmann D, separable Smith-Beckmann G (Walter approx.), Schlick")

#define BECKMANN_PARAMS(X)                                                                         \
  X(Color, kd, 0.0, 1.0, 0.5, kDiffuseParam, "diffuse albedo (Lambert: f = kd / pi)")              \
  X(Color, f0, 0.0, 1.0, 0.04, kSpecularParam | kMultiplicative | kFresnelParam,                   \
    "Fresnel reflectance at normal incidence")                                                     \
  X(Real, roughness, 0.01, 1.0, 0.5, kWidthParam | kMultiplicative,                                \
    "perceptual roughness; alpha = roughness^2")
SF_PARAMS(BECKMANN_PARAMS)
#undef BECKMANN_PARAMS

SF_FN Color Diffuse(Params p, Dots d) { return p.kd * Real(kInvPi); }
SF_FN Real Lobe(Params p, Dots d) {
  Real alpha = p.roughness * p.roughness;
  return D_Beckmann(d.NoH, d.one_minus_NoH2, alpha) *
         V_SmithBeckmannSeparable(d.NoV, d.NoL, alpha) * Real(d.NoL);
}
SF_FN Color Fresnel(Params p, Dots d) {
  return F_SchlickColor(p.f0, d.LoH);
}
SF_FN Real LobeAlpha(Params p) { return p.roughness * p.roughness; }
SF_FN Color Ambient(Params p) { return Color(Real(0)); }

SF_END_MODEL
