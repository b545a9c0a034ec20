// What every binding file of the Python module shares: numpy <-> Image conversion, nlohmann::json
// -> Python objects, model parameters from Python values, and the one GL context of the process.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/pybind11.h>

#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "shadefit/render/gl_context.h"
#include "shadefit/render/image.h"
#include "shadefit/render/models.h"
#include "shadefit/render/renderer.h"
#include "shadefit/render/scene.h"

namespace shadefit::python {

namespace py = pybind11;

// An image as a numpy array (H, W, C) float32 (H, W when `squeeze` and C == 1) that owns the
// Image's storage: no copy, the array keeps it alive.
py::array ImageToArray(Image&& image, bool squeeze = false);

// A numpy array as an Image (one copy: Image owns its std::vector). `what` names the argument in
// the messages. Accepts float32 only (TypeError otherwise), C order or not, of shape (H, W, C)
// with C in `channels`, or (H, W) when 1 is among them (ValueError otherwise).
Image ArrayToImage(py::handle array, const std::string& what, const std::vector<int>& channels);

// A mask: float32 (H, W) or (H, W, 1), value > 0.5 = use, or bool (H, W).
Image MaskToImage(py::handle array, const std::string& what);

py::object JsonToPy(const nlohmann::json& j);

// Parameters of `model`: None (defaults), a dict {row: value or (r, g, b)} (SetParam's checks,
// naming `context`), or a flat sequence of ParamCount() numbers (FitResult.values).
std::vector<double> ParamsFromPy(const ModelInfo& model, py::handle params,
                                 const std::string& context);

// The scene given as a path or as TOML text (exactly one is non-empty); text is parsed with
// `text_name` standing for its file (relative paths resolve against its folder).
Scene SceneFromArgs(const std::string& path, const std::string& text, const std::string& text_name);

// The process's GL context and renderer, made on first use and reused by every call (one
// context per process however many calls; a second thread waits for the first). The context is
// released from the calling thread after each use, so that any thread may take it next.
class SharedGl {
 public:
  // Runs f(renderer, context) with the context current on the calling thread. Call without the
  // GIL (a render is long).
  template <typename F>
  static auto With(F&& f) {
    SharedGl& gl = Get();
    std::lock_guard<std::mutex> lock(gl.mutex_);
    if (!gl.context_) {
      gl.context_ = std::make_unique<GlContext>();
      gl.renderer_ = std::make_unique<Renderer>(*gl.context_);
      ++gl.created_;
    }
    gl.context_->MakeCurrent();
    struct Release {
      GlContext* c;
      ~Release() { c->ReleaseCurrent(); }
    } release{gl.context_.get()};
    return f(*gl.renderer_, *gl.context_);
  }
  static int ContextsCreated();
  // Destroys the context (at interpreter exit, while EGL is still loaded; a later call makes a
  // new one).
  static void Close();

 private:
  static SharedGl& Get();
  std::mutex mutex_;
  std::unique_ptr<GlContext> context_;
  std::unique_ptr<Renderer> renderer_;
  int created_ = 0;
};

// Registration of each binding file's functions on the module `_shadefit`.
void RegisterFit(py::module_& m);
void RegisterProbes(py::module_& m);
void RegisterStudy(py::module_& m);

}  // namespace shadefit::python
