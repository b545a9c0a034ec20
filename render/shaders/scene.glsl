// Camera rays and analytic ray casting: the GLSL twin of CameraRay() and Intersect() in
// render/src/scene.cpp (same conventions, docs/scenes.md).

const int u_cam_ortho = SHADEFIT_CAMERA_ORTHO;  // 0 perspective, 1 orthographic.
uniform vec3 u_cam_pos;
uniform vec3 u_cam_right;
uniform vec3 u_cam_up;
uniform vec3 u_cam_forward;
uniform float u_cam_scale;      // tan(fov_y / 2) or orthographic half height.
uniform vec2 u_resolution;      // width, height in pixels.

const int kMaxObjects = 8;
// Compile-time counts let llvmpipe unroll the loops (a 10x speed-up measured on 512^2 frames),
// and compile-time types let it drop the other type's code: llvmpipe runs both sides of every
// branch under a lane mask, so a uniform's branch costs both sides.
const int u_num_objects = SHADEFIT_NUM_OBJECTS;
const int u_obj_type[kMaxObjects] = int[kMaxObjects](SHADEFIT_OBJECT_TYPES);  // 0 sphere, 1 plane.
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

// Object i's hit in (t_min, t_hit), if any: then t_hit, normal and hit are updated. Every call
// passes a literal i, so the object's type and data are constants once inlined. Written with
// selects, not early returns: llvmpipe runs every branch under a lane mask, and the masks of
// the early-return form cost as much as the arithmetic (bench/render_bench, BENCHMARKS.md). The
// values are those of the branching form wherever it hits.
void IntersectObject(const int i, vec3 origin, vec3 dir, float t_min, inout float t_hit,
                     inout vec3 normal, inout int hit) {
  float t;
  vec3 nrm;
  bool found;
  if (u_obj_type[i] == 0) {
    // Haines et al. 2019, "Precision Improvements for Ray/Sphere Intersection" (Ray Tracing
    // Gems, ch. 7): the discriminant from the closest-approach vector, and the two roots
    // without cancellation, so that float normals stay accurate up to the silhouette.
    float r = u_obj_a[i].w;
    vec3 oc = origin - u_obj_a[i].xyz;
    float b = dot(oc, dir);
    vec3 qc = oc - b * dir;
    float disc = r * r - dot(qc, qc);
    found = !(disc < 0.0);
    float root = sqrt(max(disc, 0.0));
    float c = dot(oc, oc) - r * r;
    float q = b > 0.0 ? -b - root : -b + root;
    float t0 = c / q, t1 = q;
    float near = t0 > t1 ? t1 : t0, far = t0 > t1 ? t0 : t1;
    t = near <= t_min ? far : near;
    nrm = (origin + dir * t - u_obj_a[i].xyz) / u_obj_a[i].w;
  } else {
    vec3 pn = u_obj_b[i].xyz;
    float denom = dot(pn, dir);
    found = !(abs(denom) < 1e-12);
    t = dot(u_obj_a[i].xyz - origin, pn) / denom;
    vec3 q = origin + dir * t - u_obj_a[i].xyz;
    vec3 tu = u_obj_c[i].xyz;
    vec3 tv = cross(pn, tu);
    bool outside = abs(dot(q, tu)) > u_obj_b[i].w || abs(dot(q, tv)) > u_obj_c[i].w;
    found = found && !(u_obj_b[i].w > 0.0 && outside);  // half_u = 0: unbounded.
    nrm = denom < 0.0 ? pn : -pn;
  }
  found = found && !(t <= t_min || t >= t_hit);
  t_hit = found ? t : t_hit;
  normal = found ? nrm : normal;
  hit = found ? i : hit;
}

// SHADEFIT_UNROLL_8(F) is F(0) F(1) ... F(7): loops over objects and lights are unrolled by the
// preprocessor. Mesa's NIR leaves a loop with early exits rolled, and in a rolled loop llvmpipe
// reads every uniform array element as a per-lane gather: a 512^2 frame's ray cast took twice
// as long as the same code written out straight (bench/render_bench, BENCHMARKS.md).
#define SHADEFIT_UNROLL_8(F) F(0) F(1) F(2) F(3) F(4) F(5) F(6) F(7)

// Nearest hit in (t_min, t_max). Returns the object index or -1.
int Intersect(vec3 origin, vec3 dir, float t_min, float t_max, out float t_hit, out vec3 normal) {
  int hit = -1;
  t_hit = t_max;
#define SHADEFIT_OBJECT_(i) \
  if (i < u_num_objects) IntersectObject(i, origin, dir, t_min, t_hit, normal, hit);
  SHADEFIT_UNROLL_8(SHADEFIT_OBJECT_)
#undef SHADEFIT_OBJECT_
  return hit;
}

bool Occluded(vec3 origin, vec3 dir, float t_max) {
  float t;
  vec3 n;
  return Intersect(origin, dir, 1e-4, t_max, t, n) >= 0;
}
