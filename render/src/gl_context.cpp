#include "shadefit/render/gl_context.h"

#include <epoxy/egl.h>
#include <epoxy/gl.h>
#include <fmt/format.h>

#include <cstdlib>
#include <cstring>
#include <vector>

#include "shadefit/base/error.h"

namespace shadefit {
namespace {

constexpr const char* kInstallHint =
    "no usable EGL/OpenGL 4.3+ device (install libegl1 libegl-mesa0 libgl1-mesa-dri for Mesa's "
    "llvmpipe, or the NVIDIA driver's EGL)";

bool HasExtension(const char* list, const char* name) {
  if (!list) return false;
  const std::size_t len = std::strlen(name);
  for (const char* p = list; (p = std::strstr(p, name)) != nullptr; p += len) {
    if ((p == list || p[-1] == ' ') && (p[len] == ' ' || p[len] == '\0')) return true;
  }
  return false;
}

}  // namespace

struct GlContext::Impl {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;

  // Initialises `d` and creates a core context, trying 4.5 then 4.3. False on failure.
  bool TryDisplay(EGLDisplay d) {
    if (d == EGL_NO_DISPLAY) return false;
    EGLint major = 0, minor = 0;
    if (!eglInitialize(d, &major, &minor)) return false;
    if (!eglBindAPI(EGL_OPENGL_API)) {
      eglTerminate(d);
      return false;
    }
    const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE,
                                     EGL_PBUFFER_BIT, EGL_NONE};
    EGLConfig config = nullptr;
    EGLint count = 0;
    if (!eglChooseConfig(d, config_attribs, &config, 1, &count) || count == 0) {
      // Surfaceless contexts need no pbuffer-capable config.
      const EGLint any[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
      if (!eglChooseConfig(d, any, &config, 1, &count) || count == 0) config = EGL_NO_CONFIG_KHR;
    }
    for (const int minor_version : {5, 3}) {
      const EGLint ctx_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION,
                                    minor_version, EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                    EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
      context = eglCreateContext(d, config, EGL_NO_CONTEXT, ctx_attribs);
      if (context != EGL_NO_CONTEXT) break;
    }
    if (context == EGL_NO_CONTEXT ||
        !eglMakeCurrent(d, EGL_NO_SURFACE, EGL_NO_SURFACE, context)) {
      if (context != EGL_NO_CONTEXT) eglDestroyContext(d, context);
      context = EGL_NO_CONTEXT;
      eglTerminate(d);
      return false;
    }
    display = d;
    return true;
  }
};

GlContext::GlContext() : impl_(std::make_unique<Impl>()) {
  const char* client_ext = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  const char* force = std::getenv("SHADEFIT_EGL_DEVICE");
  // Unset or empty: hardware first. Any other value is a typo that would silently do nothing.
  if (force != nullptr && *force != '\0' && std::strcmp(force, "software") != 0) {
    throw Error("", "SHADEFIT_EGL_DEVICE",
                std::string("unknown value '") + force + "' (expected 'software' or unset)");
  }
  const bool force_software = force && std::strcmp(force, "software") == 0;

  if (HasExtension(client_ext, "EGL_EXT_device_enumeration") &&
      HasExtension(client_ext, "EGL_EXT_platform_device")) {
    EGLint num = 0;
    eglQueryDevicesEXT(0, nullptr, &num);
    std::vector<EGLDeviceEXT> devices(static_cast<std::size_t>(num > 0 ? num : 0));
    if (num > 0) eglQueryDevicesEXT(num, devices.data(), &num);
    // Three passes: NVIDIA devices (EGL_NV_device_cuda: a GPU node of a cluster, where Slurm's
    // device cgroup leaves only the job's GPUs openable, so the first that initialises is the
    // job's own), then other hardware, then software ones (Mesa's llvmpipe).
    for (int pass = force_software ? 2 : 0; pass < 3 && impl_->display == EGL_NO_DISPLAY;
         ++pass) {
      for (EGLDeviceEXT dev : devices) {
        const char* dev_ext = eglQueryDeviceStringEXT(dev, EGL_EXTENSIONS);
        const bool software = HasExtension(dev_ext, "EGL_MESA_device_software");
        const bool nvidia = HasExtension(dev_ext, "EGL_NV_device_cuda");
        if (pass != (software ? 2 : nvidia ? 0 : 1)) continue;
        EGLDisplay d = eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, dev, nullptr);
        if (impl_->TryDisplay(d)) {
          info_.platform = "device";
          const char* node = HasExtension(dev_ext, "EGL_EXT_device_drm")
                                 ? eglQueryDeviceStringEXT(dev, EGL_DRM_DEVICE_FILE_EXT)
                                 : nullptr;
          info_.device = software ? "software" : (node ? node : "hardware");
          info_.hardware = !software;
          break;
        }
      }
    }
  }
  if (impl_->display == EGL_NO_DISPLAY &&
      HasExtension(client_ext, "EGL_MESA_platform_surfaceless")) {
    EGLDisplay d = eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY,
                                            nullptr);
    if (impl_->TryDisplay(d)) {
      info_.platform = "surfaceless";
      info_.device = "default";
    }
  }
  if (impl_->display == EGL_NO_DISPLAY) throw Error(kInstallHint);

  auto str = [](GLenum e) {
    const auto* s = reinterpret_cast<const char*>(glGetString(e));
    return std::string(s ? s : "");
  };
  info_.gl_vendor = str(GL_VENDOR);
  info_.gl_renderer = str(GL_RENDERER);
  info_.gl_version = str(GL_VERSION);
  info_.glsl_version = str(GL_SHADING_LANGUAGE_VERSION);
  glGetIntegerv(GL_MAJOR_VERSION, &info_.gl_major);
  glGetIntegerv(GL_MINOR_VERSION, &info_.gl_minor);
  if (info_.gl_major < 4 || (info_.gl_major == 4 && info_.gl_minor < 3)) {
    throw Error(fmt::format("OpenGL {}.{} found, 4.3 needed: {}", info_.gl_major, info_.gl_minor,
                            kInstallHint));
  }
}

GlContext::~GlContext() {
  if (impl_ && impl_->display != EGL_NO_DISPLAY) {
    eglMakeCurrent(impl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (impl_->context != EGL_NO_CONTEXT) eglDestroyContext(impl_->display, impl_->context);
    // No eglTerminate: the display is shared by every context of the process on this device.
  }
}

void GlContext::CheckNotLost() const {
  const bool available = (info_.gl_major > 4 || (info_.gl_major == 4 && info_.gl_minor >= 5)) ||
                         epoxy_has_gl_extension("GL_KHR_robustness");
  if (!available) return;
  const GLenum status = glGetGraphicsResetStatus();
  if (status != GL_NO_ERROR) {
    throw GlContextLostError("", "GL", fmt::format("context lost (reset status 0x{:04x}) on {}",
                                                   status, info_.gl_renderer));
  }
}

void GlContext::MakeCurrent() {
  if (!eglMakeCurrent(impl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, impl_->context)) {
    throw Error("eglMakeCurrent failed");
  }
}

void GlContext::ReleaseCurrent() {
  if (!eglMakeCurrent(impl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT)) {
    throw Error("eglMakeCurrent (release) failed");
  }
}

}  // namespace shadefit
