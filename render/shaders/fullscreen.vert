// One triangle that covers the viewport; the fragment shader does all the work. Upside down:
// framebuffer row k holds image row k (row 0 on top), so a readback is in our row order already
// and a pixel rectangle needs no flip (renderer.cpp).
void main() {
  vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
  gl_Position = vec4(p.x * 2.0 - 1.0, 1.0 - p.y * 2.0, 0.0, 1.0);
}
