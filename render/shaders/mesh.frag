// A mesh's fragment in the surface path's G-buffer: world position and object, and the shading
// normal (interpolated, normal-mapped, turned toward the eye on a back face). The C++ twin is
// MeshSurfaceFrame (render/src/scene.cpp): the same frame and the same normal-map sampling.
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
uniform int u_object;
uniform int u_has_normal_map;
uniform int u_flip_green;
uniform sampler2D u_normal_map;  // Rows uploaded top first: t = 0 is the image's top row.
layout(location = 0) out vec4 out_position;  // xyz world position, w = object + 1
layout(location = 1) out vec4 out_normal;    // xyz unit shading normal, w = 1

void main() {
  vec3 n = normalize(v_normal);
  if (u_has_normal_map != 0) {
    vec3 t = v_tangent.xyz - n * dot(n, v_tangent.xyz);
    if (length(t) > 1e-12) {
      t = normalize(t);
      vec3 b = cross(n, t) * (v_tangent.w < 0.0 ? -1.0 : 1.0);
      // Texture v = 0 is the image's bottom row (OpenGL, Blender): t = 1 - v here.
      vec3 ts = texture(u_normal_map, vec2(v_uv.x, 1.0 - v_uv.y)).rgb * 2.0 - 1.0;
      if (u_flip_green != 0) ts.y = -ts.y;
      ts = length(ts) > 1e-12 ? normalize(ts) : vec3(0.0, 0.0, 1.0);
      n = normalize(t * ts.x + b * ts.y + n * ts.z);
    }
  }
  // Two-sided, as planes are: a back face shows its other side.
  if (!gl_FrontFacing) n = -n;
  out_position = vec4(v_position, float(u_object + 1));
  out_normal = vec4(n, 1.0);
}
