// numpy <-> Image, JSON -> Python, parameters from Python values, the shared GL context.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "common.h"
#include "shadefit/base/error.h"

namespace shadefit::python {

py::array ImageToArray(Image&& image, bool squeeze) {
  auto* owned = new Image(std::move(image));
  py::capsule free_when_done(owned, [](void* p) { delete static_cast<Image*>(p); });
  const auto h = static_cast<py::ssize_t>(owned->height);
  const auto w = static_cast<py::ssize_t>(owned->width);
  const auto c = static_cast<py::ssize_t>(owned->channels);
  const auto f = static_cast<py::ssize_t>(sizeof(float));
  if (squeeze && c == 1) {
    return py::array_t<float>({h, w}, {w * f, f}, owned->data.data(), free_when_done);
  }
  return py::array_t<float>({h, w, c}, {w * c * f, c * f, f}, owned->data.data(), free_when_done);
}

namespace {

std::string ShapeText(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

std::string ChannelsText(const std::vector<int>& channels) {
  std::string s;
  for (std::size_t i = 0; i < channels.size(); ++i) {
    s += (i == 0 ? "" : (i + 1 == channels.size() ? " or " : ", ")) +
         fmt::format("(H, W, {})", channels[i]);
  }
  return s;
}

py::array AsArray(py::handle object, const std::string& what) {
  if (!py::isinstance<py::array>(object)) {
    throw py::type_error(
        fmt::format("{}: expected a numpy array, got {}", what,
                    py::str(py::type::of(object).attr("__name__")).cast<std::string>()));
  }
  return py::reinterpret_borrow<py::array>(object);
}

}  // namespace

Image ArrayToImage(py::handle object, const std::string& what, const std::vector<int>& channels) {
  py::array a = AsArray(object, what);
  if (!a.dtype().is(py::dtype::of<float>())) {
    throw py::type_error(fmt::format(
        "{}: expected dtype float32 (linear radiance), got {}; convert with .astype(numpy.float32)",
        what, py::str(a.dtype()).cast<std::string>()));
  }
  const bool one = std::find(channels.begin(), channels.end(), 1) != channels.end();
  const bool shape_ok = (a.ndim() == 3 && std::find(channels.begin(), channels.end(), a.shape(2)) !=
                                              channels.end()) ||
                        (a.ndim() == 2 && one);
  if (!shape_ok || a.shape(0) < 1 || a.shape(1) < 1) {
    throw py::value_error(fmt::format("{}: expected shape {}{}, got {}", what,
                                      ChannelsText(channels), one ? " or (H, W)" : "",
                                      ShapeText(a)));
  }
  if (a.shape(0) > 16384 || a.shape(1) > 16384) {
    throw py::value_error(
        fmt::format("{}: {} x {} pixels is beyond 16384 per side", what, a.shape(1), a.shape(0)));
  }
  const auto f = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(a);
  Image image(static_cast<int>(a.shape(1)), static_cast<int>(a.shape(0)),
              a.ndim() == 3 ? static_cast<int>(a.shape(2)) : 1);
  std::memcpy(image.data.data(), f.data(), image.data.size() * sizeof(float));
  return image;
}

Image MaskToImage(py::handle object, const std::string& what) {
  py::array a = AsArray(object, what);
  if (a.dtype().is(py::dtype::of<bool>())) {
    if (a.ndim() != 2) {
      throw py::value_error(fmt::format("{}: expected shape (H, W), got {}", what, ShapeText(a)));
    }
    const auto b = py::array_t<bool, py::array::c_style | py::array::forcecast>::ensure(a);
    Image image(static_cast<int>(a.shape(1)), static_cast<int>(a.shape(0)), 1);
    for (std::size_t i = 0; i < image.data.size(); ++i) image.data[i] = b.data()[i] ? 1.f : 0.f;
    return image;
  }
  if (!a.dtype().is(py::dtype::of<float>())) {
    throw py::type_error(fmt::format("{}: expected dtype float32 or bool, got {}", what,
                                     py::str(a.dtype()).cast<std::string>()));
  }
  return ArrayToImage(a, what, {1});
}

py::object JsonToPy(const nlohmann::json& j) {
  switch (j.type()) {
    case nlohmann::json::value_t::null:
      return py::none();
    case nlohmann::json::value_t::boolean:
      return py::bool_(j.get<bool>());
    case nlohmann::json::value_t::number_integer:
      return py::int_(j.get<std::int64_t>());
    case nlohmann::json::value_t::number_unsigned:
      return py::int_(j.get<std::uint64_t>());
    case nlohmann::json::value_t::number_float:
      return py::float_(j.get<double>());
    case nlohmann::json::value_t::string:
      return py::str(j.get_ref<const std::string&>());
    case nlohmann::json::value_t::array: {
      py::list out;
      for (const auto& v : j) out.append(JsonToPy(v));
      return out;
    }
    case nlohmann::json::value_t::object: {
      py::dict out;
      for (auto it = j.begin(); it != j.end(); ++it) out[py::str(it.key())] = JsonToPy(it.value());
      return out;
    }
    default:
      return py::none();  // binary, discarded: never written by shadefit.
  }
}

std::vector<double> ParamsFromPy(const ModelInfo& model, py::handle params,
                                 const std::string& context) {
  std::vector<double> out = DefaultParams(model);
  if (params.is_none()) return out;
  if (py::isinstance<py::dict>(params)) {
    for (auto item : py::reinterpret_borrow<py::dict>(params)) {
      const std::string name = py::str(item.first);
      std::vector<double> values;
      if (py::isinstance<py::str>(item.second)) {
        throw py::type_error(
            fmt::format("{}: {}: expected a number or (r, g, b), got a string", context, name));
      }
      try {
        if (py::isinstance<py::sequence>(item.second) || py::isinstance<py::array>(item.second)) {
          values = item.second.cast<std::vector<double>>();
        } else {
          values.push_back(item.second.cast<double>());
        }
      } catch (const py::cast_error&) {
        throw py::type_error(fmt::format("{}: {}: expected a number or (r, g, b)", context, name));
      }
      SetParam(model, name, values, context, &out);
    }
    return out;
  }
  std::vector<double> flat;
  try {
    flat = params.cast<std::vector<double>>();
  } catch (const py::cast_error&) {
    throw py::type_error(
        fmt::format("{}: expected a dict {{name: value}}, a sequence of {} numbers or None",
                    context, model.ParamCount()));
  }
  if (static_cast<int>(flat.size()) != model.ParamCount()) {
    throw Error("", context,
                fmt::format("{} values given; model {} has {} ({})", flat.size(), model.name,
                            model.ParamCount(), [&] {
                              std::string names;
                              for (int i = 0; i < model.ParamCount(); ++i) {
                                names += (i ? " " : "") + model.EntryName(i);
                              }
                              return names;
                            }()));
  }
  // Each value goes through SetParam's range check, under its row's name.
  for (const ParamSpec& p : model.params) {
    const int o = model.Offset(p.name);
    SetParam(model, p.name, std::vector<double>(flat.begin() + o, flat.begin() + o + p.size),
             context, &out);
  }
  return out;
}

Scene SceneFromArgs(const std::string& path, const std::string& text,
                    const std::string& text_name) {
  if (!path.empty()) return LoadScene(path);
  return ParseScene(text, text_name);
}

SharedGl& SharedGl::Get() {
  static SharedGl* gl = new SharedGl;  // Close() ends its context; the object itself stays.
  return *gl;
}

int SharedGl::ContextsCreated() {
  SharedGl& gl = Get();
  std::lock_guard<std::mutex> lock(gl.mutex_);
  return gl.created_;
}

void SharedGl::Close() {
  SharedGl& gl = Get();
  std::lock_guard<std::mutex> lock(gl.mutex_);
  if (gl.context_) gl.context_->MakeCurrent();
  gl.renderer_.reset();
  gl.context_.reset();
}

}  // namespace shadefit::python
