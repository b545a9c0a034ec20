// Lambert 1760, "Photometria": the ideal diffuse reflector, f = kd / pi.
// Written in the model language of render/include/shadefit/render/model_dsl.h.
SF_MODEL(Lambert)
SF_INFO("lambert", "Lambert diffuse, f = kd / pi")

#define LAMBERT_PARAMS(X)                                                                          \
  X(Color, kd, 0.0, 1.0, 0.5, kDiffuseParam, "diffuse albedo (Lambert: f = kd / pi)")
SF_PARAMS(LAMBERT_PARAMS)
#undef LAMBERT_PARAMS

SF_FN Color Diffuse(Params p, Dots d) { return p.kd * Real(kInvPi); }
SF_FN Real Lobe(Params p, Dots d) { return Real(0); }
SF_FN Color Fresnel(Params p, Dots d) { return Color(Real(0)); }
SF_FN Real LobeAlpha(Params p) { return Real(0); }
SF_FN Color Ambient(Params p) { return Color(Real(0)); }

SF_END_MODEL
