// A toy model for tests/render/model_registry_test.cpp, outside render/models/ on purpose: it
// shows that a model is one file plus one line in a model list (docs/adding-a-model.md).
// Minnaert 1941, "The reciprocity principle in lunar photometry": f = kd/pi (n.l n.v)^(k-1);
// k = 1 is Lambert.
SF_MODEL(Minnaert)
SF_INFO("minnaert", "Minnaert limb darkening, f = kd/pi (n.l n.v)^(k-1) (test-only toy)")

#define MINNAERT_PARAMS(X)                                                                         \
  X(Color, kd, 0.0, 1.0, 0.5, kDiffuseParam, "diffuse albedo")                                     \
  X(Real, k, 0.5, 2.0, 1.0, kPlainParam, "darkening exponent (1 = Lambert)")
SF_PARAMS(MINNAERT_PARAMS)
#undef MINNAERT_PARAMS

SF_FN Color Diffuse(Params p, Dots d) {
  return p.kd * Real(kInvPi) * pow(Real(d.NoL * d.NoV), p.k - Real(1));
}
SF_FN Real Lobe(Params p, Dots d) { return Real(0); }
SF_FN Color Fresnel(Params p, Dots d) { return Color(Real(0)); }
SF_FN Real LobeAlpha(Params p) { return Real(0); }
SF_FN Color Ambient(Params p) { return Color(Real(0)); }

SF_END_MODEL
