// Classic Blinn-Phong: Blinn 1977, "Models of Light Reflection for Computer Synthesized
// Pictures": Phong's model with (n.h)^n, h the half vector: ka amb + kd (n.l) + ks (n.h)^n.
// Unnormalised on purpose, as printed (docs/models.md); its albedo is not bounded by 1 and
// changes by orders of magnitude with n (the energy probe's sweep measures it).
SF_MODEL(BlinnPhong)
SF_INFO("blinn-phong", "classic Blinn-Phong: ka amb + kd (n.l) + ks (n.h)^n, unnormalised")

#define BLINN_PHONG_PARAMS(X)                                                                      \
  X(Color, ka, 0.0, 1.0, 0.0, kDiffuseParam, "ambient reflectance (times the ambient light)")      \
  X(Color, kd, 0.0, 1.0, 0.5, kDiffuseParam, "diffuse coefficient: kd (n.l) per unit light")       \
  X(Color, ks, 0.0, 100000.0, 0.5, kSpecularParam | kLogScale,                                     \
    "specular coefficient (unnormalised)")                                                         \
  X(Real, shininess, 1.0, 100000.0, 32.0, kWidthParam | kLogScale, "specular exponent n")
SF_PARAMS(BLINN_PHONG_PARAMS)
#undef BLINN_PHONG_PARAMS

SF_FN Color Diffuse(Params p, Dots d) { return p.kd; }
SF_FN Real Lobe(Params p, Dots d) { return PowCos(d.NoH, d.one_minus_NoH2, p.shininess); }
SF_FN Color Fresnel(Params p, Dots d) { return p.ks; }
// Walter et al. 2007, section 5.2 (see phong.glsl).
SF_FN Real LobeAlpha(Params p) { return sqrt(Real(2) / (p.shininess + Real(2))); }
SF_FN Color Ambient(Params p) { return p.ka; }

SF_END_MODEL
