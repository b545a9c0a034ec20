// Rasterises a mesh object's world-space triangles for the surface path's G-buffer
// (renderer.cpp, "surface objects"). The projection is CameraRay's (scene.glsl) inverted, so a
// pixel centre's fragment lies on the camera ray through it; the image is drawn upside down like
// fullscreen.vert's, so framebuffer row k is image row k.
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec2 a_uv;
layout(location = 3) in vec4 a_tangent;
uniform vec3 u_cam_pos;
uniform vec3 u_cam_right;
uniform vec3 u_cam_up;
uniform vec3 u_cam_forward;
uniform float u_cam_scale;   // tan(fov_y / 2) or orthographic half height.
uniform vec2 u_resolution;   // width, height of the image in pixels (not of the raster).
uniform int u_cam_ortho;
uniform vec2 u_depth_range;  // Nearest and farthest distance along the view axis.
out vec3 v_position;
out vec3 v_normal;
out vec2 v_uv;
out vec4 v_tangent;

void main() {
  vec3 d = a_position - u_cam_pos;
  float x = dot(d, u_cam_right), y = dot(d, u_cam_up), z = dot(d, u_cam_forward);
  float aspect = u_resolution.x / u_resolution.y;
  float n = u_depth_range.x, f = u_depth_range.y;
  if (u_cam_ortho == 0) {
    gl_Position = vec4(x / (u_cam_scale * aspect), -y / u_cam_scale,
                       (z * (f + n) - 2.0 * f * n) / (f - n), z);
  } else {
    gl_Position = vec4(x / (u_cam_scale * aspect), -y / u_cam_scale,
                       2.0 * (z - n) / (f - n) - 1.0, 1.0);
  }
  v_position = a_position;
  v_normal = a_normal;
  v_uv = a_uv;
  v_tangent = a_tangent;
}
