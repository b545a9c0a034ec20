// Classic Phong: Phong 1975, "Illumination for Computer Generated Pictures", eq. 1 with the
// ambient term: ka amb + kd (n.l) + ks (r.v)^n, r the mirror direction of l. Unnormalised on
// purpose (no 1/pi, no (n+2)/(2 pi)): this is the model as printed, which the studies compare
// with the physically based ones (docs/models.md). The form does not bound its albedo: ks and n
// range freely, and the lobe's flux changes with n.
SF_MODEL(Phong)
SF_INFO("phong", "classic Phong 1975: ka amb + kd (n.l) + ks (r.v)^n")

#define PHONG_PARAMS(X)                                                                            \
  X(Color, ka, 0.0, 1.0, 0.0, kDiffuseParam, "ambient reflectance (times the ambient light)")      \
  X(Color, kd, 0.0, 1.0, 0.5, kDiffuseParam, "diffuse coefficient: kd (n.l) per unit light")       \
  X(Color, ks, 0.0, 100000.0, 0.5, kSpecularParam | kLogScale,                                     \
    "specular coefficient (unnormalised)")                                                         \
  X(Real, shininess, 1.0, 100000.0, 32.0, kWidthParam | kLogScale, "specular exponent n")
SF_PARAMS(PHONG_PARAMS)
#undef PHONG_PARAMS

SF_FN Color Diffuse(Params p, Dots d) { return p.kd; }
SF_FN Real Lobe(Params p, Dots d) { return PowCos(d.RoV, d.one_minus_RoV2, p.shininess); }
SF_FN Color Fresnel(Params p, Dots d) { return p.ks; }
// Walter et al. 2007, section 5.2: exponent n ~ 2 / alpha_b^2 - 2 (Beckmann width), close
// enough to a GGX alpha for a sampling proposal.
SF_FN Real LobeAlpha(Params p) { return sqrt(Real(2) / (p.shininess + Real(2))); }
SF_FN Color Ambient(Params p) { return p.ka; }

SF_END_MODEL
