// Energy probe (docs/probes.md, "Energy"): directional albedo by quadrature, white-furnace
// renders (Furnace test: a closed environment of unit radiance returns the albedo; pbrt-v4's
// furnace checks), and the highlight-flux sweep of classic vs normalised Blinn-Phong vs GGX.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "probe_common.h"
#include "shadefit/render/albedo.h"
#include "shadefit/base/error.h"

namespace shadefit::probes {
namespace {

using internal::Num;

constexpr const char* kAlbedoAxis = "directional albedo E (max channel)";
constexpr const char* kSweepAxis = "specular albedo at normal view (flux)";

struct AlbedoCurve {
  std::vector<double> theta_deg;
  std::vector<AlbedoEstimate> e;
  int max_strata = 0;
};

// E(theta_o) per angle, doubling the strata until sigma <= target (or the limit).
AlbedoCurve Albedo(ModelId id, const std::vector<double>& params, const EnergyOptions& o) {
  AlbedoCurve c;
  for (const double t : o.view_angles_deg) {
    int strata = o.strata_per_axis;
    AlbedoEstimate e;
    for (;;) {
      AlbedoOptions ao;
      ao.strata_per_axis = strata;
      e = DirectionalAlbedo(id, params, std::cos(t * kPi / 180.0), ao);
      const double s = std::max({e.std_error[0], e.std_error[1], e.std_error[2]});
      if (s <= o.target_std_error || strata * 2 > o.max_strata_per_axis) break;
      strata *= 2;
    }
    c.theta_deg.push_back(t);
    c.e.push_back(e);
    c.max_strata = std::max(c.max_strata, strata);
  }
  return c;
}

// Linear interpolation of channel c of the albedo curve at theta (deg).
double Interpolate(const AlbedoCurve& a, int c, double theta) {
  if (theta <= a.theta_deg.front()) return a.e.front().value[c];
  for (std::size_t i = 1; i < a.theta_deg.size(); ++i) {
    if (theta <= a.theta_deg[i]) {
      const double f = (theta - a.theta_deg[i - 1]) / (a.theta_deg[i] - a.theta_deg[i - 1]);
      return a.e[i - 1].value[c] * (1 - f) + a.e[i].value[c] * f;
    }
  }
  return a.e.back().value[c];
}

std::string FurnaceToml(int res, int samples) {
  return fmt::format(
      "[camera]\nposition = [0.0, -6.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\n"
      "fov_y = 22.0\nresolution = [{0}, {0}]\n[[objects]]\ntype = \"sphere\"\n"
      "center = [0.0, 0.0, 0.0]\nradius = 1.0\n[[lights]]\ntype = \"uniform\"\nradiance = 1.0\n"
      "samples = {1}\n[background]\ntransparent = true\n",
      res, samples);
}


void ValidateOptions(const EnergyOptions& o) {
  if (o.view_angles_deg.empty()) throw Error("energy", "view_angles_deg", "empty");
  for (double t : o.view_angles_deg) {
    if (!(t >= 0 && t < 90)) {
      throw Error("energy", "view_angles_deg", fmt::format("{} outside [0, 90)", t));
    }
  }
  if (!std::is_sorted(o.view_angles_deg.begin(), o.view_angles_deg.end())) {
    throw Error("energy", "view_angles_deg", "must be increasing");
  }
  if (o.strata_per_axis < 1 || o.max_strata_per_axis < o.strata_per_axis) {
    throw Error("energy", "strata_per_axis", "needs 1 <= strata_per_axis <= max_strata_per_axis");
  }
}

// The truth first, then every model, each validated; the truth is labelled "truth".
std::vector<ModelUnderTest> ModelsOf(const ProbeInputs& inputs) {
  std::vector<ModelUnderTest> models;
  if (inputs.truth) models.push_back(*inputs.truth);
  for (const ModelUnderTest& m : inputs.models) models.push_back(m);
  if (models.empty()) throw Error("energy", "models", "no model and no truth given");
  for (const ModelUnderTest& m : models) internal::ValidateModel(m);
  if (inputs.truth) models.front().label = "truth";
  return models;
}

// Albedo numbers of one model (max over angles and channels, its sigma, the verdict) and its
// curve, the largest channel per angle.
ProbeCurve AlbedoNumbers(const ModelUnderTest& m, const AlbedoCurve& a, const EnergyOptions& o,
                         nlohmann::json* numbers) {
  double max_e = -1, max_sigma = 0, max_at = 0, sigma_at_max = 0;
  int max_channel = 0;
  std::vector<double> y;
  for (std::size_t i = 0; i < a.e.size(); ++i) {
    double row = -1;
    for (int c = 0; c < 3; ++c) {
      max_sigma = std::max(max_sigma, a.e[i].std_error[c]);
      row = std::max(row, a.e[i].value[c]);
      if (a.e[i].value[c] > max_e) {
        max_e = a.e[i].value[c];
        max_at = a.theta_deg[i];
        max_channel = c;
        sigma_at_max = a.e[i].std_error[c];
      }
    }
    y.push_back(row);
  }
  nlohmann::json& n = *numbers;
  n["model"] = m.model->name;
  n["albedo_normal"] = Num(std::max({a.e[0].value[0], a.e[0].value[1], a.e[0].value[2]}));
  n["max_albedo"] = Num(max_e);
  n["max_albedo_theta_deg"] = max_at;
  n["max_albedo_channel"] = std::string(1, "rgb"[max_channel]);
  n["max_albedo_std_error"] = Num(sigma_at_max);
  n["max_std_error"] = Num(max_sigma);
  n["strata_per_axis"] = a.max_strata;
  n["error_target_met"] = max_sigma <= o.target_std_error;
  n["verdict"] = max_e <= 1.0 + o.sigma_multiple * sigma_at_max ? "conserves" : "violates";
  return {.series = m.label,
          .kind = CurveKind::kAlbedo,
          .x = a.theta_deg,
          .y = std::move(y),
          .x_label = "theta_o (deg)",
          .y_label = kAlbedoAxis};
}

// The white-furnace scene and its G-buffer, rendered once per probe.
struct Furnace {
  Scene scene;
  GBuffer gbuffer;
};

// One model in the furnace: per covered pixel, E(theta_v) (largest channel) against the
// quadrature curve `a`; numbers furnace_max, furnace_mean, furnace_vs_quadrature_rmse and the
// curve binned in 5 degree steps of theta_v.
ProbeCurve FurnaceCheck(Renderer& renderer, const Furnace& furnace, const ModelUnderTest& m,
                        const AlbedoCurve& a, nlohmann::json* numbers) {
  const Image img = renderer.Render(furnace.scene, m.model->id, m.params);
  const GBuffer& gb = furnace.gbuffer;
  double sum_sq = 0, fmax = 0, fsum = 0;
  int count = 0;
  const int nb = 18;
  std::vector<double> bsum(nb, 0), tsum(nb, 0);
  std::vector<int> bn(nb, 0);
  for (int py = 0; py < img.height; ++py) {
    for (int px = 0; px < img.width; ++px) {
      if (img.at(px, py, 3) < 0.999f || !gb.Hit(px, py)) continue;
      const Vec3d nrm{gb.normal.at(px, py, 0), gb.normal.at(px, py, 1), gb.normal.at(px, py, 2)};
      const Vec3d v{gb.view.at(px, py, 0), gb.view.at(px, py, 1), gb.view.at(px, py, 2)};
      const double theta = std::acos(std::clamp(Dot(nrm, v), -1.0, 1.0)) * internal::kRadToDeg;
      double row = 0;
      for (int c = 0; c < 3; ++c) {
        const double d = img.at(px, py, c) - Interpolate(a, c, theta);
        sum_sq += d * d;
        row = std::max(row, static_cast<double>(img.at(px, py, c)));
      }
      fmax = std::max(fmax, row);
      fsum += row;
      ++count;
      const int b = std::min(nb - 1, static_cast<int>(theta / 5.0));
      bsum[b] += row;
      tsum[b] += theta;
      ++bn[b];
    }
  }
  nlohmann::json& n = *numbers;
  n["furnace_max"] = Num(fmax);
  n["furnace_mean"] = Num(count ? fsum / count : std::nan(""));
  n["furnace_vs_quadrature_rmse"] = Num(count ? std::sqrt(sum_sq / (3.0 * count)) : std::nan(""));
  ProbeCurve curve{.series = m.label,
                   .kind = CurveKind::kWhiteFurnace,
                   .x_label = "theta_o (deg)",
                   .y_label = kAlbedoAxis};
  for (int b = 0; b < nb; ++b) {
    if (bn[b] == 0) continue;
    curve.x.push_back(tsum[b] / bn[b]);
    curve.y.push_back(bsum[b] / bn[b]);
  }
  return curve;
}

// Normalised Blinn-Phong's specular albedo at normal view, in closed form
// (tests/render/brdf_physics_test.cpp).
double NormalizedBlinnPhongFlux(double n) {
  return (n + 8.0) * (2.0 * (1.0 - std::pow(2.0, -(n + 4.0) / 2.0)) / (n + 4.0) -
                      (1.0 - std::pow(2.0, -(n + 2.0) / 2.0)) / (n + 2.0));
}

// What the sweep adds to the probe's result: its curves, numbers["sweep"] and a note.
struct SweepOutputs {
  std::vector<ProbeCurve> curves;
  nlohmann::json numbers;
  std::string note;
};

// The sweep: specular-only albedo at normal view over the shininess list for classic and
// normalised Blinn-Phong and GGX, plus normalised Blinn-Phong's closed form as a check.
SweepOutputs ComputeLobeWidthSweep(const EnergyOptions& o) {
  SweepOutputs out;
  struct Series {
    std::string name, model;
  };
  const std::vector<Series> series = {{"blinn-phong (classic, ks = 1)", "blinn-phong"},
                                      {"blinn-phong-normalized (ks = 1)", "blinn-phong-normalized"},
                                      {"ggx (f0 = 1, alpha = sqrt(2 / (n + 2)))", "ggx"}};
  AlbedoOptions ao;
  ao.strata_per_axis = o.sweep_strata_per_axis;
  nlohmann::json& numbers = out.numbers;
  for (const Series& s : series) {
    const ModelInfo& info = FindModel(s.model);
    ProbeCurve curve{.series = s.name,
                     .kind = CurveKind::kLobeWidthSweep,
                     .x_label = "shininess n",
                     .y_label = kSweepAxis,
                     .x_scale = AxisScale::kLog};
    for (const double nexp : o.sweep_shininess) {
      // The model's specular lobe alone at unit scale (its table's roles), its width set so that
      // its lobe stands for a Blinn-Phong exponent n: alpha = sqrt(2 / (n + 2)) (Walter et al.
      // 2007, sec. 5.2, Beckmann width; close for GGX near the peak), clamped to the table.
      std::vector<double> p = SpecularOnlyParams(info);
      SetWidthForAlpha(info, std::sqrt(2.0 / (nexp + 2.0)), &p);
      curve.x.push_back(nexp);
      curve.y.push_back(DirectionalAlbedo(info.id, p, 1.0, ao).value[0]);
    }
    const auto [lo, hi] = std::minmax_element(curve.y.begin(), curve.y.end());
    nlohmann::json& n = numbers[s.model];
    n["flux_min"] = Num(*lo);
    n["flux_max"] = Num(*hi);
    n["flux_max_over_min"] = Num(*lo > 0 ? *hi / *lo : std::nan(""));
    if (s.model == "blinn-phong-normalized") {
      ProbeCurve closed{.series = "blinn-phong-normalized closed form",
                        .kind = CurveKind::kLobeWidthSweep,
                        .x = o.sweep_shininess,
                        .x_label = "shininess n",
                        .y_label = kSweepAxis,
                        .x_scale = AxisScale::kLog};
      double worst = 0;
      for (std::size_t i = 0; i < o.sweep_shininess.size(); ++i) {
        closed.y.push_back(NormalizedBlinnPhongFlux(o.sweep_shininess[i]));
        worst = std::max(worst, std::abs(curve.y[i] - closed.y.back()));
      }
      n["max_abs_error_vs_closed_form"] = worst;
      out.curves.push_back(std::move(curve));
      out.curves.push_back(std::move(closed));
    } else {
      out.curves.push_back(std::move(curve));
    }
  }
  out.note = fmt::format(
      "sweep: specular-only albedo at normal view, {}^2 strata; GGX roughness from n by Walter "
      "et al. 2007 sec. 5.2",
      o.sweep_strata_per_axis);
  return out;
}

// The sweep depends on its options alone, not on the models under test, so the probes of one
// process (a study's energy probe per material) share one computation per shininess list and
// strata: the same numbers, computed once instead of once per material.
// (A list holding NaN, which orders no map, is computed every time.)
void LobeWidthSweep(const EnergyOptions& o, ProbeResult* result) {
  const auto add = [result](const SweepOutputs& sweep) {
    result->curves.insert(result->curves.end(), sweep.curves.begin(), sweep.curves.end());
    result->numbers["sweep"] = sweep.numbers;
    result->notes.push_back(sweep.note);
  };
  if (std::any_of(o.sweep_shininess.begin(), o.sweep_shininess.end(),
                  [](double n) { return std::isnan(n); })) {
    add(ComputeLobeWidthSweep(o));
    return;
  }
  static std::mutex mutex;
  static std::map<std::pair<std::vector<double>, int>, SweepOutputs> done;
  const std::lock_guard<std::mutex> lock(mutex);
  const auto key = std::make_pair(o.sweep_shininess, o.sweep_strata_per_axis);
  auto it = done.find(key);
  if (it == done.end()) it = done.emplace(key, ComputeLobeWidthSweep(o)).first;
  add(it->second);
}

}  // namespace

ProbeResult EnergyProbe(const ProbeInputs& inputs, const EnergyOptions& o) {
  ValidateOptions(o);
  const std::vector<ModelUnderTest> models = ModelsOf(inputs);
  ProbeResult result(ProbeKind::kEnergy);
  result.notes.push_back(fmt::format(
      "E(theta_o) = DirectionalAlbedo (stratified, MIS cosine + GGX-equivalent lobe, balance "
      "heuristic), {}^2 strata per technique doubled up to {}^2 until sigma <= {}; BRDF only "
      "(exposure not applied); curves show the largest channel",
      o.strata_per_axis, o.max_strata_per_axis, o.target_std_error));
  result.notes.push_back(
      fmt::format("verdict: conserves when max albedo <= 1 + {} sigma", o.sigma_multiple));
  if (!inputs.references.empty()) {
    result.notes.push_back("references are not used: energy is a property of the BRDF");
  }
  std::optional<Furnace> furnace;
  if (inputs.renderer) {
    furnace = Furnace{ParseScene(FurnaceToml(o.furnace_resolution, o.furnace_samples), "furnace"),
                      GBuffer{}};
    furnace->gbuffer = inputs.renderer->RenderGBuffer(furnace->scene);
    result.notes.push_back(
        fmt::format("white furnace: unit sphere, uniform light radiance 1, {}^2 px, {} samples per "
                    "technique; pixel value = E(theta_v) (one bounce)",
                    o.furnace_resolution, o.furnace_samples));
  } else {
    result.notes.push_back("white furnace skipped: no GL renderer");
  }
  for (const ModelUnderTest& m : models) {
    const AlbedoCurve a = Albedo(m.model->id, m.params, o);
    nlohmann::json& n = result.numbers[m.label];
    result.curves.push_back(AlbedoNumbers(m, a, o, &n));
    if (furnace) result.curves.push_back(FurnaceCheck(*inputs.renderer, *furnace, m, a, &n));
  }
  LobeWidthSweep(o, &result);
  return result;
}

}  // namespace shadefit::probes
