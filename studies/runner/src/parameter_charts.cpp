// Parameter charts (parameter_charts.h): spheres over a model's two main parameters, one light,
// one exposure. What a chart shows is decided here (axes, values, what is held); the report only
// lays the files out and marks the fits, so it never needs the renderer.
#include "shadefit/studies/parameter_charts.h"

#include <fmt/core.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <optional>
#include <sstream>

#include "shadefit/base/error.h"
#include "shadefit/base/files.h"
#include "shadefit/reference_images/sidecar.h"
#include "shadefit/render/brdf.h"
#include "shadefit/render/gl_context.h"
#include "shadefit/render/image.h"
#include "shadefit/render/models.h"
#include "shadefit/render/renderer.h"
#include "shadefit/render/scene.h"
#include "shadefit/studies/runner.h"

namespace shadefit::studies {
namespace {
namespace fs = std::filesystem;
using json = nlohmann::json;

// Bumped whenever what a chart shows changes, so old manifests are re-rendered.
constexpr int kChartsVersion = 2;
constexpr int kSpherePx = 96;           // Per sphere; the report shows 5 x 5 of them.
constexpr float kExposureStops = 0.0f;  // The references' preview exposure: same brightness.
// Diffuse albedo held under the lobe in the Blinn-Phong charts: dim enough that the highlight
// reads, bright enough to show the sphere.
constexpr double kDiffuseAlbedo = 0.25;
constexpr double kBaseColour = 0.8;     // GGX charts: grey base colour (metals are grey too).
constexpr double kF0Dielectric = 0.04;  // ggx-metallic's default dielectric F0 (models.h).

struct Axis {
  std::string parameter;  // The model's parameter (or "metallic" for the ggx mapping).
  std::vector<double> values;
  bool log = false;  // Values spaced evenly in log: the report draws a log axis.
};

struct ChartDef {
  Axis x, y;
  std::string held;  // What is held constant, for the caption.
  // Parameter vector at (x, y).
  std::function<std::vector<double>(const ModelInfo&, double, double)> params;
};

void Set(const ModelInfo& m, const std::string& name, double v, std::vector<double>* p) {
  SetParam(m, name, {v}, "parameter chart", p);
}

// The chart of a model from its parameter table; nothing for models without two main
// parameters we know how to chart.
std::optional<ChartDef> ChartOf(const ModelInfo& m) {
  // Ranges that hold the shipped materials' fits: near-mirror metals (roughness ~0.05) to rough
  // plastics; dielectric lobes (ks ~ F0 = 0.04) to metals (ks ~ 1).
  const Axis roughness{"roughness", {0.05, 0.2, 0.4, 0.6, 0.8}, false};
  const Axis metallic{"metallic", {0.0, 0.25, 0.5, 0.75, 1.0}, false};
  const Axis shininess{"shininess", {4, 16, 64, 256, 1024}, true};
  const Axis ks{"ks", {0.02, 0.05, 0.15, 0.4, 1.0}, true};
  if (m.Find("metallic") && m.Find("roughness") && m.Find("base_color")) {
    return ChartDef{
        roughness, metallic,
        fmt::format("base colour {:g} grey, f0 of the dielectric {:g}", kBaseColour, kF0Dielectric),
        [](const ModelInfo& mi, double r, double mt) {
          std::vector<double> p = DefaultParams(mi);
          Set(mi, "base_color", kBaseColour, &p);
          Set(mi, "metallic", mt, &p);
          Set(mi, "roughness", r, &p);
          if (mi.Find("f0_dielectric")) Set(mi, "f0_dielectric", kF0Dielectric, &p);
          return p;
        }};
  }
  if (m.Find("kd") && m.Find("f0") && m.Find("roughness")) {
    // Metallic is not a parameter of these models; the chart uses ggx-metallic's mapping
    // (kd = base (1 - m), f0 = mix(0.04, base, m)) so both GGX forms share one chart.
    return ChartDef{roughness, metallic,
                    fmt::format("base colour {:g} grey: kd = base (1 - metallic), f0 = "
                                "mix({:g}, base, metallic)",
                                kBaseColour, kF0Dielectric),
                    [](const ModelInfo& mi, double r, double mt) {
                      std::vector<double> p = DefaultParams(mi);
                      Set(mi, "kd", kBaseColour * (1 - mt), &p);
                      Set(mi, "f0", kF0Dielectric * (1 - mt) + kBaseColour * mt, &p);
                      Set(mi, "roughness", r, &p);
                      return p;
                    }};
  }
  if (m.Find("ks") && m.Find("shininess") && m.Find("kd")) {
    // The classic models' kd multiplies n.l directly (kd = albedo / pi); the normalised one's
    // is the albedo (f = kd / pi), so both show the same diffuse.
    const bool classic = m.Find("ka") != nullptr;
    return ChartDef{shininess, ks,
                    fmt::format("diffuse albedo {:g} grey{}", kDiffuseAlbedo,
                                classic ? " (kd = albedo / pi), no ambient" : ""),
                    [classic](const ModelInfo& mi, double n, double s) {
                      std::vector<double> p = DefaultParams(mi);
                      if (mi.Find("ka")) Set(mi, "ka", 0.0, &p);
                      Set(mi, "kd", classic ? kDiffuseAlbedo / kPi : kDiffuseAlbedo, &p);
                      Set(mi, "ks", s, &p);
                      Set(mi, "shininess", n, &p);
                      return p;
                    }};
  }
  return std::nullopt;
}

// The first key-lit reference's scene, else the first reference's; "" with none.
std::pair<std::string, std::string> ChartScene(const StudySpec& spec) {
  std::pair<std::string, std::string> fallback;
  for (const ReferenceGroup& g : spec.groups) {
    for (const ReferenceSpec& r : g.references) {
      const std::string scene = reference_images::SceneOfSidecar(r.sidecar_path);
      if (scene.empty() || !fs::exists(scene)) continue;
      if (r.lighting == "key") return {scene, r.lighting};
      if (fallback.first.empty()) fallback = {scene, r.lighting};
    }
  }
  return fallback;
}

json AxisJson(const Axis& a) {
  return {{"parameter", a.parameter}, {"values", a.values}, {"scale", a.log ? "log" : "linear"}};
}

// The number of charts of a manifest with this hash whose every image exists; none when the
// charts are to be rendered again.
std::optional<int> UpToDateCharts(const fs::path& manifest, const std::string& study_dir,
                                  const std::string& hash) {
  if (!fs::exists(manifest)) return std::nullopt;
  try {
    std::ifstream in(manifest);
    const json old = json::parse(in);
    bool complete = old.value("hash", "") == hash;
    for (const json& c : old.value("charts", json::array())) {
      for (const json& row : c["images"]) {
        for (const json& f : row)
          complete = complete && fs::exists(fs::path(study_dir) / f.get<std::string>());
      }
    }
    if (complete) return static_cast<int>(old["charts"].size());
  } catch (const json::exception&) {
    // Unreadable manifest: render it again.
  }
  return std::nullopt;
}

// One model's chart images, a row per y value and an image per x value, paths relative to the
// study; `rendered` counts them.
json RenderChartImages(const std::string& name, const ModelInfo& info, const ChartDef& def,
                       const Scene& scene, Renderer& renderer, const std::string& study_dir,
                       int* rendered) {
  json images = json::array();
  for (std::size_t i = 0; i < def.y.values.size(); ++i) {
    json row = json::array();
    for (std::size_t j = 0; j < def.x.values.size(); ++j) {
      const std::vector<double> p = def.params(info, def.x.values[j], def.y.values[i]);
      const std::string rel = fmt::format("charts/{}-{}-{}.png", name, i, j);
      WritePngPreview((fs::path(study_dir) / rel).string(), renderer.Render(scene, info.id, p),
                      kExposureStops);
      row.push_back(rel);
      ++*rendered;
    }
    images.push_back(row);
  }
  return images;
}

}  // namespace

ChartSummary WriteParameterCharts(const StudySpec& spec, const std::string& study_dir) {
  const auto t0 = std::chrono::steady_clock::now();
  ChartSummary summary;
  const auto [scene_path, lighting] = ChartScene(spec);
  if (scene_path.empty()) return summary;
  const fs::path dir = fs::path(study_dir) / "charts";
  const fs::path manifest = dir / "charts.json";

  std::string key = fmt::format("{}|{}|{}|{}|", kChartsVersion, ShadefitVersion(), kSpherePx,
                                Sha256File(scene_path));
  for (ModelRef m : spec.models) key += m->name + ",";
  const std::string hash = Sha256String(key);
  if (const std::optional<int> charts = UpToDateCharts(manifest, study_dir, hash)) {
    summary.charts = *charts;
    return summary;
  }

  Scene scene = LoadScene(scene_path);
  scene.camera.width = kSpherePx;
  scene.camera.height_px = kSpherePx;
  fs::create_directories(dir);
  // A merge of shards may run where no GL device exists: the study's results stand without the
  // charts, so say so and go on (the report then has no chart section).
  std::unique_ptr<GlContext> context;
  try {
    context = std::make_unique<GlContext>();
  } catch (const Error& e) {
    std::fprintf(stderr, "shadefit: parameter charts not rendered: %s\n", e.what());
    return summary;
  }
  Renderer renderer(*context);
  json charts = json::array();
  for (ModelRef model : spec.models) {
    const ModelInfo& info = *model;
    const std::string& name = info.name;
    const std::optional<ChartDef> def = ChartOf(info);
    if (!def) continue;
    const json images =
        RenderChartImages(name, info, *def, scene, renderer, study_dir, &summary.rendered);
    charts.push_back({{"model", name},
                      {"x", AxisJson(def->x)},
                      {"y", AxisJson(def->y)},
                      {"held", def->held},
                      {"images", images}});
  }
  summary.charts = static_cast<int>(charts.size());
  const json out = {{"schema", "shadefit.study.charts/1"},
                    {"hash", hash},
                    {"shadefit_version", ShadefitVersion()},
                    {"scene", scene_path},
                    {"lighting", lighting},
                    {"exposure_stops", kExposureStops},
                    {"sphere_px", kSpherePx},
                    {"charts", charts}};
  WriteTextAtomic(manifest.string(), out.dump(1));
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return summary;
}

}  // namespace shadefit::studies
