// Reading a reference from files: image, sidecar JSON, scene TOML, optional mask.
#include "shadefit/reference_images/reference.h"

#include "shadefit/render/shadows.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "shadefit/base/error.h"
#include "shadefit/base/files.h"
#include "shadefit/reference_images/sidecar.h"
#include "sidecar_fields.h"

namespace shadefit::reference_images {
namespace fs = std::filesystem;
namespace {

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

// EXR and Radiance HDR hold linear radiance; every other format is a display image.
bool IsLinearFormat(const std::string& path) {
  const std::string ext = Lower(fs::path(path).extension().string());
  return ext == ".exr" || ext == ".hdr";
}

// 8-bit code values >= 254 count as clipped: 255 is certainly saturated, and 254 can be a
// rounded saturated value after a camera's or encoder's tone curve.
constexpr float kClippedCode = 254.0f / 255.0f;

// The sidecar's "measured_domain" (MakeMeasuredReference, render_measured.h) into `ref`, whose
// image is read: the domain file must be a 1-channel image of the same size with values in
// [0, 1].
void ReadMeasuredDomain(const nlohmann::json& domain, const fs::path& sidecar, Reference* ref) {
  if (!domain.is_object()) throw Error(sidecar.string(), "measured_domain", "expected an object");
  if (!domain.contains("file") || !domain["file"].is_string()) {
    throw Error(sidecar.string(), "measured_domain.file", "missing or not a string");
  }
  if (!domain.contains("measured_share_max") || !domain["measured_share_max"].is_number() ||
      !(domain["measured_share_max"].get<double>() >= 0.0 &&
        domain["measured_share_max"].get<double>() <= 1.0)) {
    throw Error(sidecar.string(), "measured_domain.measured_share_max",
                "missing or not a number in [0, 1]");
  }
  fs::path path(domain["file"].get<std::string>());
  if (path.is_relative()) path = sidecar.parent_path() / path;
  const std::string file = path.lexically_normal().string();
  if (!fs::is_regular_file(file)) {
    throw Error(sidecar.string(), "measured_domain.file",
                fmt::format("domain file '{}' does not exist", file));
  }
  Image share = ReadImage(file);
  if (share.channels != 1) {
    throw Error(file, "channels",
                fmt::format("a measured domain has 1 channel, got {}", share.channels));
  }
  if (share.width != ref->image.width || share.height != ref->image.height) {
    throw Error(file, "resolution",
                fmt::format("domain is {}x{} but the reference {} is {}x{}", share.width,
                            share.height, ref->image_path, ref->image.width, ref->image.height));
  }
  for (std::size_t i = 0; i < share.data.size(); ++i) {
    const float v = share.data[i];
    if (!(v >= 0.0f && v <= 1.0f)) {
      throw Error(file, "pixels",
                  fmt::format("share {} at ({}, {}) is not in [0, 1]", v, i % share.width,
                              i / share.width));
    }
  }
  ref->extrapolated_share = std::move(share);
  ref->measured_share_max = domain["measured_share_max"].get<double>();
  ref->domain_path = file;
  ref->sha256["domain"] = Sha256File(file);
}

}  // namespace

bool IsMeasuredPixel(const Reference& ref, int x, int y) {
  if (!ref.shadow_edge.empty() && ref.shadow_edge.at(x, y, 0) > 0.5f) return false;
  if (!ref.interreflection.empty() && ref.interreflection.at(x, y, 0) > 0.5f) return false;
  return ref.extrapolated_share.empty() ||
         ref.extrapolated_share.at(x, y, 0) <= ref.measured_share_max;
}

namespace {

// The scene the reference's sidecar names (scene_file, relative to the sidecar), with the
// sidecar's record of the decoding and of the measured domain.
void ReadSidecarScene(const fs::path& sidecar, Reference* ref) {
  if (!PathExists(sidecar)) {
    throw Error(sidecar.string(), "",
                "missing sidecar JSON (it names the reference's scene; or give --scene)");
  }
  ref->sidecar_path = sidecar.string();
  nlohmann::json meta;
  try {
    std::ifstream in(sidecar);
    meta = nlohmann::json::parse(in);
  } catch (const std::exception& e) {
    throw Error(sidecar.string(), "json", fmt::format("cannot parse: {}", e.what()));
  }
  ref->sha256["sidecar"] = Sha256File(sidecar.string());
  // `shadefit refs import` records how it decoded the source (import.cpp).
  if (meta.is_object() && meta.contains("encoding") && meta["encoding"] == "srgb") {
    ref->decoded_from = Encoding::kSrgb;
  }
  const std::string scene_field = internal::SceneFieldOf(meta);
  if (scene_field.empty()) {
    throw Error(sidecar.string(), "scene_file",
                "missing: the sidecar must name the scene TOML (or give --scene)");
  }
  fs::path scene_path(scene_field);
  if (scene_path.is_relative()) scene_path = sidecar.parent_path() / scene_path;
  if (!PathExists(scene_path)) {
    throw Error(sidecar.string(), "scene_file",
                fmt::format("scene '{}' does not exist", scene_path.string()));
  }
  ref->scene_path = scene_path.lexically_normal().string();
  if (meta.contains("measured_domain")) ReadMeasuredDomain(meta["measured_domain"], sidecar, ref);
  // Direct light only: stated, a measured render, or a Cycles render without bounces.
  const auto is_true = [&](const nlohmann::json& j, const char* key) {
    return j.is_object() && j.contains(key) && j[key].is_boolean() && j[key].get<bool>();
  };
  const auto is_zero = [&](const nlohmann::json& j, const char* key) {
    return j.is_object() && j.contains(key) && j[key].is_number() && j[key].get<double>() == 0;
  };
  ref->direct_light_only = is_true(meta, "direct_light_only") ||
                           meta.contains("measured_domain") ||
                           (meta.contains("cycles") && is_zero(meta["cycles"], "max_bounces"));
}

}  // namespace

Reference LoadReference(const std::string& image_path, const std::string& scene_override,
                        const std::string& mask_path) {
  Reference ref;
  ref.image_path = image_path;
  ref.name = fs::path(image_path).stem().string();
  if (!PathExists(image_path)) throw Error(image_path, "", "reference image does not exist");
  ref.image = ReadImage(image_path);
  ref.sha256["image"] = Sha256File(image_path);
  if (ref.image.channels < 3) {
    throw Error(image_path, "channels",
                fmt::format("expected RGB or RGBA, got {} channel(s)", ref.image.channels));
  }
  if (!IsLinearFormat(image_path)) {
    // Display image: decode the sRGB transfer function; remember the clip level (linear).
    for (int y = 0; y < ref.image.height; ++y) {
      for (int x = 0; x < ref.image.width; ++x) {
        for (int c = 0; c < 3; ++c) ref.image.at(x, y, c) = SrgbToLinear(ref.image.at(x, y, c));
      }
    }
    ref.clip_level = SrgbToLinear(kClippedCode) * (1.0f - 1e-6f);
    ref.decoded_from = Encoding::kSrgb;
  }

  // The scene: --scene, else the sidecar's scene_file resolved relative to the sidecar.
  const fs::path sidecar = SidecarPathFor(image_path);
  if (!scene_override.empty()) {
    ref.scene_path = scene_override;
  } else {
    ReadSidecarScene(sidecar, &ref);
  }
  if (!PathExists(ref.scene_path)) throw Error(ref.scene_path, "", "scene does not exist");
  ref.scene = LoadScene(ref.scene_path);
  ref.sha256["scene"] = Sha256File(ref.scene_path);
  // Objects' shadow edges are outside what the renderer reproduces (docs/scenes.md, "Shadows").
  ref.shadow_edge = ShadowEdgeMask(ref.scene);
  // ... and so is strong interreflection, where the reference may hold it.
  if (ref.scene.HasSurfaceObjects() && !ref.direct_light_only) {
    const Image share = SelfOcclusion(ref.scene);
    ref.interreflection = Image(share.width, share.height, 1);
    for (std::size_t i = 0; i < share.data.size(); ++i) {
      ref.interreflection.data[i] = share.data[i] > kInterreflectionShareMax ? 1.0f : 0.0f;
    }
  }
  if (ref.scene.camera.width != ref.image.width || ref.scene.camera.height_px != ref.image.height) {
    throw Error(
        image_path, "resolution",
        fmt::format("image is {}x{} but scene {} renders {}x{}", ref.image.width, ref.image.height,
                    ref.scene_path, ref.scene.camera.width, ref.scene.camera.height_px));
  }

  if (!mask_path.empty()) {
    if (!PathExists(mask_path)) throw Error(mask_path, "", "mask does not exist");
    ref.mask_path = mask_path;
    ref.mask = ReadImage(mask_path);
    ref.sha256["mask"] = Sha256File(mask_path);
    if (ref.mask.width != ref.image.width || ref.mask.height != ref.image.height) {
      throw Error(mask_path, "resolution",
                  fmt::format("mask is {}x{} but the reference {} is {}x{}", ref.mask.width,
                              ref.mask.height, image_path, ref.image.width, ref.image.height));
    }
  }
  return ref;
}

}  // namespace shadefit::reference_images
