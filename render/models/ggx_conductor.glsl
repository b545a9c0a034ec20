// GGX with the exact Fresnel reflectance of a conductor, complex index eta + i k per channel
// (Born and Wolf, "Principles of Optics", section 14.2; F_Conductor in brdf.h). Metals have no
// diffuse term.
SF_MODEL(GgxConductor)
SF_INFO("ggx-conductor",
        "GGX with conductor Fresnel from a complex IOR (n, k) per channel, no diffuse")

#define GGX_CONDUCTOR_PARAMS(X)                                                                    \
  X(Color, eta, 0.01, 10.0, 0.2, kPlainParam, "real part of the IOR")                              \
  X(Color, k, 0.0, 10.0, 3.0, kPlainParam, "extinction coefficient")                               \
  X(Real, roughness, 0.01, 1.0, 0.5, kWidthParam | kMultiplicative,                                \
    "perceptual roughness; alpha = roughness^2")
SF_PARAMS(GGX_CONDUCTOR_PARAMS)
#undef GGX_CONDUCTOR_PARAMS

SF_FN Color Diffuse(Params p, Dots d) { return Color(Real(0)); }
SF_FN Real Lobe(Params p, Dots d) {
  Real alpha = p.roughness * p.roughness;
  return D_GGX(d.NoH, d.one_minus_NoH2, alpha) * V_SmithGGXCorrelated(d.NoV, d.NoL, alpha) *
         Real(d.NoL);
}
SF_FN Color Fresnel(Params p, Dots d) {
  return Color(F_Conductor(d.LoH, p.eta.r, p.k.r), F_Conductor(d.LoH, p.eta.g, p.k.g),
               F_Conductor(d.LoH, p.eta.b, p.k.b));
}
SF_FN Real LobeAlpha(Params p) { return p.roughness * p.roughness; }
SF_FN Color Ambient(Params p) { return Color(Real(0)); }

SF_END_MODEL
