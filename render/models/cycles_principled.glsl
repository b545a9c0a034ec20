// Cycles 3.4's Principled BSDF, single scattering (kernel/closure/bsdf_principled_diffuse.h,
// bsdf_microfacet.h, svm_closure.h): alpha = roughness^2, separable Smith G, Burley diffuse
// weighted by base (1 - metallic) and simply added, Fresnel interpolated from cspec0 to 1 along
// the dielectric curve of ior = 2 / (1 - sqrt(0.08 specular)) - 1 (specular tint 0).
SF_MODEL(CyclesPrincipled)
SF_INFO("cycles-principled",
        "Cycles 3.4 Principled BSDF, single scattering (separable Smith, Burley, Cycles Fresnel)")

// base_color and metallic carry kSpecularParam: base 1 and metallic 1 give cspec0 = 1, no diffuse.
#define CYCLES_PRINCIPLED_PARAMS(X)                                                                \
  X(Color, base_color, 0.0, 1.0, 0.8, kSpecularParam, "base colour")                               \
  X(Real, metallic, 0.0, 1.0, 0.0, kSpecularParam | kFresnelParam, "0 dielectric, 1 metal")        \
  X(Real, specular, 0.0, 1.0, 0.5, kFresnelParam, "Cycles specular; F0 = 0.08 specular")           \
  X(Real, roughness, 0.01, 1.0, 0.5, kWidthParam | kMultiplicative,                                \
    "perceptual roughness; alpha = roughness^2")
SF_PARAMS(CYCLES_PRINCIPLED_PARAMS)
#undef CYCLES_PRINCIPLED_PARAMS

SF_FN Color Diffuse(Params p, Dots d) {
  return p.base_color * (Real(1) - p.metallic) * Fd_Burley(d.NoV, d.NoL, d.LoH, p.roughness);
}
SF_FN Real Lobe(Params p, Dots d) {
  Real alpha = p.roughness * p.roughness;
  return D_GGX(d.NoH, d.one_minus_NoH2, alpha) * V_SmithGGXSeparable(d.NoV, d.NoL, alpha) *
         Real(d.NoL);
}
SF_FN Color Fresnel(Params p, Dots d) {
  // The sqrt argument is bounded away from 0: specular = 0 would mean ior 1 and F0 = 0, where
  // the remap divides by (1 - F0) anyway; 1e-6 keeps the Jet derivative finite.
  Real ior = Real(2) / (Real(1) - sqrt(Real(0.08) * p.specular + Real(1e-6))) - Real(1);
  Color cspec0 =
      Color(Real(0.08) * p.specular * (Real(1) - p.metallic)) + p.base_color * p.metallic;
  return Color(F_CyclesPrincipled(cspec0.r, ior, d.LoH), F_CyclesPrincipled(cspec0.g, ior, d.LoH),
               F_CyclesPrincipled(cspec0.b, ior, d.LoH));
}
SF_FN Real LobeAlpha(Params p) { return p.roughness * p.roughness; }
SF_FN Color Ambient(Params p) { return Color(Real(0)); }

SF_END_MODEL
