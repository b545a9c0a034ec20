// Environment lighting, integrated deterministically per pixel: the same fixed low-discrepancy
// sample set for every frame, three sampling techniques combined with the balance heuristic
// (Veach and Guibas 1995, "Optimally Combining Sampling Techniques for Monte Carlo Rendering"):
//   1. the environment's own luminance distribution (tabulated on the CPU, render/src/environment.cpp),
//   2. cosine-weighted hemisphere samples (covers every direction a diffuse term needs),
//   3. GGX normal-distribution samples with the model's specular lobe width
//      (Walter et al. 2007, eqs. 35-36), which keep sharp highlights converged.
// docs/environment.md states the error against a brute-force reference; a test holds it.

// SHADEFIT_ENV_MODE (compile-time): 0 none, 1 uniform radiance, 2 equirectangular map.
const int u_env_mode = SHADEFIT_ENV_MODE;
uniform vec3 u_env_radiance;       // uniform mode
uniform sampler2D u_env_map;       // linear RGB, row 0 = top of the map (v = 1)
uniform sampler2D u_env_pdf;       // R: density over the unit (u, v) square, same layout
uniform sampler2D u_env_samples;   // N x 1 texels: xyz direction in map space, w unused
uniform mat3 u_env_world_to_map;   // rotation about +Z (Cycles Mapping node)
uniform float u_env_strength;
uniform int u_env_count;           // N samples per technique
uniform float u_lobe_alpha;        // GGX width of the specular proposal; 0 = no specular lobe

float RadicalInverse(uint bits) {
  bits = (bits << 16u) | (bits >> 16u);
  bits = ((bits & 0x55555555u) << 1u) | ((bits & 0xAAAAAAAAu) >> 1u);
  bits = ((bits & 0x33333333u) << 2u) | ((bits & 0xCCCCCCCCu) >> 2u);
  bits = ((bits & 0x0F0F0F0Fu) << 4u) | ((bits & 0xF0F0F0F0u) >> 4u);
  bits = ((bits & 0x00FF00FFu) << 8u) | ((bits & 0xFF00FF00u) >> 8u);
  return float(bits) * 2.3283064365386963e-10;
}

// Per-pixel Cranley-Patterson offset: decorrelates the fixed point set between pixels while
// staying deterministic (a function of the pixel only). Note that technique 3 below follows the
// model's lobe width, so the sample directions do move with roughness (docs/environment.md).
vec2 PixelOffset() {
  // Pixel (x, y) counted from the bottom row, as before frames were drawn upside down
  // (fullscreen.vert), so that every pixel keeps its offset.
  uvec2 p = uvec2(gl_FragCoord.x, u_resolution.y - 1.0 - floor(gl_FragCoord.y));
  uint h = p.x * 1973u + p.y * 9277u + 26699u;
  h = (h ^ (h >> 16u)) * 0x45d9f3bu;
  h = (h ^ (h >> 16u)) * 0x45d9f3bu;
  h ^= h >> 16u;
  return vec2(float(h & 0xFFFFu), float(h >> 16u)) / 65536.0;
}

vec2 EquirectUv(vec3 d_map) {
  // Cycles direction_to_equirectangular; v = 0 at the bottom of the map.
  float u = -atan(d_map.y, d_map.x) / (2.0 * kPi) + 0.5;
  float v = atan(d_map.z, length(d_map.xy)) / kPi + 0.5;
  return vec2(u, v);
}

vec3 EnvRadiance(vec3 dir) {
  if (u_env_mode == 1) return u_env_radiance;
  vec2 uv = EquirectUv(u_env_world_to_map * dir);
  return texture(u_env_map, vec2(uv.x, 1.0 - uv.y)).rgb * u_env_strength;
}

float EnvPdf(vec3 dir) {
  if (u_env_mode == 1) return 1.0 / (4.0 * kPi);
  vec3 d = u_env_world_to_map * dir;
  float cos_elev = length(d.xy);
  if (cos_elev < 1e-6) return 0.0;
  vec2 uv = EquirectUv(d);
  // Density over (u, v) -> solid angle: d omega = 2 pi^2 cos(elevation) du dv.
  return texture(u_env_pdf, vec2(uv.x, 1.0 - uv.y)).r / (2.0 * kPi * kPi * cos_elev);
}

mat3 FrameAround(vec3 n) {
  vec3 t = abs(n.z) < 0.999 ? normalize(cross(vec3(0.0, 0.0, 1.0), n))
                            : normalize(cross(vec3(1.0, 0.0, 0.0), n));
  return mat3(t, cross(n, t), n);
}

float GgxLightPdf(vec3 n, vec3 v, vec3 l) {
  if (u_lobe_alpha <= 0.0 || dot(n, l) <= 0.0) return 0.0;
  vec3 h = normalize(l + v);
  float NoH = dot(n, h);
  float VoH = dot(v, h);
  if (NoH <= 0.0 || VoH <= 0.0) return 0.0;
  vec3 nxh = cross(n, h);
  // Half-vector density D(h) (n.h), mapped to l by the reflection Jacobian 1 / (4 v.h).
  return D_GGX(NoH, dot(nxh, nxh), u_lobe_alpha) * NoH / (4.0 * VoH);
}

float CosinePdf(vec3 n, vec3 l) { return max(dot(n, l), 0.0) * kInvPi; }

#if SHADEFIT_SURFACE
// Surface objects: whether quadrature direction i of technique t (0 the light's, 1 cosine, 2
// GGX) of this sample reaches the sky, ray cast on the CPU for these very directions
// (render/src/surface_samples.h, EnvironmentVisibility): bit i % 32 of layer t * words + i / 32.
uniform usampler2DArray u_surf_env_visibility;   // techniques 0 and 1
uniform usampler2DArray u_surf_lobe_visibility;  // technique 2, at u_lobe_alpha
uniform int u_surf_env_words;
ivec2 g_surf_texel;  // The sample's texel, set by ShadeSample (render.frag).

bool EnvVisible(int technique, int i) {
  uint word = technique < 2
      ? texelFetch(u_surf_env_visibility, ivec3(g_surf_texel, technique * u_surf_env_words + (i >> 5)), 0).r
      : texelFetch(u_surf_lobe_visibility, ivec3(g_surf_texel, i >> 5), 0).r;
  return ((word >> uint(i & 31)) & 1u) != 0u;
}
#else
bool EnvVisible(int technique, int i) { return true; }
#endif

// `visible`: the surface path's ray-cast bit (true on analytic objects, which cast their own).
vec3 EnvContribution(vec3 p, vec3 n, vec3 v, vec3 l, bool visible) {
  if (dot(n, l) <= 0.0 || !visible) return vec3(0.0);
  vec3 f = Reflect(n, l, v);
  if (f == vec3(0.0)) return vec3(0.0);
  if (u_num_objects > 1 && Occluded(p + n * 1e-4, l, 1e30)) return vec3(0.0);
  float pdf_sum = EnvPdf(l) + CosinePdf(n, l) + GgxLightPdf(n, v, l);
  return pdf_sum > 0.0 ? f * EnvRadiance(l) / pdf_sum : vec3(0.0);
}

vec3 ShadeEnvironment(vec3 p, vec3 n, vec3 v) {
  if (u_env_mode == 0) return vec3(0.0);
  mat3 frame = FrameAround(n);
  mat3 map_to_world = transpose(u_env_world_to_map);
  vec2 offset = PixelOffset();
  vec3 sum = vec3(0.0);
  int count = u_env_count;
  for (int i = 0; i < count; ++i) {
    vec2 xi = fract(vec2((float(i) + 0.5) / float(count), RadicalInverse(uint(i))) + offset);
    // 1. Environment: tabulated directions (uniform sphere for the uniform environment).
    vec3 l_env;
    if (u_env_mode == 2) {
      l_env = map_to_world * texelFetch(u_env_samples, ivec2(i, 0), 0).xyz;
    } else {
      float z = 1.0 - 2.0 * xi.x;
      float r = sqrt(max(1.0 - z * z, 0.0));
      float phi = 2.0 * kPi * xi.y;
      l_env = vec3(r * cos(phi), r * sin(phi), z);
    }
    sum += EnvContribution(p, n, v, l_env, EnvVisible(0, i));
    // 2. Cosine-weighted hemisphere (Malley's method).
    float r = sqrt(xi.x);
    float phi = 2.0 * kPi * xi.y;
    vec3 l_cos = frame * vec3(r * cos(phi), r * sin(phi), sqrt(max(1.0 - xi.x, 0.0)));
    sum += EnvContribution(p, n, v, l_cos, EnvVisible(1, i));
    // 3. GGX half vectors with the model's lobe width, reflected about v.
    if (u_lobe_alpha > 0.0) {
      float a2 = u_lobe_alpha * u_lobe_alpha;
      float cos2 = (1.0 - xi.x) / (1.0 + (a2 - 1.0) * xi.x);
      float sin_t = sqrt(max(1.0 - cos2, 0.0));
      vec3 h = frame * vec3(sin_t * cos(phi), sin_t * sin(phi), sqrt(cos2));
      vec3 l_ggx = 2.0 * dot(v, h) * h - v;
      sum += EnvContribution(p, n, v, l_ggx, EnvVisible(2, i));
    }
  }
  return sum / float(count);
}

vec3 BackgroundRadiance(vec3 dir, vec3 color) {
  return u_env_mode == 0 ? color : EnvRadiance(dir);
}
