// The GLSL side of the model language (render/include/shadefit/render/model_dsl.h explains it):
// after this file a model file of render/models/ is plain GLSL for one model. The renderer
// joins brdf.glsl, this file, the model's file and models.glsl.

#define Real float
#define Geo float
#define Color vec3
#define SF_MODEL(Name)
#define SF_END_MODEL
#define SF_FN
#define SF_INFO(name, description)

uniform float u_params[16];

void LoadParam(inout int i, out float x) { x = u_params[i]; i += 1; }
void LoadParam(inout int i, out vec3 x) {
  x = vec3(u_params[i], u_params[i + 1], u_params[i + 2]);
  i += 3;
}

#define SF_PARAM_FIELD_(type, name, lo, hi, def, roles, desc) type name;
#define SF_PARAM_LOAD_(type, name, lo, hi, def, roles, desc) LoadParam(i, p.name);
#define SF_PARAMS(LIST)                                                                     \
  struct Params {                                                                           \
    LIST(SF_PARAM_FIELD_)                                                                   \
  };                                                                                        \
  Params LoadParams() {                                                                     \
    Params p;                                                                               \
    int i = 0;                                                                              \
    LIST(SF_PARAM_LOAD_)                                                                    \
    return p;                                                                               \
  }

struct Dots {
  float NoL, NoV, NoH, LoH, LoV;
  float one_minus_NoH2;
  float RoV;
  float one_minus_RoV2;
};

Dots ComputeShadingDots(vec3 n, vec3 l, vec3 v) {
  Dots d;
  d.NoL = dot(n, l);
  d.NoV = dot(n, v);
  vec3 h = normalize(l + v);
  d.NoH = dot(n, h);
  d.LoH = dot(l, h);
  d.LoV = dot(l, v);
  vec3 nxh = cross(n, h);
  d.one_minus_NoH2 = dot(nxh, nxh);
  vec3 r = n * (2.0 * d.NoL) - l;
  d.RoV = dot(r, v);
  vec3 rxv = cross(r, v);
  d.one_minus_RoV2 = dot(rxv, rxv);
  return d;
}

// F_Schlick (brdf.glsl) per channel of a colour f0.
vec3 F_SchlickColor(vec3 f0, float LoH) {
  return vec3(F_Schlick(f0.r, LoH), F_Schlick(f0.g, LoH), F_Schlick(f0.b, LoH));
}

// cos^n of an angle given its cosine and squared sine; 0 for cos <= 0. In float, pow(cos, n)
// loses about n ulps of cos near the peak (1e-3 relative at n = 10^4); there the squared sine
// from a cross product keeps full relative precision: cos^n = exp(n/2 ln(1 - sin2)), ln(1 - s)
// by its series. Far from the peak (sin2 >= 0.5) the cosine itself is the precise input.
float PowCos(float cos_x, float sin2, float n) {
  if (!(cos_x > 0.0)) return 0.0;
  if (sin2 >= 0.5) return pow(cos_x, n);
  float s = max(sin2, 0.0);
  float log_cos2 = s < 0.01 ? -s * (1.0 + s * (0.5 + s * (1.0 / 3.0 + s * 0.25))) : log(1.0 - s);
  return exp(0.5 * n * log_cos2);
}
