// Oren-Nayar diffuse: Oren and Nayar 1994, "Generalization of Lambert's Reflectance Model",
// eq. 30 (the qualitative model): f = kd / pi (A + B max(0, cos(phi_i - phi_r)) sin(a) tan(b)),
// A = 1 - 0.5 s^2 / (s^2 + 0.33), B = 0.45 s^2 / (s^2 + 0.09), a = max(theta_i, theta_r),
// b = min(theta_i, theta_r), s the facet slope deviation in radians. With a and b the two angles,
// sin(a) sin(b) = sin(theta_i) sin(theta_r) and cos(phi_i - phi_r) sin(theta_i) sin(theta_r) =
// l.v - (n.l)(n.v), so the last factor is max(0, l.v - (n.l)(n.v)) / max(n.l, n.v): dot
// products only. The diffuse option beside Lambert and Burley; s = 0 is Lambert. The
// qualitative model is not exactly energy conserving: with kd = 1 its directional albedo
// reaches 1.014 at grazing view (brdf_physics_test, Ngan2005/oren_nayar).
SF_MODEL(OrenNayar)
SF_INFO("oren-nayar", "Oren-Nayar 1994 rough diffuse (qualitative model), no specular lobe")

#define OREN_NAYAR_PARAMS(X)                                                                       \
  X(Color, kd, 0.0, 1.0, 0.5, kDiffuseParam, "diffuse albedo of the facets")                       \
  X(Real, sigma, 0.0, 1.5, 0.3, kPlainParam, "facet slope standard deviation (radians)")
SF_PARAMS(OREN_NAYAR_PARAMS)
#undef OREN_NAYAR_PARAMS

SF_FN Color Diffuse(Params p, Dots d) {
  Real s2 = p.sigma * p.sigma;
  Real a = Real(1) - Real(0.5) * s2 / (s2 + Real(0.33));
  Real b = Real(0.45) * s2 / (s2 + Real(0.09));
  Geo shape = max(Geo(0), d.LoV - d.NoL * d.NoV) / max(d.NoL, d.NoV);
  return p.kd * Real(kInvPi) * (a + b * Real(shape));
}
SF_FN Real Lobe(Params p, Dots d) { return Real(0); }
SF_FN Color Fresnel(Params p, Dots d) { return Color(Real(0)); }
SF_FN Real LobeAlpha(Params p) { return Real(0); }
SF_FN Color Ambient(Params p) { return Color(Real(0)); }

SF_END_MODEL
