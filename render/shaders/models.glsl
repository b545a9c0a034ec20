// GLSL twin of Reflect() in render/include/shadefit/render/models_inl.h. SHADEFIT_MODEL is
// defined by the renderer when it compiles a program (render/src/renderer.cpp), so the switch
// folds to one model. Parameters arrive flattened in the order of the model's table.

#define MODEL_LAMBERT 0
#define MODEL_PHONG 1
#define MODEL_BLINN_PHONG 2
#define MODEL_BLINN_PHONG_NORMALIZED 3
#define MODEL_GGX 4
#define MODEL_GGX_METALLIC 5
#define MODEL_GGX_SEPARABLE 6
#define MODEL_GGX_DIELECTRIC 7
#define MODEL_GGX_CONDUCTOR 8
#define MODEL_GGX_BURLEY 9
#define MODEL_BECKMANN 10
#define MODEL_CYCLES_PRINCIPLED 11

uniform float u_params[16];

float P(int i) { return u_params[i]; }
vec3 P3(int i) { return vec3(u_params[i], u_params[i + 1], u_params[i + 2]); }

// cos^n of an angle given its cosine and squared sine. In float, pow(cos, n) loses about n ulps
// of cos near the peak (1e-3 relative at n = 10^4); there the squared sine from a cross product
// keeps full relative precision: cos^n = exp(n/2 ln(1 - sin2)), ln(1 - s) by its series. Far
// from the peak (sin2 >= 0.5) the cosine itself is the precise input.
float PowCos(float cos_x, float sin2, float n) {
  if (sin2 >= 0.5) return pow(cos_x, n);
  float s = max(sin2, 0.0);
  float log_cos2 = s < 0.01 ? -s * (1.0 + s * (0.5 + s * (1.0 / 3.0 + s * 0.25))) : log(1.0 - s);
  return exp(0.5 * n * log_cos2);
}

vec3 Reflect(vec3 n, vec3 l, vec3 v) {
  float NoL = dot(n, l);
  float NoV = dot(n, v);
  if (!(NoL > 0.0) || !(NoV > 0.0)) return vec3(0.0);
  vec3 h = normalize(l + v);
  float NoH = dot(n, h);
  float LoH = dot(l, h);
  vec3 nxh = cross(n, h);
  float omNoH2 = dot(nxh, nxh);

#if SHADEFIT_MODEL == MODEL_LAMBERT
  return P3(0) * kInvPi * NoL;
#elif SHADEFIT_MODEL == MODEL_PHONG || SHADEFIT_MODEL == MODEL_BLINN_PHONG
#if SHADEFIT_MODEL == MODEL_PHONG
  vec3 r = n * (2.0 * NoL) - l;
  float cos_lobe = dot(r, v);
  vec3 rxv = cross(r, v);
  float sin2_lobe = dot(rxv, rxv);
#else
  float cos_lobe = NoH;
  float sin2_lobe = omNoH2;
#endif
  float spec = cos_lobe > 0.0 ? PowCos(cos_lobe, sin2_lobe, P(9)) : 0.0;
  return P3(3) * NoL + P3(6) * spec;
#elif SHADEFIT_MODEL == MODEL_BLINN_PHONG_NORMALIZED
  float spec = NoH > 0.0 ? PowCos(NoH, omNoH2, P(6)) : 0.0;
  float norm = (P(6) + 8.0) / (8.0 * kPi);
  return (P3(0) * kInvPi + P3(3) * norm * spec) * NoL;
#elif SHADEFIT_MODEL == MODEL_GGX || SHADEFIT_MODEL == MODEL_GGX_SEPARABLE || \
      SHADEFIT_MODEL == MODEL_GGX_BURLEY || SHADEFIT_MODEL == MODEL_BECKMANN
  float roughness = P(6);
  float alpha = roughness * roughness;
#if SHADEFIT_MODEL == MODEL_BECKMANN
  float dv = D_Beckmann(NoH, omNoH2, alpha) * V_SmithBeckmannSeparable(NoV, NoL, alpha);
#elif SHADEFIT_MODEL == MODEL_GGX_SEPARABLE
  float dv = D_GGX(NoH, omNoH2, alpha) * V_SmithGGXSeparable(NoV, NoL, alpha);
#else
  float dv = D_GGX(NoH, omNoH2, alpha) * V_SmithGGXCorrelated(NoV, NoL, alpha);
#endif
#if SHADEFIT_MODEL == MODEL_GGX_BURLEY
  float fd = Fd_Burley(NoV, NoL, LoH, roughness);
#else
  float fd = Fd_Lambert();
#endif
  vec3 f0 = P3(3);
  vec3 F = vec3(F_Schlick(f0.r, LoH), F_Schlick(f0.g, LoH), F_Schlick(f0.b, LoH));
  return (P3(0) * fd + F * dv) * NoL;
#elif SHADEFIT_MODEL == MODEL_GGX_METALLIC
  vec3 base = P3(0);
  float metallic = P(3);
  float alpha = P(4) * P(4);
  float dv = D_GGX(NoH, omNoH2, alpha) * V_SmithGGXCorrelated(NoV, NoL, alpha);
  vec3 kd = base * (1.0 - metallic);
  vec3 f0 = P(5) * (1.0 - metallic) + base * metallic;
  vec3 F = vec3(F_Schlick(f0.r, LoH), F_Schlick(f0.g, LoH), F_Schlick(f0.b, LoH));
  return (kd * kInvPi + F * dv) * NoL;
#elif SHADEFIT_MODEL == MODEL_GGX_DIELECTRIC
  float alpha = P(4) * P(4);
  float spec = F_Dielectric(LoH, P(3)) * D_GGX(NoH, omNoH2, alpha) *
               V_SmithGGXCorrelated(NoV, NoL, alpha);
  return (P3(0) * kInvPi + vec3(spec)) * NoL;
#elif SHADEFIT_MODEL == MODEL_GGX_CONDUCTOR
  float alpha = P(6) * P(6);
  float dv = D_GGX(NoH, omNoH2, alpha) * V_SmithGGXCorrelated(NoV, NoL, alpha);
  vec3 F = vec3(F_Conductor(LoH, P(0), P(3)), F_Conductor(LoH, P(1), P(4)),
                F_Conductor(LoH, P(2), P(5)));
  return F * dv * NoL;
#elif SHADEFIT_MODEL == MODEL_CYCLES_PRINCIPLED
  vec3 base = P3(0);
  float metallic = P(3);
  float specular = P(4);
  float roughness = P(5);
  float alpha = roughness * roughness;
  float ior = 2.0 / (1.0 - sqrt(0.08 * specular + 1e-6)) - 1.0;
  float dv = D_GGX(NoH, omNoH2, alpha) * V_SmithGGXSeparable(NoV, NoL, alpha);
  float fd = Fd_Burley(NoV, NoL, LoH, roughness);
  vec3 cspec0 = 0.08 * specular * (1.0 - metallic) + base * metallic;
  vec3 F = vec3(F_CyclesPrincipled(cspec0.r, ior, LoH), F_CyclesPrincipled(cspec0.g, ior, LoH),
                F_CyclesPrincipled(cspec0.b, ior, LoH));
  return (base * (1.0 - metallic) * fd + F * dv) * NoL;
#else
#error "unknown SHADEFIT_MODEL"
#endif
}

vec3 AmbientReflectance() {
#if SHADEFIT_MODEL == MODEL_PHONG || SHADEFIT_MODEL == MODEL_BLINN_PHONG
  return P3(0);
#else
  return vec3(0.0);
#endif
}
