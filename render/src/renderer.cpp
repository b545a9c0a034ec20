#include "shadefit/render/renderer.h"

#include <epoxy/gl.h>
#include <fmt/format.h>

#include <cmath>
#include <deque>
#include <map>
#include <regex>
#include <string>

#include "shadefit/base/error.h"
#include "shadefit/render/environment.h"
#include "shadefit/render/mesh.h"
#include "surface_samples.h"

namespace shadefit {
namespace internal {
const std::map<std::string, std::string>& ShaderSources();
}

namespace {

// Files of the fragment program in the order they are joined (render.frag documents it); the
// model's own file (models/<name>.glsl) goes after the model language.
std::vector<std::string> FragmentFiles(ModelId model) {
  return {"brdf.glsl", "model_dsl.glsl", ModelGlslFile(model), "models.glsl",
          "scene.glsl", "environment.glsl", "render.frag"};
}

// Each file starts at line k * kLineBase + 1, so an error's line number alone says which file
// it is in, whatever a driver does with #line's source-string number (Mesa prints 0).
constexpr int kLineBase = 100000;

std::string JoinSources(const std::string& preamble, const std::vector<std::string>& files) {
  std::string out = preamble;
  for (std::size_t k = 0; k < files.size(); ++k) {
    out += fmt::format("#line {}\n", (k + 1) * kLineBase + 1);
    out += internal::ShaderSources().at(files[k]);
    out += "\n";
  }
  return out;
}

// Rewrites "<n>:<line>(<col>)" (Mesa) and "<n>(<line>)" (NVIDIA) locations as "<file>:<line>".
std::string NameSources(const std::string& log, const std::vector<std::string>& files) {
  static const std::regex kLocation(R"((\d+)[:(](\d+)\)?(\(\d+\))?)");
  std::string out;
  auto begin = std::sregex_iterator(log.begin(), log.end(), kLocation);
  std::size_t last = 0;
  for (auto it = begin; it != std::sregex_iterator(); ++it) {
    const long line = std::stol((*it)[2].str());
    const std::size_t k = static_cast<std::size_t>(line / kLineBase);
    if (k < 1 || k > files.size()) continue;
    out += log.substr(last, it->position() - last);
    out += fmt::format("{}:{}", files[k - 1], line % kLineBase);
    last = it->position() + it->length();
  }
  return out + log.substr(last);
}

GLuint CompileShader(GLenum type, const std::string& source,
                     const std::vector<std::string>& files) {
  GLuint shader = glCreateShader(type);
  const char* src = source.c_str();
  glShaderSource(shader, 1, &src, nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    GLint len = 0;
    glGetShaderiv(shader, GL_INFO_LOG_LENGTH, &len);
    std::string log(static_cast<std::size_t>(len > 0 ? len : 1), '\0');
    glGetShaderInfoLog(shader, len, nullptr, log.data());
    glDeleteShader(shader);
    std::string first_line = NameSources(log, files);
    first_line = first_line.substr(0, first_line.find('\n'));
    throw Error("GLSL", "compile", first_line);
  }
  return shader;
}

constexpr int kMaxParams = 16;  // u_params[16] in model_dsl.glsl.
constexpr int kMaxObjects = 8;  // kMaxObjects in scene.glsl.
constexpr int kMaxLights = 8;   // kMaxLights in render.frag.
// Texture unit used only to create textures, so that doing so never disturbs the units 0-2 the
// environment samplers are bound to.
constexpr int kScratchTextureUnit = 15;

// The GGX proposal's width on surface objects: the model's lobe on a grid of 5% steps, so that
// the proposal's visibility (ray cast per width) is made once per step, not once per render; the
// estimator stays unbiased with any proposal width (docs/environment.md), and a proposal 2.5% off
// the lobe is nearly as good.
double SurfaceLobeAlpha(double alpha) {
  if (!(alpha > 0)) return 0.0;
  const double step = std::log(1.05);
  return std::exp(std::round(std::log(alpha) / step) * step);
}

// The camera's uniforms, shared by scene.glsl's CameraRay and mesh.vert's projection.
void BindCamera(GLuint program, const Camera& cam) {
  Vec3d right, up, forward;
  cam.Basis(&right, &up, &forward);
  auto set3 = [&](const char* n, const Vec3d& v) {
    glUniform3f(glGetUniformLocation(program, n), static_cast<float>(v.x),
                static_cast<float>(v.y), static_cast<float>(v.z));
  };
  set3("u_cam_pos", cam.position);
  set3("u_cam_right", right);
  set3("u_cam_up", up);
  set3("u_cam_forward", forward);
  const double scale = cam.type == Camera::Type::kPerspective
                           ? std::tan(0.5 * cam.fov_y_deg * kPi / 180.0)
                           : 0.5 * cam.height;
  glUniform1f(glGetUniformLocation(program, "u_cam_scale"), static_cast<float>(scale));
  glUniform2f(glGetUniformLocation(program, "u_resolution"), static_cast<float>(cam.width),
              static_cast<float>(cam.height_px));
}

}  // namespace

struct Renderer::Impl {
  GlContext& context;
  RendererOptions options;
  GLuint vao = 0;
  GLuint proxy_vbo = 0;  // Triangles of ObjectPixelPolygons, in pixels (fullscreen.vert).
  // The last polygon draw's triangles and rectangle while attachment 0 holds 0 everywhere in
  // the rectangle outside them (no other draw since): the same draw again needs no clear, which
  // costs about a tenth of a 512^2 frame on llvmpipe.
  std::vector<float> clean_vertices;
  PixelRect clean_rect;
  bool clean = false;
  GLuint fbo = 0;
  int fbo_width = 0, fbo_height = 0;
  GLuint color_tex[3] = {0, 0, 0};
  // Programs are specialised on the model and on the scene's shape (counts of objects and
  // lights, supersampling, environment kind), which the shader takes as compile-time constants.
  std::map<std::string, GLuint> programs;
  // Environment textures, rebuilt when the light changes.
  std::shared_ptr<const EnvironmentMap> env;
  int env_samples = 0;
  GLuint env_tex = 0, env_pdf_tex = 0, env_samples_tex = 0;

  // Surface objects (meshes, a normal map): the per-sample G-buffer of the last geometry drawn,
  // its textures and the image's G-buffer, and the light visibility of recent light sets (a fit
  // renders its lightings in turn over one geometry), at most kVisibilityCache of them.
  static constexpr std::size_t kVisibilityCache = 16;
  struct MeshBuffers {
    std::shared_ptr<const TriangleMesh> mesh;  // Keeps the key's address alive.
    GLuint vao = 0, vbo[4] = {0, 0, 0, 0}, ebo = 0;
  };
  std::map<const TriangleMesh*, MeshBuffers> mesh_buffers;
  std::map<const NormalMap*, std::pair<std::shared_ptr<const NormalMap>, GLuint>> normal_maps;
  GLuint mesh_program = 0;
  GLuint mesh_fbo = 0, mesh_depth = 0, mesh_color[2] = {0, 0};
  int mesh_width = 0, mesh_height = 0;
  std::string surface_key;
  internal::SurfaceSamples surface_samples;
  GBuffer surface_gbuffer;
  PixelRect surface_rect;  // The pixels any sample of which hits.
  GLuint surface_tex[2] = {0, 0};
  std::map<std::string, GLuint> visibility_tex;
  std::deque<std::string> visibility_order;

  Impl(GlContext& c, const RendererOptions& o) : context(c), options(o) {
    glGenVertexArrays(1, &vao);
    glGenBuffers(1, &proxy_vbo);
    glBindVertexArray(vao);
    glBindBuffer(GL_ARRAY_BUFFER, proxy_vbo);
    glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 0, nullptr);  // Enabled by DrawPolygons.
    glGenFramebuffers(1, &fbo);
  }

  ~Impl() {
    for (auto& [key, program] : programs) glDeleteProgram(program);
    if (mesh_program) glDeleteProgram(mesh_program);
    for (auto& [key, b] : mesh_buffers) {
      glDeleteVertexArrays(1, &b.vao);
      glDeleteBuffers(4, b.vbo);
      glDeleteBuffers(1, &b.ebo);
    }
    for (auto& [key, m] : normal_maps) glDeleteTextures(1, &m.second);
    glDeleteTextures(2, mesh_color);
    glDeleteRenderbuffers(1, &mesh_depth);
    glDeleteFramebuffers(1, &mesh_fbo);
    glDeleteTextures(2, surface_tex);
    for (auto& [key, tex] : visibility_tex) glDeleteTextures(1, &tex);
    glDeleteTextures(3, color_tex);
    GLuint env_textures[3] = {env_tex, env_pdf_tex, env_samples_tex};
    glDeleteTextures(3, env_textures);
    glDeleteFramebuffers(1, &fbo);
    glDeleteBuffers(1, &proxy_vbo);
    glDeleteVertexArrays(1, &vao);
  }

  GLuint Program(ModelId model, ModelTerm term, bool gbuffer, const Scene& scene) {
    int num_lights = 0;
    for (const Light& light : scene.lights) {
      num_lights += light.type == Light::Type::kPoint || light.type == Light::Type::kDirectional;
    }
    const int env = scene.EnvironmentLight();
    const int env_mode =
        env < 0 ? 0 : (scene.lights[env].type == Light::Type::kUniform ? 1 : 2);
    // Object and light types as compile-time codes (scene.glsl, render.frag), padded to the
    // arrays' fixed sizes.
    std::string object_types, light_types;
    // Surface objects are read from the per-sample G-buffer: no analytic object is ray cast.
    const bool surface = scene.HasSurfaceObjects();
    const int num_objects = surface ? 0 : static_cast<int>(scene.objects.size());
    for (int i = 0; i < kMaxObjects; ++i) {
      const bool plane = i < num_objects && scene.objects[i].type != SceneObject::Type::kSphere;
      object_types += fmt::format("{}{}", i ? "," : "", plane ? 1 : 0);
    }
    int n = 0;
    for (const Light& light : scene.lights) {
      if (light.type == Light::Type::kPoint || light.type == Light::Type::kDirectional) {
        light_types +=
            fmt::format("{}{}", n++ ? "," : "", light.type == Light::Type::kPoint ? 0 : 1);
      }
    }
    for (; n < kMaxLights; ++n) light_types += fmt::format("{}0", n ? "," : "");
    const std::string preamble = fmt::format(
        "#version 430 core\n// model {}\n#define SHADEFIT_TERM {}\n#define SHADEFIT_GBUFFER {}\n"
        "#define SHADEFIT_NUM_OBJECTS {}\n#define SHADEFIT_NUM_LIGHTS {}\n"
        "#define SHADEFIT_SUPERSAMPLE {}\n#define SHADEFIT_ENV_MODE {}\n"
        "#define SHADEFIT_OBJECT_TYPES {}\n#define SHADEFIT_LIGHT_TYPES {}\n"
        "#define SHADEFIT_CAMERA_ORTHO {}\n#define SHADEFIT_TRANSPARENT {}\n"
        "#define SHADEFIT_SURFACE {}\n{}",
        ModelGlslFile(model), static_cast<int>(term), gbuffer ? 1 : 0, num_objects,
        num_lights, scene.camera.supersample, gbuffer ? 0 : env_mode, object_types, light_types,
        scene.camera.type == Camera::Type::kOrthographic ? 1 : 0,
        scene.background.transparent ? 1 : 0, surface ? 1 : 0,
        *ModelGlslVariant(model) ? fmt::format("#define {}\n", ModelGlslVariant(model)) : "");
    auto it = programs.find(preamble);
    if (it != programs.end()) return it->second;
    const std::vector<std::string> vfiles = {"fullscreen.vert"};
    const std::vector<std::string> ffiles = FragmentFiles(model);
    GLuint vs = CompileShader(GL_VERTEX_SHADER, JoinSources("#version 430 core\n", vfiles), vfiles);
    GLuint fs = CompileShader(GL_FRAGMENT_SHADER, JoinSources(preamble, ffiles), ffiles);
    GLuint program = glCreateProgram();
    glAttachShader(program, vs);
    glAttachShader(program, fs);
    glLinkProgram(program);
    glDeleteShader(vs);
    glDeleteShader(fs);
    GLint ok = 0;
    glGetProgramiv(program, GL_LINK_STATUS, &ok);
    if (!ok) {
      char log[1024] = {0};
      glGetProgramInfoLog(program, sizeof(log), nullptr, log);
      glDeleteProgram(program);
      std::string line(log);
      throw Error("GLSL", "link", line.substr(0, line.find('\n')));
    }
    programs[preamble] = program;
    return program;
  }

  void EnsureTargets(int w, int h) {
    if (w == fbo_width && h == fbo_height) return;
    clean = false;
    glDeleteTextures(3, color_tex);
    glGenTextures(3, color_tex);
    glActiveTexture(GL_TEXTURE0 + kScratchTextureUnit);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    for (int i = 0; i < 3; ++i) {
      glBindTexture(GL_TEXTURE_2D, color_tex[i]);
      glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA32F, w, h);
      glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0 + i, GL_TEXTURE_2D,
                             color_tex[i], 0);
    }
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
      throw Error("OpenGL", "framebuffer", "RGBA32F render target is not supported");
    }
    fbo_width = w;
    fbo_height = h;
  }

  static GLuint MakeFloatTexture(GLenum internal, GLenum format, int w, int h, const float* data,
                                 GLenum filter, GLenum wrap_s) {
    GLuint tex = 0;
    glGenTextures(1, &tex);
    glActiveTexture(GL_TEXTURE0 + kScratchTextureUnit);
    glBindTexture(GL_TEXTURE_2D, tex);
    glTexStorage2D(GL_TEXTURE_2D, 1, internal, w, h);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, w, h, format, GL_FLOAT, data);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, filter);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, filter);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, wrap_s);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    return tex;
  }

  // Returns the GGX proposal's width the shader uses: the model's lobe, or on surface objects
  // that lobe on a grid of 2% steps (SurfaceLobeAlpha), whose visibility is ray cast once per step.
  float BindEnvironment(GLuint program, const Scene& scene, ModelId model,
                        const std::vector<double>& params) {
    auto loc = [&](const char* n) { return glGetUniformLocation(program, n); };
    const int index = scene.EnvironmentLight();
    if (index < 0) return 0.0f;
    const Light& light = scene.lights[index];
    glUniform1i(loc("u_env_count"), light.samples);
    const double model_alpha = SpecularLobeAlpha(model, params.data());
    const float lobe_alpha = static_cast<float>(
        scene.HasSurfaceObjects() ? SurfaceLobeAlpha(model_alpha) : model_alpha);
    glUniform1f(loc("u_lobe_alpha"), lobe_alpha);
    if (light.type == Light::Type::kUniform) {
      glUniform3f(loc("u_env_radiance"), light.value.x, light.value.y, light.value.z);
      return lobe_alpha;
    }
    auto map = LoadEnvironmentCached(light.file, light.strength, light.rotation_z_deg);
    if (map != env || env_samples != light.samples) {
      GLuint old[3] = {env_tex, env_pdf_tex, env_samples_tex};
      glDeleteTextures(3, old);
      env = map;
      env_samples = light.samples;
      const Image& rad = map->radiance();
      env_tex = MakeFloatTexture(GL_RGB32F, GL_RGB, rad.width, rad.height, rad.data.data(),
                                 GL_LINEAR, GL_REPEAT);
      const Image& pdf = map->pdf_image();
      env_pdf_tex = MakeFloatTexture(GL_R32F, GL_RED, pdf.width, pdf.height, pdf.data.data(),
                                     GL_NEAREST, GL_REPEAT);
      const std::vector<float> samples = map->SampleSetMapSpace(light.samples);
      env_samples_tex = MakeFloatTexture(GL_RGBA32F, GL_RGBA, light.samples, 1, samples.data(),
                                         GL_NEAREST, GL_CLAMP_TO_EDGE);
    }
    glUniform1f(loc("u_env_strength"), static_cast<float>(light.strength));
    float m[9];
    for (int i = 0; i < 9; ++i) m[i] = static_cast<float>(map->world_to_map()[i]);
    glUniformMatrix3fv(loc("u_env_world_to_map"), 1, GL_TRUE, m);  // Row-major.
    const GLuint textures[3] = {env_tex, env_pdf_tex, env_samples_tex};
    const char* names[3] = {"u_env_map", "u_env_pdf", "u_env_samples"};
    for (int i = 0; i < 3; ++i) {
      glActiveTexture(GL_TEXTURE0 + i);
      glBindTexture(GL_TEXTURE_2D, textures[i]);
      glUniform1i(loc(names[i]), i);
    }
    return lobe_alpha;
  }

  void BindScene(GLuint program, const Scene& scene) {
    auto loc = [&](const std::string& n) { return glGetUniformLocation(program, n.c_str()); };
    const Camera& cam = scene.camera;
    auto set3 = [&](const std::string& n, const Vec3d& v) {
      glUniform3f(loc(n), static_cast<float>(v.x), static_cast<float>(v.y),
                  static_cast<float>(v.z));
    };
    BindCamera(program, cam);
    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
      const SceneObject& o = scene.objects[i];
      const std::string idx = fmt::format("[{}]", i);
      if (o.type == SceneObject::Type::kSphere) {
        glUniform4f(loc("u_obj_a" + idx), o.center.x, o.center.y, o.center.z, o.radius);
      } else {
        Vec3d u, v;
        o.PlaneTangents(&u, &v);
        glUniform4f(loc("u_obj_a" + idx), o.point.x, o.point.y, o.point.z, 0.0f);
        glUniform4f(loc("u_obj_b" + idx), o.normal.x, o.normal.y, o.normal.z, o.half_u);
        glUniform4f(loc("u_obj_c" + idx), u.x, u.y, u.z, o.half_v);
      }
    }
    int n = 0;
    Vec3d ambient{0, 0, 0};
    for (const Light& light : scene.lights) {
      if (light.type == Light::Type::kAmbient) ambient += light.value;
      if (light.type != Light::Type::kPoint && light.type != Light::Type::kDirectional) continue;
      const std::string idx = fmt::format("[{}]", n++);
      set3("u_light_pos" + idx,
           light.type == Light::Type::kPoint ? light.position : -light.direction);
      set3("u_light_value" + idx, light.value);
    }
    set3("u_ambient", ambient);
    set3("u_background", scene.background.color);
  }

  // Shades the pixels of `rect` (the scissor clips the full-screen triangle to them, so
  // llvmpipe bins and runs no fragment outside). Framebuffer rows are image rows
  // (fullscreen.vert), so `rect` needs no flip.
  void Draw(GLuint program, int w, int h, int attachments, const PixelRect& rect) {
    if (!BeginDraw(program, w, h, attachments, rect)) return;
    clean = false;
    glDisableVertexAttribArray(0);  // No vertex is read: gl_VertexID alone places them.
    glUniform1i(glGetUniformLocation(program, "u_proxy"), 0);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glDisable(GL_SCISSOR_TEST);
  }

  // Clears `rect` to 0 and shades only the pixels whose centres lie in `polygons` (inside
  // `rect`): the rest of it stays 0, as the ray cast leaves a transparent background.
  void DrawPolygons(GLuint program, int w, int h, const PixelRect& rect,
                    const std::vector<PixelPolygon>& polygons) {
    if (!BeginDraw(program, w, h, 1, rect)) return;
    std::vector<float> vertices;  // A fan about each polygon's first corner.
    for (const PixelPolygon& poly : polygons) {
      for (std::size_t k = 1; k + 1 < poly.size(); ++k) {
        for (const PixelPoint& p : {poly[0], poly[k], poly[k + 1]}) {
          vertices.push_back(static_cast<float>(p.x));
          vertices.push_back(static_cast<float>(p.y));
        }
      }
    }
    const bool same = clean && vertices == clean_vertices && rect.x0 == clean_rect.x0 &&
                      rect.y0 == clean_rect.y0 && rect.x1 == clean_rect.x1 &&
                      rect.y1 == clean_rect.y1;
    if (!same) {
      glClearColor(0.0f, 0.0f, 0.0f, 0.0f);
      glClear(GL_COLOR_BUFFER_BIT);
      clean_vertices = vertices;
      clean_rect = rect;
      clean = true;
    }
    glBindBuffer(GL_ARRAY_BUFFER, proxy_vbo);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices.size() * sizeof(float)),
                 vertices.data(), GL_STREAM_DRAW);
    glEnableVertexAttribArray(0);
    glUniform1i(glGetUniformLocation(program, "u_proxy"), 1);
    glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(vertices.size() / 2));
    glDisable(GL_SCISSOR_TEST);
  }

  // Binds the targets and the scissor of a draw; false when `rect` is empty.
  bool BeginDraw(GLuint program, int w, int h, int attachments, const PixelRect& rect) {
    EnsureTargets(w, h);
    if (rect.empty()) return false;
    glUseProgram(program);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    const GLenum bufs[3] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2};
    glDrawBuffers(attachments, bufs);
    glViewport(0, 0, w, h);
    glEnable(GL_SCISSOR_TEST);
    glScissor(rect.x0, rect.y0, rect.width(), rect.height());
    glBindVertexArray(vao);
    return true;
  }


  // --- Surface objects ---------------------------------------------------------------------

  MeshBuffers& BuffersOf(const std::shared_ptr<const TriangleMesh>& mesh) {
    auto it = mesh_buffers.find(mesh.get());
    if (it != mesh_buffers.end()) return it->second;
    MeshBuffers b;
    b.mesh = mesh;
    glGenVertexArrays(1, &b.vao);
    glGenBuffers(4, b.vbo);
    glGenBuffers(1, &b.ebo);
    glBindVertexArray(b.vao);
    const std::size_t nv = mesh->VertexCount();
    // Absent coordinates and tangents read as 0 (no normal map is applied without them).
    const std::vector<float> zeros2(mesh->uvs.empty() ? 2 * nv : 0, 0.0f);
    const std::vector<float> zeros4(mesh->tangents.empty() ? 4 * nv : 0, 0.0f);
    const std::vector<float>* arrays[4] = {&mesh->positions, &mesh->normals,
                                           mesh->uvs.empty() ? &zeros2 : &mesh->uvs,
                                           mesh->tangents.empty() ? &zeros4 : &mesh->tangents};
    const int sizes[4] = {3, 3, 2, 4};
    for (int a = 0; a < 4; ++a) {
      glBindBuffer(GL_ARRAY_BUFFER, b.vbo[a]);
      glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(arrays[a]->size() * sizeof(float)),
                   arrays[a]->data(), GL_STATIC_DRAW);
      glVertexAttribPointer(a, sizes[a], GL_FLOAT, GL_FALSE, 0, nullptr);
      glEnableVertexAttribArray(a);
    }
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, b.ebo);
    glBufferData(GL_ELEMENT_ARRAY_BUFFER,
                 static_cast<GLsizeiptr>(mesh->indices.size() * sizeof(std::uint32_t)),
                 mesh->indices.data(), GL_STATIC_DRAW);
    glBindVertexArray(vao);
    return mesh_buffers.emplace(mesh.get(), std::move(b)).first->second;
  }

  GLuint NormalMapTexture(const std::shared_ptr<const NormalMap>& map) {
    auto it = normal_maps.find(map.get());
    if (it != normal_maps.end()) return it->second.second;
    GLuint tex = MakeFloatTexture(GL_RGB32F, GL_RGB, map->image.width, map->image.height,
                                  map->image.data.data(), GL_LINEAR, GL_REPEAT);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
    normal_maps[map.get()] = {map, tex};
    return tex;
  }

  // Rasterises the meshes at ss samples per pixel side into position and normal (mesh.vert,
  // mesh.frag) and reads them back.
  internal::SurfaceSamples RasterMeshes(const Scene& scene, int ss) {
    if (!mesh_program) {
      const std::vector<std::string> vfiles = {"mesh.vert"}, ffiles = {"mesh.frag"};
      GLuint vs = CompileShader(GL_VERTEX_SHADER, JoinSources("#version 430 core\n", vfiles), vfiles);
      GLuint fs = CompileShader(GL_FRAGMENT_SHADER, JoinSources("#version 430 core\n", ffiles), ffiles);
      mesh_program = glCreateProgram();
      glAttachShader(mesh_program, vs);
      glAttachShader(mesh_program, fs);
      glLinkProgram(mesh_program);
      glDeleteShader(vs);
      glDeleteShader(fs);
      GLint ok = 0;
      glGetProgramiv(mesh_program, GL_LINK_STATUS, &ok);
      if (!ok) throw Error("GLSL", "link", "mesh program");
    }
    const Camera& cam = scene.camera;
    const int w = cam.width * ss, h = cam.height_px * ss;
    if (w != mesh_width || h != mesh_height) {
      glDeleteTextures(2, mesh_color);
      glDeleteRenderbuffers(1, &mesh_depth);
      if (!mesh_fbo) glGenFramebuffers(1, &mesh_fbo);
      glBindFramebuffer(GL_FRAMEBUFFER, mesh_fbo);
      glGenTextures(2, mesh_color);
      glActiveTexture(GL_TEXTURE0 + kScratchTextureUnit);
      for (int i = 0; i < 2; ++i) {
        glBindTexture(GL_TEXTURE_2D, mesh_color[i]);
        glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA32F, w, h);
        glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0 + i, GL_TEXTURE_2D,
                               mesh_color[i], 0);
      }
      glGenRenderbuffers(1, &mesh_depth);
      glBindRenderbuffer(GL_RENDERBUFFER, mesh_depth);
      glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, w, h);
      glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, mesh_depth);
      if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
        throw Error("OpenGL", "framebuffer", "the mesh G-buffer's targets are not supported");
      }
      mesh_width = w;
      mesh_height = h;
    }
    const Vec3d forward = Normalize(cam.look_at - cam.position);  // Camera::Basis's forward.
    // The depth range: every vertex's distance along the view axis, with slack.
    double z0 = 1e300, z1 = -1e300;
    for (const SceneObject& o : scene.objects) {
      for (std::size_t v = 0; v < o.mesh->VertexCount(); ++v) {
        const double z = Dot(o.mesh->Position(static_cast<std::uint32_t>(v)) - cam.position, forward);
        z0 = std::min(z0, z);
        z1 = std::max(z1, z);
      }
    }
    // Slack of 1% of the span, and of 0.1% of the distance: a flat mesh facing the camera has
    // no span, and float depth needs a range it can resolve.
    const double slack = std::max(0.01 * (z1 - z0), 1e-3 * std::max({std::abs(z0), std::abs(z1), 1e-3}));
    double near = z0 - slack, far = z1 + slack;
    if (cam.type == Camera::Type::kPerspective) near = std::max(near, 1e-4 * std::max(far, 1e-3));
    glUseProgram(mesh_program);
    auto loc = [&](const char* n) { return glGetUniformLocation(mesh_program, n); };
    BindCamera(mesh_program, cam);
    glUniform1i(loc("u_cam_ortho"), cam.type == Camera::Type::kOrthographic ? 1 : 0);
    glUniform2f(loc("u_depth_range"), static_cast<float>(near), static_cast<float>(far));
    glBindFramebuffer(GL_FRAMEBUFFER, mesh_fbo);
    const GLenum bufs[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    glDrawBuffers(2, bufs);
    glViewport(0, 0, w, h);
    glClearColor(0.0f, 0.0f, 0.0f, 0.0f);
    glClearDepth(1.0);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    // The projection turns the image upside down (framebuffer row k = image row k), which turns
    // a counter-clockwise front face clockwise in window space.
    glFrontFace(GL_CW);
    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
      const SceneObject& o = scene.objects[i];
      MeshBuffers& b = BuffersOf(o.mesh);
      glUniform1i(loc("u_object"), static_cast<int>(i));
      glUniform1i(loc("u_has_normal_map"), o.normal_map ? 1 : 0);
      glUniform1i(loc("u_flip_green"), o.normal_map && o.normal_map->flip_green ? 1 : 0);
      if (o.normal_map) {
        const GLuint texture = NormalMapTexture(o.normal_map);  // Uses the scratch unit.
        glActiveTexture(GL_TEXTURE3);
        glBindTexture(GL_TEXTURE_2D, texture);
        glUniform1i(loc("u_normal_map"), 3);
      }
      glBindVertexArray(b.vao);
      glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(o.mesh->indices.size()), GL_UNSIGNED_INT,
                     nullptr);
    }
    glBindVertexArray(vao);
    glDisable(GL_DEPTH_TEST);
    glFrontFace(GL_CCW);
    internal::SurfaceSamples out;
    out.ss = ss;
    out.width = w;
    out.height = h;
    for (int a = 0; a < 2; ++a) {
      Image img(w, h, 4);
      glReadBuffer(GL_COLOR_ATTACHMENT0 + a);
      glPixelStorei(GL_PACK_ALIGNMENT, 1);
      glReadPixels(0, 0, w, h, GL_RGBA, GL_FLOAT, img.data.data());
      (a == 0 ? out.position : out.normal) = std::move(img);
    }
    return out;
  }

  // The per-sample G-buffer, its textures and the image's G-buffer for the scene's geometry;
  // the visibility texture for its lights. Returns the visibility texture.
  GLuint PrepareSurface(const Scene& scene) {
    const int ss = std::max(1, scene.camera.supersample);
    const std::string key = internal::SurfaceGeometryKey(scene, ss);
    const bool pixels = scene.objects.front().type == SceneObject::Type::kNormalMap;
    if (key != surface_key) {
      surface_key.clear();
      surface_samples = pixels ? internal::PixelSurfaceSamples(scene, ss) : RasterMeshes(scene, ss);
      const internal::SurfaceSamples centres =
          ss == 1 ? surface_samples
                  : (pixels ? internal::PixelSurfaceSamples(scene, 1) : RasterMeshes(scene, 1));
      surface_gbuffer = internal::SurfaceGBuffer(scene, centres, surface_samples);
      PixelRect r{scene.camera.width, scene.camera.height_px, 0, 0};
      for (int y = 0; y < surface_gbuffer.height; ++y) {
        for (int x = 0; x < surface_gbuffer.width; ++x) {
          if (!(surface_gbuffer.Coverage(x, y) > 0)) continue;
          r.x0 = std::min(r.x0, x);
          r.y0 = std::min(r.y0, y);
          r.x1 = std::max(r.x1, x + 1);
          r.y1 = std::max(r.y1, y + 1);
        }
      }
      surface_rect = r.empty() ? PixelRect{} : r;
      glDeleteTextures(2, surface_tex);
      surface_tex[0] = MakeFloatTexture(GL_RGBA32F, GL_RGBA, surface_samples.width,
                                        surface_samples.height, surface_samples.position.data.data(),
                                        GL_NEAREST, GL_CLAMP_TO_EDGE);
      surface_tex[1] = MakeFloatTexture(GL_RGBA32F, GL_RGBA, surface_samples.width,
                                        surface_samples.height, surface_samples.normal.data.data(),
                                        GL_NEAREST, GL_CLAMP_TO_EDGE);
      for (auto& [k, tex] : visibility_tex) glDeleteTextures(1, &tex);
      visibility_tex.clear();
      visibility_order.clear();
      surface_key = key;
    }
    const std::string lights = internal::SurfaceLightsKey(scene, ss);
    auto it = visibility_tex.find(lights);
    if (it != visibility_tex.end()) return it->second;
    const std::vector<std::uint32_t> bits = internal::SampleVisibility(scene, surface_samples);
    GLuint tex = 0;
    glGenTextures(1, &tex);
    glActiveTexture(GL_TEXTURE0 + kScratchTextureUnit);
    glBindTexture(GL_TEXTURE_2D, tex);
    glTexStorage2D(GL_TEXTURE_2D, 1, GL_R32UI, surface_samples.width, surface_samples.height);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, surface_samples.width, surface_samples.height,
                    GL_RED_INTEGER, GL_UNSIGNED_INT, bits.data());
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    if (visibility_order.size() >= kVisibilityCache) {
      glDeleteTextures(1, &visibility_tex[visibility_order.front()]);
      visibility_tex.erase(visibility_order.front());
      visibility_order.pop_front();
    }
    visibility_order.push_back(lights);
    visibility_tex[lights] = tex;
    return tex;
  }

  // A surface scene's environment visibility (internal::EnvironmentVisibility): the fixed
  // techniques' per geometry and light, the GGX proposal's per lobe width too, kept with the
  // point lights' visibility (same cache, same eviction, cleared with the geometry).
  GLuint EnvironmentVisibilityTexture(const Scene& scene, internal::EnvTechniques which,
                                      float lobe_alpha) {
    // The cache is emptied with every new geometry (PrepareSurface): the light is the key.
    const Light& light = scene.lights[scene.EnvironmentLight()];
    const std::string key = fmt::format(
        "env {} {} {:.17g} {} {}", light.type == Light::Type::kUniform ? "uniform" : light.file,
        light.samples, light.rotation_z_deg,
        which == internal::EnvTechniques::kLobe ? "lobe" : "fixed", lobe_alpha);
    auto it = visibility_tex.find(key);
    if (it != visibility_tex.end()) return it->second;
    int layers = 0;
    const std::vector<std::uint32_t> bits =
        internal::EnvironmentVisibility(scene, surface_samples, which, lobe_alpha, &layers);
    GLuint tex = 0;
    glGenTextures(1, &tex);
    glActiveTexture(GL_TEXTURE0 + kScratchTextureUnit);
    glBindTexture(GL_TEXTURE_2D_ARRAY, tex);
    glTexStorage3D(GL_TEXTURE_2D_ARRAY, 1, GL_R32UI, surface_samples.width,
                   surface_samples.height, std::max(layers, 1));
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    if (layers > 0) {
      glTexSubImage3D(GL_TEXTURE_2D_ARRAY, 0, 0, 0, 0, surface_samples.width,
                      surface_samples.height, layers, GL_RED_INTEGER, GL_UNSIGNED_INT,
                      bits.data());
    }
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    if (visibility_order.size() >= kVisibilityCache) {
      glDeleteTextures(1, &visibility_tex[visibility_order.front()]);
      visibility_tex.erase(visibility_order.front());
      visibility_order.pop_front();
    }
    visibility_order.push_back(key);
    visibility_tex[key] = tex;
    return tex;
  }

  void BindSurfaceEnvironment(GLuint program, const Scene& scene, float lobe_alpha) {
    if (scene.EnvironmentLight() < 0) return;
    const GLuint textures[2] = {
        EnvironmentVisibilityTexture(scene, internal::EnvTechniques::kLightAndCosine, 0.0f),
        EnvironmentVisibilityTexture(scene, internal::EnvTechniques::kLobe, lobe_alpha)};
    const char* names[2] = {"u_surf_env_visibility", "u_surf_lobe_visibility"};
    for (int i = 0; i < 2; ++i) {
      glActiveTexture(GL_TEXTURE6 + i);
      glBindTexture(GL_TEXTURE_2D_ARRAY, textures[i]);
      glUniform1i(glGetUniformLocation(program, names[i]), 6 + i);
    }
    glUniform1i(glGetUniformLocation(program, "u_surf_env_words"),
                internal::EnvironmentVisibilityWords(scene));
  }

  void BindSurface(GLuint program, GLuint visibility) {
    const GLuint textures[3] = {surface_tex[0], surface_tex[1], visibility};
    const char* names[3] = {"u_surf_position", "u_surf_normal", "u_surf_visibility"};
    for (int i = 0; i < 3; ++i) {
      glActiveTexture(GL_TEXTURE3 + i);
      glBindTexture(GL_TEXTURE_2D, textures[i]);
      glUniform1i(glGetUniformLocation(program, names[i]), 3 + i);
    }
  }

  // Reads `rect` of an attachment straight into a w x h image (rows in our order already);
  // the pixels outside it stay 0.
  Image Read(int attachment, int w, int h, const PixelRect& rect) {
    Image img(w, h, 4);
    if (rect.empty()) return img;
    glReadBuffer(GL_COLOR_ATTACHMENT0 + attachment);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glPixelStorei(GL_PACK_ROW_LENGTH, w);
    glReadPixels(rect.x0, rect.y0, rect.width(), rect.height(), GL_RGBA, GL_FLOAT,
                 &img.data[(static_cast<std::size_t>(rect.y0) * w + rect.x0) * 4]);
    glPixelStorei(GL_PACK_ROW_LENGTH, 0);
    return img;
  }
};

Renderer::Renderer(GlContext& context, const RendererOptions& options)
    : impl_(std::make_unique<Impl>(context, options)) {}
Renderer::~Renderer() = default;

Image Renderer::Render(const Scene& scene, ModelId model, const std::vector<double>& params,
                       ModelTerm term) {
  const ModelInfo& info = GetModel(model);
  if (static_cast<int>(params.size()) != info.ParamCount() || info.ParamCount() > kMaxParams) {
    throw Error("", "params", fmt::format("model {} takes {} parameters, got {}", info.name,
                                          info.ParamCount(), params.size()));
  }
  // Another GlContext made on this thread (a nested Fit, say) may have taken the thread over.
  impl_->context.MakeCurrent();
  const GLuint visibility = scene.HasSurfaceObjects() ? impl_->PrepareSurface(scene) : 0;
  GLuint program = impl_->Program(model, term, false, scene);
  glUseProgram(program);
  impl_->BindScene(program, scene);
  const float lobe_alpha = impl_->BindEnvironment(program, scene, model, params);
  if (visibility) impl_->BindSurfaceEnvironment(program, scene, lobe_alpha);
  float p[kMaxParams] = {0};
  for (std::size_t i = 0; i < params.size(); ++i) p[i] = static_cast<float>(params[i]);
  glUniform1fv(glGetUniformLocation(program, "u_params"), kMaxParams, p);
  const int w = scene.camera.width, h = scene.camera.height_px;
  // Where no sample hits, a transparent background's pixel is 0 in all four channels (the
  // shader's sums start at 0 and the background adds nothing), which is what Read leaves
  // outside the rectangle. An opaque background (a colour or the environment) is shaded.
  // Within the rectangle, only the objects' polygons are rasterised.
  const PixelRect frame{0, 0, w, h};
  if (visibility) {
    impl_->BindSurface(program, visibility);
    // Outside the pixels any sample hits, a transparent background's pixel is 0 (as above).
    const PixelRect rect = scene.background.transparent ? impl_->surface_rect : frame;
    impl_->Draw(program, w, h, 1, rect);
    return impl_->Read(0, w, h, rect);
  }
  if (impl_->options.bound_objects && scene.background.transparent) {
    bool whole_frame = false;
    const std::vector<PixelPolygon> polygons = ObjectPixelPolygons(scene, &whole_frame);
    if (!whole_frame) {
      const PixelRect rect = ObjectPixelBounds(scene);
      impl_->DrawPolygons(program, w, h, rect, polygons);
      return impl_->Read(0, w, h, rect);
    }
  }
  impl_->Draw(program, w, h, 1, frame);
  return impl_->Read(0, w, h, frame);
}

GBuffer Renderer::RenderGBuffer(const Scene& scene) {
  impl_->context.MakeCurrent();
  if (scene.HasSurfaceObjects()) {
    impl_->PrepareSurface(scene);
    return impl_->surface_gbuffer;
  }
  GLuint program = impl_->Program(ModelId::kLambert, ModelTerm::kReflect, true, scene);
  glUseProgram(program);
  impl_->BindScene(program, scene);
  const int w = scene.camera.width, h = scene.camera.height_px;
  // Every pixel: the view direction is defined on the background too.
  const PixelRect frame{0, 0, w, h};
  impl_->Draw(program, w, h, 3, frame);
  GBuffer g;
  g.width = w;
  g.height = h;
  g.position = impl_->Read(0, w, h, frame);
  g.normal = impl_->Read(1, w, h, frame);
  g.view = impl_->Read(2, w, h, frame);
  return g;
}

}  // namespace shadefit
