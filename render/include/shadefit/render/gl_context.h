// A headless OpenGL 4.5 (4.3 minimum) core context through EGL: no window, no display, no X.
#pragma once

#include <memory>
#include <string>

#include "shadefit/base/error.h"

namespace shadefit {

// The GL context was lost (a GPU reset, a driver restart, a node's GPU taken away): nothing
// rendered since can be trusted. The study runner records it, makes a new context and retries
// the job once.
class GlContextLostError : public Error {
 public:
  using Error::Error;
};

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
  // Unbinds it from the calling thread, so that another thread can MakeCurrent() it (a context
  // made on a helper thread while the main one reads its inputs).
  void ReleaseCurrent();
  const GlDeviceInfo& info() const { return info_; }
  // Throws GlContextLostError when the context reports a reset (glGetGraphicsResetStatus, core
  // in GL 4.5; a no-op on a 4.3 context without KHR_robustness).
  void CheckNotLost() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  GlDeviceInfo info_;
};

}  // namespace shadefit
