#include "shadefit/fit/exposure_pin.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "exposure_gauge.h"
#include "model_structure.h"
#include "shadefit/fit/residuals.h"
#include "shadefit/render/models.h"

namespace shadefit::fit {
namespace {

// A reflectance moved by the gauge stays within this fraction of its upper bound: on the bound
// the sine transform's column vanishes and the entry would read "at bound" for a choice of
// gauge, not for the data.
constexpr double kGaugeHeadroom = 0.99;

// The rows of `entries`, each named once, in table order: "kd, ks".
std::string RowNames(const ModelInfo& model, const std::vector<int>& entries) {
  std::vector<std::string> names;
  for (int i : entries) {
    const std::string& row = model.SpecOfEntry(i).name;
    if (std::find(names.begin(), names.end(), row) == names.end()) names.push_back(row);
  }
  return fmt::format("{}", fmt::join(names, ", "));
}

// kFresnel: every kFresnelParam row at its default, a colour row in its green entry only.
ExposurePin FresnelPin(const ModelInfo& model) {
  ExposurePin pin;
  pin.kind = PinKind::kFresnel;
  std::vector<std::string> held;
  for (const ParamSpec& row : model.params) {
    if (!(row.roles & kFresnelParam)) continue;
    const int entry = model.Offset(row.name) + (row.size == 3 ? 1 : 0);
    pin.entries.push_back(entry);
    pin.values.push_back(row.default_value);
    held.push_back(fmt::format("{} = {:g}", model.EntryName(entry), row.default_value));
  }
  pin.text = fmt::format(
      "{} (a dielectric's Fresnel reflectance at normal incidence, F0 = 0.04): the radiance is "
      "not linear in the reflectances; with these held the exposure is fitted, and the other "
      "reflectances are absolute if the material is a dielectric",
      fmt::join(held, ", "));
  return pin;
}

}  // namespace

ExposurePin ExposurePinOf(const ModelInfo& model, const std::vector<FixedValue>& fixed) {
  const std::vector<bool> linear = internal::LinearEntries(model.id);
  const Parametrization user(model, fixed);  // The user's fixed entries.
  ExposurePin pin;
  for (int i = 0; i < model.ParamCount(); ++i) {
    const EntryMap& e = user.entry(i);
    const bool sets_scale =
        (linear[i] && e.fixed_value != 0.0) || (model.SpecOfEntry(i).roles & kFresnelParam);
    if (e.fixed && sets_scale) {
      pin.text = fmt::format("nothing added: the fixed {} sets the scale", model.EntryName(i));
      return pin;
    }
  }
  if (internal::HomogeneousInLinearEntries(model.id)) {
    pin.kind = PinKind::kExposure;
    for (int i = 0; i < model.ParamCount(); ++i) {
      if (linear[i] && !user.entry(i).fixed) pin.entries.push_back(i);
    }
    pin.text = fmt::format(
        "the exposure: the radiance is linear in {} (exposure times them is one number), so the "
        "fit is moved along that line to exposure 1, or to the nearest exposure that keeps each "
        "within {:g}% of its upper bound; the image does not change",
        RowNames(model, pin.entries), 100 * kGaugeHeadroom);
    return pin;
  }
  const bool fresnel = std::any_of(model.params.begin(), model.params.end(),
                                   [](const ParamSpec& row) { return row.roles & kFresnelParam; });
  if (fresnel) return FresnelPin(model);
  pin.kind = PinKind::kUnitExposure;
  pin.text =
      "the exposure, held at 1 (the pixels as radiance per unit light): the radiance is not "
      "linear in a reflectance and no row sets a dielectric's Fresnel value";
  return pin;
}

namespace internal {

void MoveToExposureGauge(const Parametrization& param, const ExposurePin& pin,
                         MultiStartResult* solved, CeresProblems* problems) {
  const ModelInfo& model = param.model();
  for (StartResult& start : solved->starts) {
    if (!(start.exposure > 0) || !std::isfinite(start.exposure)) continue;
    // exposure * s and x / s: s = 1 / exposure unless an x would then pass kGaugeHeadroom of its
    // upper bound.
    double s = 1.0 / start.exposure;
    for (int i : pin.entries) {
      if (param.entry(i).fixed) continue;  // Held at 0 (no ambient light): 0 / s is 0.
      s = std::max(s, start.params[i] / (kGaugeHeadroom * model.SpecOfEntry(i).max));
    }
    start.exposure *= s;
    for (int i : pin.entries) {
      const EntryMap& e = param.entry(i);
      if (e.fixed) continue;
      start.params[i] = std::max(start.params[i] / s, e.log ? std::exp(e.lower) : e.lower);
    }
  }
  const StartResult& winner = solved->starts[solved->best];
  for (int i : pin.entries) {
    if (!param.entry(i).fixed) problems->u[i] = param.ToInternal(i, winner.params[i]);
  }
  problems->log_exposure[0] = std::log(winner.exposure);
  problems->full.SetParameterBlockConstant(problems->log_exposure);
  problems->exposure_free = false;
}

}  // namespace internal
}  // namespace shadefit::fit
