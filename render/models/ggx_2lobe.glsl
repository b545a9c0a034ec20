// Lambert plus two GGX lobes sharing one Schlick Fresnel colour: f = kd / pi + F_Schlick(f0)
// [(1 - w) D V(alpha_1) + w D V(alpha_2)], D = D_GGX (Walter et al. 2007, eq. 33), V =
// V_SmithGGXCorrelated (Heitz 2014, eq. 99), F_Schlick (Schlick 1994, eq. 15). A sharp peak on a
// broad haze, the shape of measured metals' highlights (Ngan, Durand and Matusik 2005, sec. 5.3,
// fitted two Cook-Torrance lobes for it; Low et al. 2012 a wider-tailed distribution). The
// lobes are kept apart by the parametrisation, so a fit cannot swap them: roughness_2 =
// roughness + (1 - roughness) spread >= roughness (spread in [0, 1]). The model language has one
// Fresnel colour per model (Reflect = Diffuse NoL + Fresnel Lobe), so the lobes share f0 and
// split its weight by w: f0 (1 - w) is the narrow lobe's reflectance, f0 w the wide one's.
SF_MODEL(Ggx2lobe)
SF_INFO("ggx-2lobe", "Lambert + two GGX lobes (narrow and wide) sharing F_Schlick(f0), weight w on the wide one")

#define GGX_2LOBE_PARAMS(X)                                                                        \
  X(Color, kd, 0.0, 1.0, 0.5, kDiffuseParam, "diffuse albedo (Lambert: f = kd / pi)")              \
  X(Color, f0, 0.0, 1.0, 0.04, kSpecularParam | kMultiplicative | kFresnelParam,                   \
    "Fresnel reflectance at normal incidence of both lobes together")                              \
  X(Real, roughness, 0.01, 1.0, 0.15, kWidthParam | kMultiplicative,                               \
    "perceptual roughness of the narrow lobe; alpha_1 = roughness^2")                                   \
  X(Real, spread, 0.0, 1.0, 0.6, kPlainParam,                                                      \
    "wide lobe: roughness_2 = roughness + (1 - roughness) spread")                                 \
  X(Real, w, 0.0, 1.0, 0.5, kPlainParam, "weight of the wide lobe (1 - w: the narrow one)")
SF_PARAMS(GGX_2LOBE_PARAMS)
#undef GGX_2LOBE_PARAMS

SF_FN Real GgxLobe(Real roughness, Dots d) {
  Real alpha = roughness * roughness;
  return D_GGX(d.NoH, d.one_minus_NoH2, alpha) * V_SmithGGXCorrelated(d.NoV, d.NoL, alpha) *
         Real(d.NoL);
}

SF_FN Color Diffuse(Params p, Dots d) { return p.kd * Real(kInvPi); }
SF_FN Real Lobe(Params p, Dots d) {
  Real wide = p.roughness + (Real(1) - p.roughness) * p.spread;
  return (Real(1) - p.w) * GgxLobe(p.roughness, d) + p.w * GgxLobe(wide, d);
}
SF_FN Color Fresnel(Params p, Dots d) {
  return F_SchlickColor(p.f0, d.LoH);
}
// The narrow lobe: it is the one an environment's importance sampling must resolve.
SF_FN Real LobeAlpha(Params p) { return p.roughness * p.roughness; }
SF_FN Color Ambient(Params p) { return Color(Real(0)); }

SF_END_MODEL
