// A headless OpenGL 4.5 (4.3 minimum) core context through EGL: no window, no display, no X.
#pragma once

#include <memory>
#include <string>

namespace shadefit {

struct GlDeviceInfo {
  std::string platform;     // "device" (EGL_EXT_platform_device) or "surfaceless".
  std::string device;       // DRM node or "software" (Mesa's llvmpipe device).
  bool hardware = false;
  std::string gl_vendor, gl_renderer, gl_version, glsl_version;
  int gl_major = 0, gl_minor = 0;
};

// Owns an EGL display + context. Device choice: a hardware device from EGL device enumeration
// (NVIDIA's EGL on GPU machines), else Mesa's software device (llvmpipe), else the surfaceless
// platform. Environment variable SHADEFIT_EGL_DEVICE=software forces the software device.
// One context per thread: MakeCurrent() binds it to the calling thread.
class GlContext {
 public:
  // Throws shadefit::Error with a one-line message naming the packages that provide EGL
  // (libegl1 libegl-mesa0 libgl1-mesa-dri) when no usable device exists.
  GlContext();
  ~GlContext();
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  void MakeCurrent();
  const GlDeviceInfo& info() const { return info_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  GlDeviceInfo info_;
};

}  // namespace shadefit
