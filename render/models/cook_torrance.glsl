// Cook-Torrance as published: Cook and Torrance 1982, "A Reflectance Model for Computer
// Graphics", with the Beckmann distribution (normalised as in Walter et al. 2007, eq. 25), the
// V-cavity geometric attenuation G = min(1, 2 (n.h)(n.v) / (v.h), 2 (n.h)(n.l) / (v.h)) and the
// exact dielectric Fresnel of the index implied by the normal-incidence reflectance per channel,
// eta = (1 + sqrt(f0)) / (1 - sqrt(f0)) (the paper's own recipe): f = kd / pi + D G F / (4 (n.l)
// (n.v)). The model Ngan et al. 2005 call Cook-Torrance. Single scattering with the V-cavity G
// loses energy: with f0 at its maximum the lobe measures at most 0.990 (brdf_physics_test).
SF_MODEL(CookTorrance)
SF_INFO("cook-torrance", "Cook-Torrance 1982: Beckmann D, V-cavity G, dielectric Fresnel from f0")

#define COOK_TORRANCE_PARAMS(X)                                                                    \
  X(Color, kd, 0.0, 1.0, 0.5, kDiffuseParam, "diffuse albedo (Lambert: f = kd / pi)")              \
  X(Color, f0, 0.001, 0.99, 0.04, kSpecularParam | kMultiplicative | kFresnelParam,                \
    "Fresnel reflectance at normal incidence")                                                     \
  X(Real, m, 0.01, 1.0, 0.25, kWidthParam | kMultiplicative,                                       \
    "Beckmann rms slope of the microfacets")
SF_PARAMS(COOK_TORRANCE_PARAMS)
#undef COOK_TORRANCE_PARAMS

SF_FN Real FresnelOfF0(Real f0, Geo LoH) {
  Real s = sqrt(f0);
  return F_Dielectric(LoH, (Real(1) + s) / (Real(1) - s));
}

SF_FN Color Diffuse(Params p, Dots d) { return p.kd * Real(kInvPi); }
SF_FN Real Lobe(Params p, Dots d) {
  Geo g = min(Geo(1), Geo(2) * d.NoH * min(d.NoV, d.NoL) / d.LoH);
  return D_Beckmann(d.NoH, d.one_minus_NoH2, p.m) * Real(g / (Geo(4) * d.NoV));
}
SF_FN Color Fresnel(Params p, Dots d) {
  return Color(FresnelOfF0(p.f0.r, d.LoH), FresnelOfF0(p.f0.g, d.LoH), FresnelOfF0(p.f0.b, d.LoH));
}
// The Beckmann slope width; GGX's alpha matches it near the peak.
SF_FN Real LobeAlpha(Params p) { return p.m; }
SF_FN Color Ambient(Params p) { return Color(Real(0)); }

SF_END_MODEL
