// Isotropic Ward: Ward 1992, "Measuring and Modeling Anisotropic Reflection", eq. 5 with
// alpha_x = alpha_y: f = kd / pi + ks exp(-tan^2(theta_h) / alpha^2) / (4 pi alpha^2
// sqrt(cos theta_i cos theta_o)). No Fresnel (ks is a constant colour), one of the models Ngan
// et al. 2005 fitted to MERL. The form does not bound the albedo (its normalisation is exact
// only for small alpha; ward_duer.glsl is the bounded variant); over this table's widths the
// lobe at ks = 1 measures at most 0.992 (tests/render/brdf_physics_test.cpp, Ngan2005/ward).
SF_MODEL(Ward)
SF_INFO("ward",
        "isotropic Ward 1992: kd/pi + ks exp(-tan^2 h / a^2) / (4 pi a^2 sqrt(cos i cos o))")

#define WARD_PARAMS(X)                                                                             \
  X(Color, kd, 0.0, 1.0, 0.5, kDiffuseParam, "diffuse albedo (Lambert: f = kd / pi)")              \
  X(Color, ks, 0.0, 1.0, 0.04, kSpecularParam | kMultiplicative,                                   \
    "specular reflectance of the lobe")                                                            \
  X(Real, alpha, 0.01, 1.0, 0.25, kWidthParam | kMultiplicative,                                   \
    "rms slope of the surface (lobe width)")
SF_PARAMS(WARD_PARAMS)
#undef WARD_PARAMS

SF_FN Color Diffuse(Params p, Dots d) { return p.kd * Real(kInvPi); }
SF_FN Real Lobe(Params p, Dots d) {
  Real a2 = max(p.alpha, Real(kMinAlpha)) * max(p.alpha, Real(kMinAlpha));
  Real tan2 = Real(d.one_minus_NoH2 / (d.NoH * d.NoH));
  return exp(-tan2 / a2) / (Real(4.0 * kPi) * a2) * Real(d.NoL / sqrt(d.NoL * d.NoV));
}
SF_FN Color Fresnel(Params p, Dots d) { return p.ks; }
// Ward's alpha is a Beckmann-like slope width, which GGX's alpha matches near the peak.
SF_FN Real LobeAlpha(Params p) { return p.alpha; }
SF_FN Color Ambient(Params p) { return Color(Real(0)); }

SF_END_MODEL
