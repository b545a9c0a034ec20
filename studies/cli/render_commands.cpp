// info, models and render: the renderer's own subcommands.
#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "commands.h"
#include "shadefit/base/error.h"
#include "shadefit/base/files.h"
#include "shadefit/fit/exposure_pin.h"
#include "shadefit/render/gl_context.h"
#include "shadefit/render/models.h"
#include "shadefit/render/renderer.h"
#include "shadefit/render/scene.h"
#include "shadefit/version.h"

namespace shadefit::cli {

void RegisterInfoCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("info", "Print the EGL device and OpenGL strings in use");
  cmd->callback([] {
    GlContext context;
    const GlDeviceInfo& i = context.info();
    fmt::print("EGL platform : {}\nEGL device   : {} ({})\nGL vendor    : {}\n"
               "GL renderer  : {}\nGL version   : {}\nGLSL version : {}\n",
               i.platform, i.device, i.hardware ? "hardware" : "software", i.gl_vendor,
               i.gl_renderer, i.gl_version, i.glsl_version);
  });
}

void RegisterModelsCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("models", "List every shading model with its parameter table");
  cmd->callback([] {
    for (const ModelInfo& m : AllModels()) {
      fmt::print("{}\n  {}\n", m.name, m.description);
      fmt::print("  {:<14} {:>4} {:>10} {:>10} {:>9}  {}\n", "parameter", "size", "min", "max",
                 "default", "meaning");
      for (const ParamSpec& p : m.params) {
        fmt::print("  {:<14} {:>4} {:>10g} {:>10g} {:>9g}  {}{}\n", p.name, p.size, p.min, p.max,
                   p.default_value, p.description, p.log_scale ? " (fitted in log space)" : "");
      }
      // docs/fitting.md, "Free exposure".
      fmt::print("  with a free exposure, pinned: {}\n\n", fit::ExposurePinOf(m).text);
    }
  });
}

// Writes the G-buffer as one multichannel EXR.
void WriteAov(const std::string& path, const GBuffer& g, const ImageMetadata& meta) {
  Image aov(g.width, g.height, 10);
  for (int y = 0; y < g.height; ++y) {
    for (int x = 0; x < g.width; ++x) {
      const float v[10] = {g.position.at(x, y, 0), g.position.at(x, y, 1), g.position.at(x, y, 2),
                           g.normal.at(x, y, 0),   g.normal.at(x, y, 1),   g.normal.at(x, y, 2),
                           g.view.at(x, y, 0),     g.view.at(x, y, 1),     g.view.at(x, y, 2),
                           g.normal.at(x, y, 3)};
      for (int c = 0; c < 10; ++c) aov.at(x, y, c) = v[c];
    }
  }
  WriteExr(path, aov, meta,
           {"P.X", "P.Y", "P.Z", "N.X", "N.Y", "N.Z", "V.X", "V.Y", "V.Z", "coverage"});
}

void RegisterRenderCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("render", "Render a scene with a shading model to a linear EXR");
  struct Options {
    std::string scene, model = "ggx", output, aov;
    std::vector<std::string> sets;
    float exposure = 0.0f;
    bool no_preview = false;
  };
  auto opt = std::make_shared<Options>();
  cmd->add_option("--scene", opt->scene, "Scene TOML file")->required();
  cmd->add_option("--model", opt->model, "Shading model (see `shadefit models`)");
  cmd->add_option("--set", opt->sets, "Parameter, name=value or name=r,g,b (repeatable)");
  cmd->add_option("-o,--output", opt->output, "Output EXR")->required();
  cmd->add_option("--aov", opt->aov, "Also write the G-buffer (P, N, V, coverage) to this EXR");
  cmd->add_option("--exposure", opt->exposure, "Exposure in stops for the PNG preview");
  cmd->add_flag("--no-preview", opt->no_preview, "Do not write the sRGB PNG preview");
  cmd->callback([opt] {
    if (!std::isfinite(opt->exposure) || std::abs(opt->exposure) > 64) {
      throw Error("", "--exposure", fmt::format("{} stops is not in [-64, 64]", opt->exposure));
    }
    const ModelInfo& model = FindModel(opt->model);
    std::vector<double> params = DefaultParams(model);
    for (const auto& s : opt->sets) SetParamFromString(model, s, "--set", &params);
    const Scene scene = LoadScene(opt->scene);
    GlContext context;
    Renderer renderer(context);
    const Image image = renderer.Render(scene, model.id, params);
    ImageMetadata meta{{"shadefit:model", model.name},
                       {"shadefit:scene", scene.source_text},
                       {"shadefit:version", SHADEFIT_VERSION_STRING},
                       {"shadefit:gl_renderer", context.info().gl_renderer}};
    std::string values;
    for (int i = 0; i < model.ParamCount(); ++i) {
      values += fmt::format("{}{}={:.9g}", i ? " " : "", model.EntryName(i), params[i]);
    }
    meta["shadefit:parameters"] = values;
    // Everything is rendered before anything is written; each write is atomic.
    GBuffer gbuffer;
    if (!opt->aov.empty()) gbuffer = renderer.RenderGBuffer(scene);
    // All or nothing: a preview or AOV that cannot be written takes the EXR with it.
    std::vector<OutputWrite> writes = {
        {opt->output, [&] { WriteExr(opt->output, image, meta); }}};
    const std::string png = std::filesystem::path(opt->output).replace_extension(".png").string();
    if (!opt->no_preview) {
      writes.push_back({png, [&] { WritePngPreview(png, image, opt->exposure); }});
    }
    if (!opt->aov.empty()) writes.push_back({opt->aov, [&] { WriteAov(opt->aov, gbuffer, meta); }});
    WriteAllOrNothing(writes);
    fmt::print("wrote {}\n", opt->output);
  });
}

}  // namespace shadefit::cli
