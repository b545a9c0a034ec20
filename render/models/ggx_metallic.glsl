// ggx in the metallic-roughness parametrisation of the real-time engines (Karis 2013, "Real
// Shading in Unreal Engine 4"; Filament's BRDF): kd = base (1 - m), f0 = mix(f0_dielectric,
// base, m), then Lambert + D_GGX V_SmithGGXCorrelated F_Schlick(f0).
SF_MODEL(GgxMetallic)
SF_INFO("ggx-metallic",
        "ggx in metallic-roughness form: kd = base (1-m), f0 = mix(f0_dielectric, base, m)")

// base_color and metallic carry kSpecularParam: base 1 and metallic 1 give f0 = 1 and kd = 0.
#define GGX_METALLIC_PARAMS(X)                                                                     \
  X(Color, base_color, 0.0, 1.0, 0.8, kSpecularParam, "base colour")                               \
  X(Real, metallic, 0.0, 1.0, 0.0, kSpecularParam | kFresnelParam, "0 dielectric, 1 metal")        \
  X(Real, roughness, 0.01, 1.0, 0.5, kWidthParam | kMultiplicative,                                \
    "perceptual roughness; alpha = roughness^2")                                                   \
  X(Real, f0_dielectric, 0.0, 1.0, 0.04, kMultiplicative | kFresnelParam,                          \
    "F0 of the dielectric part")
SF_PARAMS(GGX_METALLIC_PARAMS)
#undef GGX_METALLIC_PARAMS

SF_FN Color Diffuse(Params p, Dots d) {
  return p.base_color * (Real(1) - p.metallic) * Real(kInvPi);
}
SF_FN Real Lobe(Params p, Dots d) {
  Real alpha = p.roughness * p.roughness;
  return D_GGX(d.NoH, d.one_minus_NoH2, alpha) * V_SmithGGXCorrelated(d.NoV, d.NoL, alpha) *
         Real(d.NoL);
}
SF_FN Color Fresnel(Params p, Dots d) {
  Color f0 = Color(p.f0_dielectric * (Real(1) - p.metallic)) + p.base_color * p.metallic;
  return F_SchlickColor(f0, d.LoH);
}
SF_FN Real LobeAlpha(Params p) { return p.roughness * p.roughness; }
SF_FN Color Ambient(Params p) { return Color(Real(0)); }

SF_END_MODEL
