// Camera rays and analytic ray casting: the GLSL twin of CameraRay() and Intersect() in
// render/src/scene.cpp (same conventions, docs/scenes.md).

uniform int u_cam_ortho;        // 0 perspective, 1 orthographic.
uniform vec3 u_cam_pos;
uniform vec3 u_cam_right;
uniform vec3 u_cam_up;
uniform vec3 u_cam_forward;
uniform float u_cam_scale;      // tan(fov_y / 2) or orthographic half height.
uniform vec2 u_resolution;      // width, height in pixels.

const int kMaxObjects = 8;
// Compile-time counts let llvmpipe unroll the loops (a 10x speed-up measured on 512^2 frames).
const int u_num_objects = SHADEFIT_NUM_OBJECTS;
uniform int u_obj_type[kMaxObjects];     // 0 sphere, 1 plane.
uniform vec4 u_obj_a[kMaxObjects];       // sphere: centre, radius; plane: point, unused.
uniform vec4 u_obj_b[kMaxObjects];       // plane: normal, half_u.
uniform vec4 u_obj_c[kMaxObjects];       // plane: tangent u, half_v.

void CameraRay(vec2 pixel, out vec3 origin, out vec3 dir) {
  float aspect = u_resolution.x / u_resolution.y;
  float nx = 2.0 * pixel.x / u_resolution.x - 1.0;
  float ny = 1.0 - 2.0 * pixel.y / u_resolution.y;
  if (u_cam_ortho == 0) {
    origin = u_cam_pos;
    dir = normalize(u_cam_forward + u_cam_right * (nx * u_cam_scale * aspect) +
                    u_cam_up * (ny * u_cam_scale));
  } else {
    origin = u_cam_pos + u_cam_right * (nx * u_cam_scale * aspect) + u_cam_up * (ny * u_cam_scale);
    dir = u_cam_forward;
  }
}

// Nearest hit in (t_min, t_max). Returns the object index or -1.
int Intersect(vec3 origin, vec3 dir, float t_min, float t_max, out float t_hit, out vec3 normal) {
  int hit = -1;
  t_hit = t_max;
  for (int i = 0; i < u_num_objects; ++i) {
    float t = -1.0;
    vec3 nrm;
    if (u_obj_type[i] == 0) {
      // Haines et al. 2019, "Precision Improvements for Ray/Sphere Intersection" (Ray Tracing
      // Gems, ch. 7): the discriminant from the closest-approach vector, and the two roots
      // without cancellation, so that float normals stay accurate up to the silhouette.
      float r = u_obj_a[i].w;
      vec3 oc = origin - u_obj_a[i].xyz;
      float b = dot(oc, dir);
      vec3 qc = oc - b * dir;
      float disc = r * r - dot(qc, qc);
      if (disc < 0.0) continue;
      float c = dot(oc, oc) - r * r;
      float q = b > 0.0 ? -b - sqrt(disc) : -b + sqrt(disc);
      float t0 = c / q, t1 = q;
      if (t0 > t1) { float tmp = t0; t0 = t1; t1 = tmp; }
      t = t0;
      if (t <= t_min) t = t1;
      nrm = (origin + dir * t - u_obj_a[i].xyz) / u_obj_a[i].w;
    } else {
      vec3 pn = u_obj_b[i].xyz;
      float denom = dot(pn, dir);
      if (abs(denom) < 1e-12) continue;
      t = dot(u_obj_a[i].xyz - origin, pn) / denom;
      if (u_obj_b[i].w > 0.0) {
        vec3 q = origin + dir * t - u_obj_a[i].xyz;
        vec3 tu = u_obj_c[i].xyz;
        vec3 tv = cross(pn, tu);
        if (abs(dot(q, tu)) > u_obj_b[i].w || abs(dot(q, tv)) > u_obj_c[i].w) continue;
      }
      nrm = denom < 0.0 ? pn : -pn;
    }
    if (t <= t_min || t >= t_hit) continue;
    t_hit = t;
    normal = nrm;
    hit = i;
  }
  return hit;
}

bool Occluded(vec3 origin, vec3 dir, float t_max) {
  float t;
  vec3 n;
  return Intersect(origin, dir, 1e-4, t_max, t, n) >= 0;
}
