// Reflect() of the one model compiled into this program (render/models/<name>.glsl, joined just
// before this file), composed from the model's terms exactly as the C++ twin composes them
// (ReflectTerm in render/include/shadefit/render/models.h). SHADEFIT_TERM (0 = the whole model)
// selects a single term, which the twin test compares term by term.

vec3 Reflect(vec3 n, vec3 l, vec3 v) {
  float NoL = dot(n, l);
  float NoV = dot(n, v);
  Params p = LoadParams();
  Dots d = ComputeShadingDots(n, l, v);
#if SHADEFIT_TERM == 1
  vec3 f = Diffuse(p, d) * d.NoL;
#elif SHADEFIT_TERM == 2
  vec3 f = vec3(Lobe(p, d));
#elif SHADEFIT_TERM == 3
  vec3 f = Fresnel(p, d);
#else
  vec3 f = Diffuse(p, d) * d.NoL + Fresnel(p, d) * Lobe(p, d);
#endif
  // A select, not an early return: llvmpipe computes both anyway (scene.glsl, IntersectObject).
  return NoL > 0.0 && NoV > 0.0 ? f : vec3(0.0);
}

vec3 AmbientReflectance() {
#if SHADEFIT_TERM == 0
  return Ambient(LoadParams());
#else
  return vec3(0.0);
#endif
}
