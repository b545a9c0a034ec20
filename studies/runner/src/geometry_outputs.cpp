#include "geometry_outputs.h"

#include <fmt/core.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>

#include "shadefit/base/error.h"
#include "shadefit/base/files.h"
#include "shadefit/reference_images/reference.h"
#include "shadefit/render/gbuffer.h"

namespace shadefit::studies::internal {
namespace {
using json = nlohmann::json;

// The fixed columns of a row; then, per light slot, lx ly lz Er Eg Eb (all 0 where the light is
// below the surface or occluded). "train": coverage 1, inside the reference's mask and not
// clipped (the pixels a fit trains on, fit/src/prepared_reference.cpp); every row is covered
// (reference alpha > 0.5, or every pixel of an RGB reference): the pixels its metrics use.
const std::vector<std::string> kColumns = {"x",  "y",  "coverage", "train", "r",  "g", "b",
                                           "nx", "ny", "nz",       "vx",    "vy", "vz"};
constexpr int kLightColumns = 6;

// A little-endian float32 C-order .npy file (NumPy's format, version 1.0): a reader needs numpy
// alone, and the bytes depend on the values only.
std::string NpyBytes(const std::vector<float>& data, std::size_t rows, std::size_t cols) {
  std::string header =
      fmt::format("{{'descr': '<f4', 'fortran_order': False, 'shape': ({}, {}), }}", rows, cols);
  const std::size_t preamble = 10;  // magic (6) + version (2) + header length (2)
  const std::size_t total = (preamble + header.size() + 1 + 63) / 64 * 64;
  header.append(total - preamble - header.size() - 1, ' ');
  header.push_back('\n');
  std::string out("\x93NUMPY\x01\x00", 8);
  const auto n = static_cast<std::uint16_t>(header.size());
  out.push_back(static_cast<char>(n & 0xff));
  out.push_back(static_cast<char>(n >> 8));
  out += header;
  const std::size_t offset = out.size();
  out.resize(offset + data.size() * sizeof(float));
  std::memcpy(out.data() + offset, data.data(), data.size() * sizeof(float));  // x86: little-endian
  return out;
}

json LightJson(const Light& light) {
  auto v = [](const Vec3d& a) { return json::array({a.x, a.y, a.z}); };
  switch (light.type) {
    case Light::Type::kPoint:
      return {{"type", "point"}, {"position", v(light.position)}, {"intensity", v(light.value)}};
    case Light::Type::kDirectional:
      return {{"type", "directional"},
              {"direction", v(light.direction)},
              {"irradiance", v(light.value)}};
    case Light::Type::kAmbient:
      return {{"type", "ambient"}, {"radiance", v(light.value)}};
    default:
      return {{"type", "environment"}};
  }
}

// Why the floor cannot use this scene ("" when it can): its fit needs lights the tabulated BRDF
// sees one direction at a time.
std::string SkipReason(const Scene& scene) {
  if (!TwinSupportsScene(scene))
    return "environment or uniform light (not one direction per light)";
  for (const Light& l : scene.lights) {
    if (l.type == Light::Type::kAmbient && (l.value.x > 0 || l.value.y > 0 || l.value.z > 0)) {
      return "ambient light (a model's ka term, not a BRDF value)";
    }
  }
  return "";
}

// The rows of one reference (see kColumns), and how many light slots they hold.
std::vector<float> GeometryRows(const reference_images::Reference& ref, const GBuffer& g,
                                std::size_t* rows, int* slots) {
  const Image& im = ref.image;
  const std::vector<ShadingPoint> points = PrepareShading(ref.scene, g, 0.0f);
  // Each pixel's shading point, if it has one (an index into points, or -1).
  std::vector<int> point_at(static_cast<std::size_t>(im.width) * im.height, -1);
  *slots = 0;
  for (std::size_t k = 0; k < points.size(); ++k) {
    const ShadingPoint& sp = points[k];
    *slots = std::max<int>(*slots, static_cast<int>(sp.lights.size()));
    if (sp.x < 0 || sp.y < 0 || sp.x >= im.width || sp.y >= im.height) continue;
    int& at = point_at[static_cast<std::size_t>(sp.y) * im.width + sp.x];
    if (at < 0) at = static_cast<int>(k);  // The first point of a pixel, as before.
  }
  const std::size_t cols = kColumns.size() + static_cast<std::size_t>(kLightColumns * *slots);
  std::vector<float> out;
  *rows = 0;
  for (int y = 0; y < im.height; ++y) {
    for (int x = 0; x < im.width; ++x) {
      if (im.channels >= 4 && !(im.at(x, y, 3) > 0.5f)) continue;
      out.resize(out.size() + cols, 0.0f);
      float* row = out.data() + out.size() - cols;
      row[0] = static_cast<float>(x);
      row[1] = static_cast<float>(y);
      bool clipped = false;
      for (int c = 0; c < 3; ++c) {
        row[4 + c] = im.at(x, y, c);
        clipped = clipped || !std::isfinite(im.at(x, y, c)) || im.at(x, y, c) >= ref.clip_level;
      }
      const int at = point_at[static_cast<std::size_t>(y) * im.width + x];
      if (at >= 0) {
        const ShadingPoint& sp = points[static_cast<std::size_t>(at)];
        row[2] = g.Coverage(x, y);
        const bool full = im.channels < 4 || im.at(x, y, 3) >= 1.0f;
        const bool masked = ref.mask.empty() || ref.mask.at(x, y, 0) > 0.5f;
        row[3] = (row[2] >= 1.0f && full && masked && !clipped) ? 1.0f : 0.0f;
        const Vec3d n = sp.n, v = sp.v;
        const double nv[6] = {n.x, n.y, n.z, v.x, v.y, v.z};
        for (int k = 0; k < 6; ++k) row[7 + k] = static_cast<float>(nv[k]);
        for (std::size_t i = 0; i < sp.lights.size(); ++i) {
          const PixelLight& pl = sp.lights[i];
          const double lv[6] = {pl.l.x,          pl.l.y,          pl.l.z,
                                pl.irradiance.x, pl.irradiance.y, pl.irradiance.z};
          for (int k = 0; k < 6; ++k)
            row[kColumns.size() + kLightColumns * i + k] = static_cast<float>(lv[k]);
        }
      }
      ++*rows;
    }
  }
  return out;
}

}  // namespace

bool WritesGeometry(const StudySpec& spec) {
  if (spec.floor.has_value()) return *spec.floor;
  return std::any_of(spec.model_settings.begin(), spec.model_settings.end(),
                     [](const auto& m) { return m.second.exposure == fit::Exposure::kFree; });
}

void WriteGeometry(const RunContext& context, Renderer& renderer) {
  const std::filesystem::path dir = context.paths.dir / "geometry";
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw Error(dir.string(), "", "cannot create directory: " + ec.message());
  json refs_json = json::array();
  for (const ReferenceGroup& group : context.spec.groups) {
    for (const ReferenceSpec& rs : group.references) {
      const std::shared_ptr<const reference_images::Reference> shared =
          context.Reference(rs.image_path);
      const reference_images::Reference& ref = *shared;
      // decoded_from: how the values were decoded from the stored ones (sRGB or linear), so that
      // the floor can take the decoding a fit with encoding = "fit" chose instead.
      json e = {{"reference", rs.name},
                {"material", group.material},
                {"lighting", rs.lighting},
                {"decoded_from", reference_images::EncodingName(ref.decoded_from)}};
      if (!group.object.empty()) e["object"] = group.object;  // The report's floor per object.
      json lights = json::array();
      for (const Light& l : ref.scene.lights) lights.push_back(LightJson(l));
      e["lights"] = lights;
      const std::string why = SkipReason(ref.scene);
      if (!why.empty()) {
        e["skipped"] = why;
        context.log->Line(fmt::format("geometry: {} skipped: {}", rs.name, why));
        refs_json.push_back(e);
        continue;
      }
      const GBuffer g = renderer.RenderGBuffer(ref.scene);
      std::size_t rows = 0;
      int slots = 0;
      const std::vector<float> data = GeometryRows(ref, g, &rows, &slots);
      const std::string file = fmt::format("geometry/{}.npy", rs.name);
      WriteTextAtomic((context.paths.dir / file).string(),
                      NpyBytes(data, rows, kColumns.size() + kLightColumns * slots));
      e.update({{"file", file},
                {"width", ref.image.width},
                {"height", ref.image.height},
                {"rows", rows},
                {"light_slots", slots}});
      refs_json.push_back(e);
    }
  }
  const json index = {{"schema", "shadefit.study.geometry/1"},
                      {"columns", kColumns},
                      {"light_columns", {"lx", "ly", "lz", "Er", "Eg", "Eb"}},
                      {"values",
                       "the reference as loaded (linear, as imported; no fitted "
                       "encoding); a pixel's radiance is sum over light slots of "
                       "f(l, v) (n.l) E, times its coverage"},
                      {"references", refs_json}};
  WriteTextAtomic((dir / "index.json").string(), index.dump(1) + "\n");
}

}  // namespace shadefit::studies::internal
