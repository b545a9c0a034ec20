// Radiance (and G-buffer) pass. Preamble added by the renderer: #version, SHADEFIT_TERM,
// SHADEFIT_GBUFFER, SHADEFIT_NUM_OBJECTS, SHADEFIT_NUM_LIGHTS, SHADEFIT_SUPERSAMPLE,
// SHADEFIT_ENV_MODE, SHADEFIT_SURFACE, SHADEFIT_OBJECT_TYPES, SHADEFIT_LIGHT_TYPES (kMaxObjects / kMaxLights
// comma-separated codes), SHADEFIT_CAMERA_ORTHO, SHADEFIT_TRANSPARENT, then brdf.glsl, model_dsl.glsl, the model's models/<name>.glsl,
// models.glsl, scene.glsl, environment.glsl.

const int kMaxLights = 8;
const int u_num_lights = SHADEFIT_NUM_LIGHTS;  // Point and directional lights.
const int u_light_type[kMaxLights] = int[kMaxLights](SHADEFIT_LIGHT_TYPES);  // 0 point, 1 directional.
uniform vec3 u_light_pos[kMaxLights];   // point: position; directional: direction to the light.
uniform vec3 u_light_value[kMaxLights]; // point: intensity W/sr; directional: irradiance.
uniform vec3 u_ambient;                 // ambient radiance (classic ka term)
const int u_supersample = SHADEFIT_SUPERSAMPLE;
const int u_transparent = SHADEFIT_TRANSPARENT;
uniform vec3 u_background;

#if SHADEFIT_GBUFFER
layout(location = 0) out vec4 out_position;  // xyz world position, w = object id + 1 (0 miss)
layout(location = 1) out vec4 out_normal;    // xyz unit normal, w = coverage
layout(location = 2) out vec4 out_view;      // xyz unit direction to the eye
#else
layout(location = 0) out vec4 out_color;     // premultiplied radiance, alpha = coverage
#endif

// Offset added along the normal to shadow-ray origins, in world units (scenes are metre-sized).
const float kRayEpsilon = 1e-4;

#if SHADEFIT_SURFACE
// Surface objects (meshes, normal maps): the renderer's per-sample G-buffer at SHADEFIT_SUPERSAMPLE
// times the image's resolution, and each sample's light visibility (bit i: light i reaches it),
// ray cast on the CPU once per geometry and lights (renderer.cpp).
uniform sampler2D u_surf_position;   // xyz world position, w = object + 1 (0 = nothing)
uniform sampler2D u_surf_normal;     // xyz unit shading normal facing the eye
uniform usampler2D u_surf_visibility;
#endif

// Light i's reflected radiance at p (a literal i, as IntersectObject's in scene.glsl). `visible`:
// the surface path's visibility bits; the analytic path casts its shadow rays here.
vec3 ShadeLight(const int i, vec3 p, vec3 n, vec3 v, uint visible) {
  vec3 l;
  vec3 e;
  float dist;
  if (u_light_type[i] == 0) {
    vec3 d = u_light_pos[i] - p;
    float d2 = dot(d, d);
    dist = sqrt(d2);
    l = d / dist;
    e = u_light_value[i] / d2;  // Inverse-square law: E = I / d^2 at normal incidence.
  } else {
    l = u_light_pos[i];
    e = u_light_value[i];
    dist = 1e30;
  }
  // Selects rather than early returns (IntersectObject in scene.glsl says why).
#if SHADEFIT_SURFACE
  bool lit = !(dot(n, l) <= 0.0) && ((visible >> uint(i)) & 1u) != 0u;
#else
  bool lit = !(dot(n, l) <= 0.0) && !(u_num_objects > 1 && Occluded(p + n * kRayEpsilon, l, dist));
#endif
  return lit ? Reflect(n, l, v) * e : vec3(0.0);
}

vec3 ShadeDirect(vec3 p, vec3 n, vec3 v, uint visible) {
  vec3 radiance = AmbientReflectance() * u_ambient;
#define SHADEFIT_LIGHT_(i) if (i < u_num_lights) radiance += ShadeLight(i, p, n, v, visible);
  SHADEFIT_UNROLL_8(SHADEFIT_LIGHT_)
#undef SHADEFIT_LIGHT_
  radiance += ShadeEnvironment(p, n, v);
  return radiance;
}

// Adds the radiance along the camera ray through `pixel` to sum (a hit, counted in hits) or to
// background_sum (a miss, on an opaque background).
void ShadeSample(vec2 pixel, inout vec3 sum, inout vec3 background_sum, inout int hits) {
  vec3 origin, dir;
  CameraRay(pixel, origin, dir);
#if SHADEFIT_SURFACE
  // The sample's texel of the per-sample G-buffer: pixel is corner + (s + 0.5) / ss.
  ivec2 texel = ivec2(floor(pixel * float(max(u_supersample, 1))));
  vec4 surface = texelFetch(u_surf_position, texel, 0);
  if (surface.w > 0.5) {
    g_surf_texel = texel;
    vec3 p = surface.xyz;
    vec3 v = u_cam_ortho != 0 ? -u_cam_forward : normalize(u_cam_pos - p);
    sum += ShadeDirect(p, texelFetch(u_surf_normal, texel, 0).xyz, v,
                       texelFetch(u_surf_visibility, texel, 0).r);
    ++hits;
  } else if (u_transparent == 0) {
    background_sum += BackgroundRadiance(dir, u_background);
  }
  return;
#endif
  float t;
  vec3 n;
  bool hit = Intersect(origin, dir, 0.0, 1e30, t, n) >= 0;
  // A select on a transparent background without environment light, where a miss adds nothing
  // (IntersectObject in scene.glsl says why); with environment light, shading is a loop over
  // hundreds of samples that a group of missing pixels should skip.
  if (u_transparent != 0 && u_env_mode == 0) {
    vec3 radiance = ShadeDirect(origin + dir * t, n, -dir, 0u);
    sum += hit ? radiance : vec3(0.0);
    hits += hit ? 1 : 0;
  } else if (hit) {
    sum += ShadeDirect(origin + dir * t, n, -dir, 0u);
    ++hits;
  } else if (u_transparent == 0) {
    background_sum += BackgroundRadiance(dir, u_background);
  }
}

void main() {
  // fullscreen.vert draws upside down: framebuffer row k is image row k, counted from the top.
  vec2 pixel_corner = floor(gl_FragCoord.xy);
#if SHADEFIT_GBUFFER
  vec3 origin, dir;
  CameraRay(pixel_corner + 0.5, origin, dir);
  float t;
  vec3 n;
  int obj = Intersect(origin, dir, 0.0, 1e30, t, n);
  // Coverage from the supersampling grid so that silhouettes can be masked out of fits. With one
  // sample per pixel that sample is the ray above.
  int ss = max(u_supersample, 1);
#if SHADEFIT_SUPERSAMPLE <= 1
  int hits = obj >= 0 ? 1 : 0;
#else
  int hits = 0;
  for (int sy = 0; sy < ss; ++sy) {
    for (int sx = 0; sx < ss; ++sx) {
      vec3 o2, d2;
      CameraRay(pixel_corner + (vec2(sx, sy) + 0.5) / float(ss), o2, d2);
      float t2;
      vec3 n2;
      if (Intersect(o2, d2, 0.0, 1e30, t2, n2) >= 0) ++hits;
    }
  }
#endif
  float coverage = float(hits) / float(ss * ss);
  if (obj < 0) {
    out_position = vec4(0.0);
    out_normal = vec4(0.0, 0.0, 0.0, coverage);
    out_view = vec4(-dir, 0.0);
  } else {
    out_position = vec4(origin + dir * t, float(obj + 1));
    out_normal = vec4(n, coverage);
    out_view = vec4(-dir, 0.0);
  }
#else
  int ss = max(u_supersample, 1);
  vec3 sum = vec3(0.0);
  vec3 background_sum = vec3(0.0);
  int hits = 0;
#if SHADEFIT_SUPERSAMPLE <= 1
  ShadeSample(pixel_corner + 0.5, sum, background_sum, hits);  // (0 + 0.5) / 1: the same ray.
#else
  for (int sy = 0; sy < ss; ++sy) {
    for (int sx = 0; sx < ss; ++sx) {
      ShadeSample(pixel_corner + (vec2(sx, sy) + 0.5) / float(ss), sum, background_sum, hits);
    }
  }
#endif
  float inv = 1.0 / float(ss * ss);
  float coverage = float(hits) * inv;
  out_color = vec4((sum + background_sum) * inv, coverage);
#endif
}
