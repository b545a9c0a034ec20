// Normalised Blinn-Phong: f = kd / pi + ks (n + 8) / (8 pi) (n.h)^n. (n + 8) / (8 pi) is the
// approximate normalisation of the lobe with the cosine factor (Akenine-Moller, Haines, Hoffman,
// "Real-Time Rendering" 3rd ed., eq. 7.49; exact for n -> infinity, see docs/models.md). Its
// specular albedo at normal view has a closed form (tests/render/brdf_physics_test.cpp) that
// exceeds 1 slightly at small n: the form bounds it only approximately.
SF_MODEL(BlinnPhongNormalized)
SF_INFO("blinn-phong-normalized", "f = kd/pi + ks (n+8)/(8 pi) (n.h)^n")

#define BLINN_PHONG_NORMALIZED_PARAMS(X)                                                           \
  X(Color, kd, 0.0, 1.0, 0.5, kDiffuseParam, "diffuse albedo (Lambert: f = kd / pi)")              \
  X(Color, ks, 0.0, 1.0, 0.04, kSpecularParam | kMultiplicative,                                   \
    "specular reflectance (normalised lobe)")                                                      \
  X(Real, shininess, 1.0, 100000.0, 32.0, kWidthParam | kLogScale, "specular exponent n")
SF_PARAMS(BLINN_PHONG_NORMALIZED_PARAMS)
#undef BLINN_PHONG_NORMALIZED_PARAMS

SF_FN Color Diffuse(Params p, Dots d) { return p.kd * Real(kInvPi); }
SF_FN Real Lobe(Params p, Dots d) {
  return (p.shininess + Real(8)) / Real(8.0 * kPi) *
         PowCos(d.NoH, d.one_minus_NoH2, p.shininess) * Real(d.NoL);
}
SF_FN Color Fresnel(Params p, Dots d) { return p.ks; }
// Walter et al. 2007, section 5.2 (see phong.glsl).
SF_FN Real LobeAlpha(Params p) { return sqrt(Real(2) / (p.shininess + Real(2))); }
SF_FN Color Ambient(Params p) { return Color(Real(0)); }

SF_END_MODEL
