#include "probe_common.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "shadefit/render/brdf.h"
#include "shadefit/base/error.h"
#include "shadefit/base/statistics.h"

namespace shadefit::probes {

void ValidateReference(const ProbeReference& reference, double min_coverage) {
  const std::string& name = reference.name.empty() ? std::string("reference") : reference.name;
  const Image& image = reference.image;
  if (image.empty()) throw Error(name, "image", "empty image");
  if (image.channels < 4) {
    throw Error(name, "image",
                fmt::format("expected RGBA (alpha = coverage), got {} channel(s)", image.channels));
  }
  const GBuffer& g = reference.gbuffer;
  if (g.width <= 0 || g.height <= 0 || g.normal.empty() || g.position.empty() || g.view.empty()) {
    throw Error(name, "gbuffer", "empty G-buffer (render it with Renderer::RenderGBuffer)");
  }
  if (image.width != g.width || image.height != g.height) {
    throw Error(name, "image",
                fmt::format("size {}x{} differs from the G-buffer's {}x{}", image.width,
                            image.height, g.width, g.height));
  }
  const Camera& c = reference.scene.camera;
  if (image.width != c.width || image.height != c.height_px) {
    throw Error(name, "scene.camera.resolution",
                fmt::format("{}x{} differs from the image's {}x{}", c.width, c.height_px,
                            image.width, image.height));
  }
  std::size_t valid = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      for (int ch = 0; ch < image.channels; ++ch) {
        if (!std::isfinite(image.at(x, y, ch))) {
          throw Error(name, "image",
                      fmt::format("non-finite value at pixel ({}, {}) channel {}", x, y, ch));
        }
      }
      if (image.at(x, y, 3) >= min_coverage && g.Hit(x, y)) ++valid;
    }
  }
  if (valid == 0) {
    throw Error(name, "image",
                fmt::format("empty mask: no pixel with coverage >= {} on an object", min_coverage));
  }
}

ModelRenders::Key ModelRenders::KeyOf(const ModelUnderTest& model,
                                      const ProbeReference& reference) {
  return {model.label, model.model ? model.model->name : std::string(), reference.name,
          model.params, model.exposure};
}

const Image* ModelRenders::Find(const ModelUnderTest& model,
                                const ProbeReference& reference) const {
  const auto it = renders_.find(KeyOf(model, reference));
  return it == renders_.end() ? nullptr : &it->second;
}

void ModelRenders::Keep(const ModelUnderTest& model, const ProbeReference& reference,
                        const Image& image) {
  const std::size_t bytes = image.data.size() * sizeof(float);
  if (bytes_ + bytes > budget_) return;
  if (renders_.try_emplace(KeyOf(model, reference), image).second) bytes_ += bytes;
}

namespace internal {

const ModelInfo& ValidateModel(const ModelUnderTest& model) {
  const std::string& label = model.label.empty() ? std::string("model") : model.label;
  if (model.label.empty()) throw Error(label, "label", "empty label");
  if (!model.model) throw Error(label, "model", "no model given");
  const ModelInfo* info = &*model.model;
  if (static_cast<int>(model.params.size()) != info->ParamCount()) {
    throw Error(label, "params",
                fmt::format("model {} takes {} values, got {}", info->name, info->ParamCount(),
                            model.params.size()));
  }
  for (int i = 0; i < info->ParamCount(); ++i) {
    const double v = model.params[i];
    const ParamSpec& spec = info->SpecOfEntry(i);
    if (!std::isfinite(v) || v < spec.min || v > spec.max) {
      throw Error(label, "params." + info->EntryName(i),
                  fmt::format("value {} outside [{}, {}]", v, spec.min, spec.max));
    }
  }
  if (!std::isfinite(model.exposure) || model.exposure <= 0) {
    throw Error(label, "exposure", fmt::format("must be finite and > 0, got {}", model.exposure));
  }
  return *info;
}

Image RenderModel(const ProbeInputs& inputs, const ModelUnderTest& model,
                  const ProbeReference& reference) {
  const ModelInfo& info = ValidateModel(model);
  if (inputs.renders != nullptr) {
    if (const Image* kept = inputs.renders->Find(model, reference)) return *kept;
  }
  Image image;
  if (inputs.renderer != nullptr) {
    image = inputs.renderer->Render(reference.scene, info.id, model.params);
  } else {
    if (!TwinSupportsScene(reference.scene)) {
      throw Error(model.label, "renderer",
                  fmt::format("reference {} has environment/uniform light: needs the GL renderer",
                              reference.name));
    }
    image = ShadeGBuffer(reference.scene, reference.gbuffer, info.id, model.params);
  }
  const int rgb = std::min(image.channels, 3);
  for (std::size_t i = 0; i < image.PixelCount(); ++i) {
    for (int c = 0; c < rgb; ++c) {
      image.data[i * image.channels + c] *= static_cast<float>(model.exposure);
    }
  }
  if (inputs.renders != nullptr) inputs.renders->Keep(model, reference, image);
  return image;
}

void DiffuseAndLobe(ModelId id, const double* p, const ShadingPoint& point, double diffuse_rgb[3],
                    std::vector<double>* lobe_per_light) {
  // The model's own Diffuse and Lobe terms (render/models/<name>.glsl): the same code that makes
  // up Reflect, so the split cannot drift from the model (glsl_twin_test holds each term to GL).
  double ka[3];
  AmbientReflectance(id, p, ka);
  for (int c = 0; c < 3; ++c) diffuse_rgb[c] = ka[c] * point.ambient[c];
  lobe_per_light->assign(point.lights.size(), 0.0);
  for (std::size_t i = 0; i < point.lights.size(); ++i) {
    const PixelLight& light = point.lights[i];
    const ModelTerms<double, double> t = EvaluateTerms(id, p, point.n, light.l, point.v);
    if (!t.valid) continue;  // Reflect() is 0 there too.
    for (int c = 0; c < 3; ++c) diffuse_rgb[c] += t.diffuse[c] * t.NoL * light.irradiance[c];
    (*lobe_per_light)[i] =
        t.lobe * Luma(light.irradiance[0], light.irradiance[1], light.irradiance[2]);
  }
}

namespace {

double AcosDeg(double c) { return std::acos(std::clamp(c, -1.0, 1.0)) * kRadToDeg; }

}  // namespace

ShadingAngles AnglesOf(const std::vector<ShadingPoint>& points) {
  ShadingAngles a;
  a.theta_v_deg.reserve(points.size());
  a.first_light.reserve(points.size() + 1);
  for (const ShadingPoint& pt : points) {
    a.theta_v_deg.push_back(AcosDeg(Dot(pt.n, pt.v)));
    a.first_light.push_back(a.theta_h_deg.size());
    for (const PixelLight& light : pt.lights) {
      const Vec3d& l = light.l;
      const Vec3d h = Normalize(l + pt.v);
      a.theta_h_deg.push_back(AcosDeg(Dot(pt.n, h)));
      a.theta_d_deg.push_back(AcosDeg(Dot(l, h)));
    }
  }
  a.first_light.push_back(a.theta_h_deg.size());
  return a;
}

Decomposition Decompose(const std::vector<ShadingPoint>& points, const ShadingAngles& angles,
                        const Image& image, const ModelUnderTest* known, double min_coverage,
                        double diffuse_percentile) {
  if (angles.theta_v_deg.size() != points.size()) {
    throw Error("probe", "angles", "the angles are not those of the shading points");
  }
  Decomposition out;
  out.has_lobe = known != nullptr;
  const ModelInfo* info = known ? &ValidateModel(*known) : nullptr;
  std::vector<double> lambert_shading;  // S(x) for kd = 1, unknown BRDF only
  std::vector<double> lobes;
  out.pixels.reserve(points.size());
  lambert_shading.reserve(points.size());
  for (std::size_t k = 0; k < points.size(); ++k) {
    const ShadingPoint& pt = points[k];
    if (image.channels >= 4 && image.at(pt.x, pt.y, 3) < min_coverage) continue;
    PixelTerms t;
    t.x = pt.x;
    t.y = pt.y;
    t.total = Luma(image.at(pt.x, pt.y, 0), image.at(pt.x, pt.y, 1), image.at(pt.x, pt.y, 2));
    t.theta_v_deg = angles.theta_v_deg[k];
    int dominant = -1;
    double best = 0;
    double shading = 0;
    for (std::size_t i = 0; i < pt.lights.size(); ++i) {
      const PixelLight& l = pt.lights[i];
      const double e =
          std::max(0.0, Dot(pt.n, l.l)) * Luma(l.irradiance[0], l.irradiance[1], l.irradiance[2]);
      shading += e * kInvPi;
      if (!known && e > best) {
        best = e;
        dominant = static_cast<int>(i);
      }
    }
    if (known) {
      double d[3];
      DiffuseAndLobe(info->id, known->params.data(), pt, d, &lobes);
      t.diffuse = Luma(d[0], d[1], d[2]) * known->exposure;
      for (std::size_t i = 0; i < lobes.size(); ++i) {
        t.lobe += lobes[i];
        if (lobes[i] > best) {
          best = lobes[i];
          dominant = static_cast<int>(i);
        }
      }
      if (dominant < 0) {  // No lobe anywhere (Lambert): take the strongest light.
        for (std::size_t i = 0; i < pt.lights.size(); ++i) {
          const double e = std::max(0.0, Dot(pt.n, pt.lights[i].l));
          if (e > best) {
            best = e;
            dominant = static_cast<int>(i);
          }
        }
      }
    }
    if (dominant >= 0) {
      const std::size_t j = angles.first_light[k] + static_cast<std::size_t>(dominant);
      t.theta_h_deg = angles.theta_h_deg[j];
      t.theta_d_deg = angles.theta_d_deg[j];
    }
    out.pixels.push_back(t);
    lambert_shading.push_back(shading);
  }
  if (known) {
    out.diffuse_source = known->label;
  } else {
    double max_s = 0;
    for (double s : lambert_shading) max_s = std::max(max_s, s);
    std::vector<double> ratios;
    for (std::size_t i = 0; i < out.pixels.size(); ++i) {
      if (lambert_shading[i] >= 0.05 * max_s && lambert_shading[i] > 0) {
        ratios.push_back(out.pixels[i].total / lambert_shading[i]);
      }
    }
    // diffuse_percentile is in percent; the order statistic of base/statistics.h.
    double kd =
        ratios.empty() ? 0.0 : std::max(0.0, shadefit::Percentile(ratios, diffuse_percentile / 100));
    for (std::size_t i = 0; i < out.pixels.size(); ++i) {
      out.pixels[i].diffuse = kd * lambert_shading[i];
    }
    out.diffuse_source =
        fmt::format("lambert-percentile (p{:g} of Y / S: kd_Y = {:.4g})", diffuse_percentile, kd);
  }
  for (PixelTerms& t : out.pixels) t.specular = t.total - t.diffuse;
  return out;
}

std::vector<const ProbeReference*> SelectTwinReferences(const ProbeInputs& inputs,
                                                        const std::vector<std::string>& lightings,
                                                        std::vector<std::string>* notes) {
  std::vector<const ProbeReference*> out;
  for (const ProbeReference& r : inputs.references) {
    if (!lightings.empty() &&
        std::find(lightings.begin(), lightings.end(), r.lighting) == lightings.end()) {
      notes->push_back(fmt::format("skipped {}: lighting '{}' not selected", r.name, r.lighting));
      continue;
    }
    if (!TwinSupportsScene(r.scene)) {
      notes->push_back(fmt::format(
          "skipped {}: environment/uniform lighting has no per-pixel light direction", r.name));
      continue;
    }
    out.push_back(&r);
  }
  return out;
}

nlohmann::json Num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

}  // namespace internal
}  // namespace shadefit::probes
