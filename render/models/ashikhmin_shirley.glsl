// Isotropic Ashikhmin-Shirley: Ashikhmin and Shirley 2000, "An Anisotropic Phong BRDF Model",
// eqs. 4 and 5 with n_u = n_v = n:
//   f_s = (n + 1) / (8 pi) (n.h)^n / ((h.l) max(n.l, n.v)) F_Schlick(rs, h.l),
//   f_d = 28 rd / (23 pi) (1 - rs) (1 - (1 - n.l / 2)^5) (1 - (1 - n.v / 2)^5).
// The (1 - rs) factor trades diffuse for specular energy; the form does not bound the albedo
// exactly: the lobe at rs = 1 measures at most 0.995 (brdf_physics_test, Ngan2005/...).
SF_MODEL(AshikhminShirley)
SF_INFO("ashikhmin-shirley", "isotropic Ashikhmin-Shirley 2000: Phong lobe with Schlick Fresnel")

#define ASHIKHMIN_SHIRLEY_PARAMS(X)                                                                \
  X(Color, rd, 0.0, 1.0, 0.5, kDiffuseParam, "diffuse reflectance")                                \
  X(Color, rs, 0.0, 1.0, 0.04, kSpecularParam | kMultiplicative | kFresnelParam,                   \
    "specular reflectance at normal incidence")                                                    \
  X(Real, n, 1.0, 100000.0, 32.0, kWidthParam | kLogScale, "Phong exponent of the lobe")
SF_PARAMS(ASHIKHMIN_SHIRLEY_PARAMS)
#undef ASHIKHMIN_SHIRLEY_PARAMS

SF_FN Color Diffuse(Params p, Dots d) {
  Geo l5 = Pow5(Geo(1) - Geo(0.5) * d.NoL);
  Geo v5 = Pow5(Geo(1) - Geo(0.5) * d.NoV);
  return p.rd * (Color(Real(1)) - p.rs) * Real(28.0 / (23.0 * kPi) * (1.0 - l5) * (1.0 - v5));
}
SF_FN Real Lobe(Params p, Dots d) {
  return (p.n + Real(1)) / Real(8.0 * kPi) * PowCos(d.NoH, d.one_minus_NoH2, p.n) *
         Real(d.NoL / (d.LoH * max(d.NoL, d.NoV)));
}
SF_FN Color Fresnel(Params p, Dots d) {
  return F_SchlickColor(p.rs, d.LoH);
}
// Walter et al. 2007, section 5.2 (see phong.glsl).
SF_FN Real LobeAlpha(Params p) { return sqrt(Real(2) / (p.n + Real(2))); }
SF_FN Color Ambient(Params p) { return Color(Real(0)); }

SF_END_MODEL
