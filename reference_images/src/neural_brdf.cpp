// Neural-BRDF networks (Sztrajman et al. 2021): a Keras Sequential of three Dense layers read with
// the HDF5 C API, evaluated as ../shared/brdf-data/README.md specifies:
//   a1 = relu(x W1 + b1), a2 = relu(a1 W2 + b2), y = max(exp(a2 W3 + b3) - 1, 0).
#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>

#include "shadefit/base/files.h"
#include "shadefit/reference_images/measured_brdf.h"
#include "shadefit/base/error.h"

namespace shadefit::reference_images {
namespace {

// Closes an HDF5 handle on scope exit.
class H5Handle {
 public:
  H5Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~H5Handle() {
    if (id_ >= 0) close_(id_);
  }
  H5Handle(const H5Handle&) = delete;
  H5Handle& operator=(const H5Handle&) = delete;
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

// The HDF5 library is not built thread-safe on Debian; every call goes through this lock.
std::mutex& Hdf5Mutex() {
  static std::mutex m;
  return m;
}

// Reads one float dataset of the expected shape; the error names the file and the dataset path.
std::vector<float> ReadDataset(hid_t file, const std::string& file_path, const std::string& name,
                               const std::vector<hsize_t>& shape) {
  // H5Lexists on a path whose parent group is missing fails, so walk it one link at a time.
  std::string prefix;
  std::size_t pos = 1;
  while (pos <= name.size()) {
    const std::size_t next = name.find('/', pos);
    prefix = name.substr(0, next == std::string::npos ? name.size() : next);
    if (H5Lexists(file, prefix.c_str(), H5P_DEFAULT) <= 0) {
      throw Error(file_path, name, "dataset missing (no link " + prefix + ")");
    }
    if (next == std::string::npos) break;
    pos = next + 1;
  }
  H5Handle set(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!set.ok()) throw Error(file_path, name, "cannot open dataset");
  H5Handle space(H5Dget_space(set.get()), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space.get());
  std::vector<hsize_t> dims(std::max(rank, 0));
  if (rank > 0) H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
  if (dims != shape) {
    auto str = [](const std::vector<hsize_t>& d) {
      std::string s = "(";
      for (std::size_t i = 0; i < d.size(); ++i) s += (i ? ", " : "") + std::to_string(d[i]);
      return s + ")";
    };
    throw Error(file_path, name, "shape " + str(dims) + ", expected " + str(shape));
  }
  std::size_t count = 1;
  for (hsize_t d : dims) count *= d;
  std::vector<float> out(count);
  if (H5Dread(set.get(), H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0) {
    throw Error(file_path, name, "cannot read dataset as float32");
  }
  for (float v : out) {
    if (!std::isfinite(v)) throw Error(file_path, name, "NaN or Inf weight");
  }
  return out;
}

// One Dense layer of the Keras config: its name (and so its dataset paths), activation, width.
struct DenseLayer {
  std::string name, activation;
  int units;
};

// The model config's three Dense layers, checked to be relu, relu, linear with 3 outputs.
std::vector<DenseLayer> ReadDenseLayers(const std::string& json_path) {
  nlohmann::json config;
  try {
    std::ifstream in(json_path);
    config = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw Error(json_path, "json", "not valid JSON: " + OneLine(e.what()));
  }
  const nlohmann::json* layers = nullptr;
  if (config.contains("config") && config["config"].is_object() &&
      config["config"].contains("layers") && config["config"]["layers"].is_array()) {
    layers = &config["config"]["layers"];
  } else if (config.contains("config") && config["config"].is_array()) {
    layers = &config["config"];  // Keras < 2.2 wrote the layer list directly.
  }
  if (!layers) throw Error(json_path, "config.layers", "missing: expected a Keras Sequential");
  std::vector<DenseLayer> dense;
  for (std::size_t i = 0; i < layers->size(); ++i) {
    const nlohmann::json& layer = (*layers)[i];
    const std::string field = "config.layers[" + std::to_string(i) + "]";
    if (!layer.is_object()) throw Error(json_path, field, "expected an object");
    if (!layer.contains("class_name") || !layer["class_name"].is_string()) {
      throw Error(json_path, field + ".class_name", "missing or not a string");
    }
    if (layer["class_name"] != "Dense") continue;
    if (!layer.contains("config") || !layer["config"].is_object()) {
      throw Error(json_path, field + ".config", "missing or not an object");
    }
    const nlohmann::json& c = layer["config"];
    for (const char* key : {"name", "activation"}) {
      if (!c.contains(key) || !c[key].is_string()) {
        throw Error(json_path, field + ".config." + key, "missing or not a string");
      }
    }
    // A width beyond 4096 is no network of this family (21 in the published ones) and would
    // make the dataset shapes overflow.
    const bool units_ok = c.contains("units") && c["units"].is_number_integer() &&
                          c["units"].get<std::int64_t>() >= 1 &&
                          c["units"].get<std::int64_t>() <= 4096;
    if (!units_ok) {
      throw Error(json_path, field + ".config.units", "expected an integer in [1, 4096]");
    }
    dense.push_back(
        {c["name"].get<std::string>(), c["activation"].get<std::string>(), c["units"].get<int>()});
  }
  static const char* kActivation[3] = {"relu", "relu", "linear"};
  if (dense.size() != 3) {
    throw Error(json_path, "config.layers",
                std::to_string(dense.size()) + " Dense layers, expected 3");
  }
  for (int l = 0; l < 3; ++l) {
    if (dense[l].activation != kActivation[l]) {
      throw Error(json_path, "config.layers[" + dense[l].name + "].activation",
                  "\"" + dense[l].activation + "\", expected \"" + kActivation[l] + "\"");
    }
  }
  if (dense[2].units != 3)
    throw Error(json_path, "config.layers[" + dense[2].name + "].units",
                "expected 3 outputs (RGB)");
  return dense;
}

}  // namespace

NeuralBrdf::NeuralBrdf(const std::string& h5_path, const std::string& json_path)
    : h5_path_(h5_path), json_path_(json_path) {
  namespace fs = std::filesystem;
  if (!PathExists(json_path)) throw Error(json_path, "", "file not found");
  if (!PathExists(h5_path)) throw Error(h5_path, "", "file not found");

  // The model config names the layers (and so the dataset paths) and their activations.
  const std::vector<DenseLayer> dense = ReadDenseLayers(json_path);

  std::lock_guard<std::mutex> lock(Hdf5Mutex());
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // Errors come back as ours, not printed stacks.
  if (H5Fis_hdf5(h5_path.c_str()) <= 0) throw Error(h5_path, "format", "not an HDF5 file");
  H5Handle file(H5Fopen(h5_path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) throw Error(h5_path, "format", "cannot open HDF5 file (truncated or corrupt?)");
  int in = 6;  // (sin theta_h, 0, cos theta_h, d.x, d.y, d.z)
  for (int l = 0; l < 3; ++l) {
    const std::string& name = dense[l].name;
    Layer& layer = layers_[l];
    layer.in = in;
    layer.out = dense[l].units;
    if (layer.out <= 0) {
      throw Error(json_path, "config.layers[" + name + "].units", "missing or not positive");
    }
    const std::string base = "/" + name + "/" + name + "/";
    layer.kernel = ReadDataset(file.get(), h5_path, base + "kernel:0",
                               {static_cast<hsize_t>(layer.in), static_cast<hsize_t>(layer.out)});
    layer.bias =
        ReadDataset(file.get(), h5_path, base + "bias:0", {static_cast<hsize_t>(layer.out)});
    in = layer.out;
  }
}

Vec3d NeuralBrdf::Forward(const std::array<double, 6>& x) const {
  // Hidden widths are 21 in the published networks; 64 leaves room for other fits.
  std::vector<double> a(x.begin(), x.end()), z;
  for (int l = 0; l < 3; ++l) {
    const Layer& layer = layers_[l];
    z.assign(layer.bias.begin(), layer.bias.end());
    for (int i = 0; i < layer.in; ++i) {
      const double ai = a[i];
      const float* row = &layer.kernel[static_cast<std::size_t>(i) * layer.out];
      for (int o = 0; o < layer.out; ++o) z[o] += ai * row[o];
    }
    if (l < 2) {
      for (double& v : z) v = std::max(v, 0.0);  // relu
    }
    a.swap(z);
  }
  // The Lambda output layer: exp(x) - 1 (the networks were trained on log(1 + f)), clamped at 0.
  return {std::max(std::expm1(a[0]), 0.0), std::max(std::expm1(a[1]), 0.0),
          std::max(std::expm1(a[2]), 0.0)};
}

Vec3d NeuralBrdf::EvalAngles(double theta_h, double theta_d, double phi_d) const {
  const std::array<double, 6> x = {std::sin(theta_h),
                                   0.0,
                                   std::cos(theta_h),
                                   std::sin(theta_d) * std::cos(phi_d),
                                   std::sin(theta_d) * std::sin(phi_d),
                                   std::cos(theta_d)};
  return Forward(x);
}

Vec3d NeuralBrdf::Eval(const Vec3d& wi, const Vec3d& wo) const {
  if (wi.z <= 0 || wo.z <= 0) return {0, 0, 0};
  const HalfDiff hd = ToHalfDiff(wi, wo);
  return Forward({std::sin(hd.theta_h), 0.0, std::cos(hd.theta_h), hd.d.x, hd.d.y, hd.d.z});
}

}  // namespace shadefit::reference_images
