// Two-lobe Cook-Torrance of Ngan, Durand and Matusik 2005, "Experimental Analysis of BRDF
// Models" (EGSR), sec. 5.3: the Cook-Torrance model (Cook and Torrance 1982; this repository's
// cook_torrance.glsl: Beckmann D normalised as in Walter et al. 2007, eq. 25, V-cavity G, the
// exact dielectric Fresnel of the index eta = (1 + sqrt(f0)) / (1 - sqrt(f0))) with a second
// specular lobe, which Ngan et al. found necessary for metals and metallic paints (a sharp peak
// on a broad haze). Ngan fitted each lobe its own specular coefficient and Fresnel; the model
// language has one Fresnel colour per model (Reflect = Diffuse NoL + Fresnel Lobe), so here the
// lobes share f0 and split its weight by w (f0 (1 - w) narrow, f0 w wide), with the wide slope
// m_2 = m + (1 - m) spread >= m: the lobes cannot swap, so the fit is identifiable.
SF_MODEL(CookTorrance2lobe)
SF_INFO("cook-torrance-2lobe", "Ngan 2005 two-lobe Cook-Torrance: Beckmann D, V-cavity G, dielectric Fresnel, narrow + wide lobe")

#define COOK_TORRANCE_2LOBE_PARAMS(X)                                                              \
  X(Color, kd, 0.0, 1.0, 0.5, kDiffuseParam, "diffuse albedo (Lambert: f = kd / pi)")              \
  X(Color, f0, 0.001, 0.99, 0.04, kSpecularParam | kMultiplicative | kFresnelParam,                \
    "Fresnel reflectance at normal incidence")                                                     \
  X(Real, m, 0.01, 1.0, 0.1, kWidthParam | kMultiplicative,                                        \
    "Beckmann rms slope of the narrow lobe")                                                            \
  X(Real, spread, 0.0, 1.0, 0.4, kPlainParam, "wide lobe: m_2 = m + (1 - m) spread")               \
  X(Real, w, 0.0, 1.0, 0.5, kPlainParam, "weight of the wide lobe (1 - w: the narrow one)")
SF_PARAMS(COOK_TORRANCE_2LOBE_PARAMS)
#undef COOK_TORRANCE_2LOBE_PARAMS

SF_FN Real FresnelOfF0(Real f0, Geo LoH) {
  Real s = sqrt(f0);
  return F_Dielectric(LoH, (Real(1) + s) / (Real(1) - s));
}

SF_FN Color Diffuse(Params p, Dots d) { return p.kd * Real(kInvPi); }
SF_FN Real Lobe(Params p, Dots d) {
  Geo g = min(Geo(1), Geo(2) * d.NoH * min(d.NoV, d.NoL) / d.LoH);
  Real wide = p.m + (Real(1) - p.m) * p.spread;
  Real distribution = (Real(1) - p.w) * D_Beckmann(d.NoH, d.one_minus_NoH2, p.m) +
                      p.w * D_Beckmann(d.NoH, d.one_minus_NoH2, wide);
  return distribution * Real(g / (Geo(4) * d.NoV));
}
SF_FN Color Fresnel(Params p, Dots d) {
  return Color(FresnelOfF0(p.f0.r, d.LoH), FresnelOfF0(p.f0.g, d.LoH), FresnelOfF0(p.f0.b, d.LoH));
}
// The narrow lobe's slope width; GGX's alpha matches it near the peak.
SF_FN Real LobeAlpha(Params p) { return p.m; }
SF_FN Color Ambient(Params p) { return Color(Real(0)); }

SF_END_MODEL
