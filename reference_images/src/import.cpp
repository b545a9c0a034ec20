#include "shadefit/reference_images/import.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <vector>

#include "shadefit/base/files.h"
#include "shadefit/reference_images/render_measured.h"
#include "shadefit/base/error.h"
#include "shadefit/base/statistics.h"

namespace shadefit::reference_images {
namespace {

namespace fs = std::filesystem;

std::string StripPrefix(const std::string& message, const std::string& path) {
  const std::string prefix = path + ": ";
  return message.rfind(prefix, 0) == 0 ? message.substr(prefix.size()) : message;
}

nlohmann::json FileRecord(const std::string& path) {
  return {{"path", fs::absolute(path).lexically_normal().string()}, {"sha256", Sha256File(path)}};
}

}  // namespace

Encoding ParseEncoding(const std::string& name) {
  if (name == "auto") return Encoding::kAuto;
  if (name == "srgb") return Encoding::kSrgb;
  if (name == "linear") return Encoding::kLinear;
  throw Error("", "encoding", "\"" + name + "\": expected auto, srgb or linear");
}

std::string EncodingName(Encoding e) {
  return e == Encoding::kSrgb ? "srgb" : e == Encoding::kLinear ? "linear" : "auto";
}

LoadedImage LoadImageForImport(const std::string& path) {
  if (!PathExists(path)) throw Error(path, "image", "file not found");
  if (KindOfPath(path, "image") != PathKind::kFile) throw Error(path, "image", "not a regular file");
  LoadedImage out;
  CheckImageHeader(path);
  {
    StderrCapture quiet;  // libpng's own error lines: the Error says it in one line
    ImageFileInfo info;
    std::string error;
    if (!ReadImageInfo(path, &info, &error)) {
      quiet.Discard();
      throw Error(path, "image", "cannot read image: " + OneLine(error));
    }
    out.is_float = info.is_float;
    out.format = info.format;
    out.file_channels = info.channels;
  }
  if (out.file_channels != 1 && out.file_channels != 3 && out.file_channels != 4) {
    throw Error(path, "channels",
                fmt::format("{} channels; expected 1 (grey), 3 (RGB) or 4 (RGBA, alpha ignored)",
                            out.file_channels));
  }
  Image raw;  // ReadImage also rejects JPEG and PNG files cut short (render/src/image.cpp).
  try {
    raw = ReadImage(path);
  } catch (const Error& e) {
    // Keep ReadImage's field when it names one ("pixels" for truncated data).
    const std::string rest = OneLine(StripPrefix(e.what(), path));
    if (rest.rfind("pixels: ", 0) == 0) throw Error(path, "pixels", rest.substr(8));
    throw Error(path, "image", rest);
  }
  out.rgb = Image(raw.width, raw.height, 3);
  for (int y = 0; y < raw.height; ++y) {
    for (int x = 0; x < raw.width; ++x) {
      for (int c = 0; c < 3; ++c) {
        const float v = raw.at(x, y, raw.channels == 1 ? 0 : c);
        if (!std::isfinite(v)) {
          throw Error(path, "pixels",
                      fmt::format("{} at pixel ({}, {}) channel {}", std::isnan(v) ? "NaN" : "Inf",
                                  x, y, c));
        }
        out.rgb.at(x, y, c) = v;
      }
    }
  }
  return out;
}

Image DecodeToLinear(const LoadedImage& loaded, Encoding encoding, Encoding* applied) {
  const Encoding e = encoding != Encoding::kAuto
                         ? encoding
                         : (loaded.is_float ? Encoding::kLinear : Encoding::kSrgb);
  if (applied) *applied = e;
  Image linear = loaded.rgb;
  if (e == Encoding::kSrgb) {
    for (float& v : linear.data) v = SrgbToLinear(v);
  }
  return linear;
}

double DisplayWhite(const LoadedImage& loaded, const Image& linear) {
  // Integer files are already display-referred: full scale is 1.
  if (!loaded.is_float) return 1.0;
  std::vector<float> lum(linear.PixelCount());
  for (std::size_t i = 0; i < lum.size(); ++i) {
    lum[i] = 0.2126f * linear.data[3 * i] + 0.7152f * linear.data[3 * i + 1] +
             0.0722f * linear.data[3 * i + 2];
  }
  return std::max(1e-12, static_cast<double>(Percentile(lum, 0.995)));
}

namespace {

// Validates the request before touching any input.
void CheckImportRequest(const ImportOptions& options) {
  if (options.output.empty()) throw Error("", "output", "no output file given");
  if (fs::path(options.output).extension() != ".exr") {
    throw Error(options.output, "output", "the output must be an .exr file");
  }
  const fs::path out_dir = fs::path(options.output).parent_path();
  if (!out_dir.empty() && !fs::is_directory(out_dir)) {
    throw Error(options.output, "output", "output directory does not exist");
  }
  if (options.auto_sphere == !options.scene_path.empty()) {
    throw Error("", "scene", "give exactly one of --scene and --auto-sphere");
  }
  if (options.clip_threshold < 1 || options.clip_threshold > 256) {
    throw Error(
        "", "clip-threshold",
        fmt::format("{} is outside [1, 256] (256 disables clipping)", options.clip_threshold));
  }
  if (!options.scene_path.empty() && !PathExists(options.scene_path)) {
    throw Error(options.scene_path, "scene", "file not found");
  }
  if (!options.mask_path.empty() && !PathExists(options.mask_path)) {
    throw Error(options.mask_path, "mask", "file not found");
  }
}

// The --mask image (empty without one), checked to be the image's size.
Image ReadImportMask(const ImportOptions& options, const Image& raw) {
  Image mask;
  if (!options.mask_path.empty()) {
    try {
      mask = ReadImage(options.mask_path);
    } catch (const Error& e) {
      throw Error(options.mask_path, "mask", OneLine(StripPrefix(e.what(), options.mask_path)));
    }
    if (mask.width != raw.width || mask.height != raw.height) {
      throw Error(options.mask_path, "resolution",
                  fmt::format("mask is {}x{}, the image {} is {}x{}", mask.width, mask.height,
                              options.image_path, raw.width, raw.height));
    }
  }
  return mask;
}

// The scene of the image: --scene, or with --auto-sphere one made from the detected sphere (its
// TOML in `scene_toml_text`, its estimate in `result`); its camera must match the image.
Scene ImportScene(const ImportOptions& options, const LoadedImage& loaded, const Image& linear,
                  const Image& mask, ImportResult* result, std::string* scene_toml_text) {
  const Image& raw = loaded.rgb;
  Scene scene;
  if (options.auto_sphere) {
    // With --mask the sphere is the mask's disc (DetectSphere): the user has said where it is.
    result->sphere = DetectSphere(linear, DisplayWhite(loaded, linear), options.image_path,
                                  mask.empty() ? nullptr : &mask);
    result->has_sphere = true;
    result->scene_path = fs::path(options.output).replace_extension(".toml").string();
    *scene_toml_text = OrthographicSphereSceneToml(
        result->sphere, raw.width, raw.height, fs::path(options.image_path).filename().string());
    scene = ParseScene(*scene_toml_text, result->scene_path);
    scene.path = result->scene_path;
  } else {
    scene = LoadScene(options.scene_path);
    result->scene_path = options.scene_path;
  }
  if (scene.camera.width != raw.width || scene.camera.height_px != raw.height) {
    throw Error(options.image_path, "resolution",
                fmt::format("image is {}x{}, the camera of {} is {}x{}", raw.width, raw.height,
                            result->scene_path, scene.camera.width, scene.camera.height_px));
  }
  return scene;
}

// Validity, coverage, counts: result->image's RGB is the linear value where valid (0 elsewhere),
// its A validity x G-buffer coverage. `clip_rule`: pixels at or above the clip threshold are
// invalid.
void MarkValidPixels(const ImportOptions& options, const Image& raw, const Image& linear,
                     const Image& mask, const GBuffer& gbuffer, bool clip_rule,
                     ImportResult* result) {
  ImportCounts& n = result->counts;
  result->image = Image(raw.width, raw.height, 4);
  // The decoded value of code c is c / 255 (16-bit files: c / 65535, compared on the same scale).
  const double clip_level = options.clip_threshold / 255.0 - 0.25 / 255.0;
  for (int y = 0; y < raw.height; ++y) {
    for (int x = 0; x < raw.width; ++x) {
      ++n.total;
      bool valid = true;
      if (!mask.empty() && !(mask.at(x, y, 0) > 0.5f)) {
        ++n.masked_out;
        valid = false;
      }
      if (valid && clip_rule) {
        for (int c = 0; c < 3; ++c) {
          if (raw.at(x, y, c) >= clip_level) valid = false;
        }
        if (!valid) ++n.clipped;
      }
      const float coverage = gbuffer.Coverage(x, y);
      if (coverage > 0) ++n.covered;
      if (valid) {
        ++n.valid;
        if (coverage > 0) ++n.valid_covered;
        for (int c = 0; c < 3; ++c) result->image.at(x, y, c) = linear.at(x, y, c);
        result->image.at(x, y, 3) = coverage;
      }
    }
  }
  if (n.valid_covered == 0) {
    throw Error(options.image_path, "pixels",
                "no valid pixel on the object (all masked out, clipped or off the object)");
  }
}

// The sidecar's record of an --auto-sphere estimate.
nlohmann::json AutoSphereJson(const ImportOptions& options, const SphereEstimate& s) {
  return {
      {"center_px", {s.center_x, s.center_y}},
      {"radius_px", s.radius},
      {"found_by", s.found_by},
      {"contour_points_used", s.contour_points_used},
      {"fit_rms_px", s.fit_rms_px},
      {"light_found", s.light_found},
      {"highlight_px", {s.highlight_x, s.highlight_y}},
      {"light_direction_to_light", {s.light_direction.x, s.light_direction.y, s.light_direction.z}},
      {"assumptions",
       options.mask_path.empty()
           ? "one sphere, orthographic view, differing from the background; the light is "
             "the mirror of the view about the normal at the highlight (initial guess)"
           : "the sphere is the mask's disc, orthographic view; the light is the mirror of "
             "the view about the normal at the highlight (initial guess)"}};
}

// The sidecar: where the image came from, how it was decoded and which pixels count.
nlohmann::json ImportSidecar(const ImportOptions& options, const LoadedImage& loaded,
                             const Scene& scene, bool clip_rule, const ImportResult& result) {
  const ImportCounts& n = result.counts;
  nlohmann::json sidecar;
  sidecar["kind"] = "imported";
  sidecar["generator"] = "shadefit refs import";
  sidecar["source"] = FileRecord(options.image_path);
  sidecar["source"]["format"] = loaded.format;
  sidecar["source"]["channels"] = loaded.file_channels;
  sidecar["encoding"] = EncodingName(result.encoding);
  sidecar["clip_threshold"] = options.clip_threshold;
  sidecar["clip_rule"] = clip_rule ? fmt::format("a pixel is excluded when any channel >= {}/255",
                                                 options.clip_threshold)
                                   : std::string("not applied (float input or threshold 256)");
  sidecar["mask"] =
      options.mask_path.empty() ? nlohmann::json(nullptr) : FileRecord(options.mask_path);
  sidecar["scene_file"] = fs::absolute(result.scene_path).lexically_normal().string();
  sidecar["scene_sha256"] = Sha256String(scene.source_text);
  sidecar["counts"] = {{"total", n.total},     {"masked_out", n.masked_out},
                       {"clipped", n.clipped}, {"valid", n.valid},
                       {"covered", n.covered}, {"valid_covered", n.valid_covered}};
  sidecar["exposure"] = "unknown";
  sidecar["notes"] =
      "Exposure and white balance of the source are unknown: a fit must free a global scale. "
      "RGB = linear value where valid (0 elsewhere); A = validity x G-buffer coverage.";
  if (result.has_sphere) sidecar["auto_sphere"] = AutoSphereJson(options, result.sphere);
  if (options.direct_light_only) sidecar["direct_light_only"] = true;
  return sidecar;
}

// Writes the image, its sidecar and a made scene: each file atomically, all or nothing
// (base/files.h).
void WriteImport(const ImportOptions& options, const ImportResult& result, const Scene& scene,
                 const std::string& scene_toml_text, const nlohmann::json& sidecar) {
  ImageMetadata meta{{"shadefit:kind", "imported"},
                     {"shadefit:source", fs::path(options.image_path).filename().string()},
                     {"shadefit:encoding", EncodingName(result.encoding)},
                     {"shadefit:exposure", "unknown"},
                     {"shadefit:scene", scene.source_text}};
  std::vector<OutputWrite> writes;
  if (result.has_sphere) {
    writes.push_back(
        {result.scene_path, [&] { WriteTextAtomic(result.scene_path, scene_toml_text); }});
  }
  writes.push_back({options.output, [&] { WriteExr(options.output, result.image, meta); }});
  const std::string sidecar_path = SidecarPath(options.output);
  writes.push_back(
      {sidecar_path, [&] { WriteTextAtomic(sidecar_path, sidecar.dump(1) + "\n"); }});
  WriteAllOrNothing(writes);
}

}  // namespace

ImportResult ImportReference(const ImportOptions& options, Renderer& renderer) {
  CheckImportRequest(options);
  const LoadedImage loaded = LoadImageForImport(options.image_path);
  ImportResult result;
  const Image linear = DecodeToLinear(loaded, options.encoding, &result.encoding);
  const Image mask = ReadImportMask(options, loaded.rgb);
  std::string scene_toml_text;
  const Scene scene = ImportScene(options, loaded, linear, mask, &result, &scene_toml_text);
  const GBuffer gbuffer = renderer.RenderGBuffer(scene);
  const bool clip_rule = !loaded.is_float && options.clip_threshold <= 255;
  MarkValidPixels(options, loaded.rgb, linear, mask, gbuffer, clip_rule, &result);
  const nlohmann::json sidecar = ImportSidecar(options, loaded, scene, clip_rule, result);
  WriteImport(options, result, scene, scene_toml_text, sidecar);
  return result;
}

}  // namespace shadefit::reference_images
