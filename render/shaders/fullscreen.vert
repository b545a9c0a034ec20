// One triangle that covers the viewport, or (u_proxy = 1) the triangles of the objects' pixel
// polygons (ObjectPixelPolygons in scene.h), given in pixels; the fragment shader does all the
// work. Framebuffer row k holds image row k (row 0 on top), so a readback is in our row order
// already and a pixel rectangle needs no flip (renderer.cpp).
layout(location = 0) in vec2 a_pixel;  // u_proxy = 1: continuous pixel coordinates, y down.
uniform int u_proxy;
uniform vec2 u_resolution;             // width, height in pixels (scene.glsl).

void main() {
  if (u_proxy != 0) {
    gl_Position = vec4(2.0 * a_pixel / u_resolution - 1.0, 0.0, 1.0);
    return;
  }
  vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
  gl_Position = vec4(p.x * 2.0 - 1.0, 1.0 - p.y * 2.0, 0.0, 1.0);
}
