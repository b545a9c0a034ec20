// One-lobe isotropic Lafortune: Lafortune et al. 1997, "Non-Linear Approximation of Reflectance
// Functions", eq. 3 in the local frame with C_x = C_y:
//   f = kd / pi + ks (n + 2) / (2 pi) [C_xy (l_x v_x + l_y v_y) + C_z l_z v_z]^n,
// l_x v_x + l_y v_y = l.v - (n.l)(n.v), l_z v_z = (n.l)(n.v). C_xy = -1, C_z = 1 is Phong's
// mirror lobe, where (n + 2) / (2 pi) normalises it; C_xy > -C_z leans it towards retro- or
// off-specular reflection. Ngan et al. 2005 fitted this form to MERL. A common scale of C is the
// same as a factor on ks (s^n), so C is bounded to |C_xy| <= 1, 0 <= C_z <= 1: then the bracket
// is at most cos(theta_i - theta_o) <= 1 and (.)^n cannot overflow at n = 10^5 (C up to 2 did:
// inf pixels on 4 of 20 measured materials). Within these bounds the form still does not bound
// the albedo (ks is free); at C = (-1, 1), ks = 1 it measures at most 1.0001 (brdf_physics_test).
SF_MODEL(Lafortune)
SF_INFO("lafortune", "one-lobe isotropic Lafortune 1997: kd/pi + ks (n+2)/(2 pi) (C . (l, v))^n")

#define LAFORTUNE_PARAMS(X)                                                                        \
  X(Color, kd, 0.0, 1.0, 0.5, kDiffuseParam, "diffuse albedo (Lambert: f = kd / pi)")              \
  X(Color, ks, 0.0, 1000.0, 0.04, kSpecularParam | kLogScale, "specular coefficient")              \
  X(Real, cxy, -1.0, 1.0, -1.0, kPlainParam, "C_x = C_y: tangential weight (-1 = mirror)")         \
  X(Real, cz, 0.0, 1.0, 1.0, kPlainParam, "C_z: normal weight")                                    \
  X(Real, n, 1.0, 100000.0, 32.0, kWidthParam | kLogScale, "lobe exponent")
SF_PARAMS(LAFORTUNE_PARAMS)
#undef LAFORTUNE_PARAMS

SF_FN Color Diffuse(Params p, Dots d) { return p.kd * Real(kInvPi); }
SF_FN Real Lobe(Params p, Dots d) {
  Real base = p.cxy * Real(d.LoV - d.NoL * d.NoV) + p.cz * Real(d.NoL * d.NoV);
  // pow's derivative in n is base^n log(base): keep base away from 0, where the lobe is 0.
  return base > Real(1e-12)
             ? (p.n + Real(2)) / Real(2.0 * kPi) * pow(base, p.n) * Real(d.NoL)
             : Real(0);
}
SF_FN Color Fresnel(Params p, Dots d) { return p.ks; }
// Walter et al. 2007, section 5.2 (see phong.glsl), for the mirror lobe C = (-1, 1).
SF_FN Real LobeAlpha(Params p) { return sqrt(Real(2) / (p.n + Real(2))); }
SF_FN Color Ambient(Params p) { return Color(Real(0)); }

SF_END_MODEL
