// Portability probe (docs/probes.md, "Portability"): a material fitted under some lightings is
// rendered under the others. Burley 2012 (section 1) reports that ad-hoc models needed a
// "material re-do" whenever the lighting changed; the test/train error ratio measures that.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "probe_common.h"
#include "shadefit/base/error.h"

namespace shadefit::probes {
namespace {

using internal::Num;

// Sum of squared RGB errors and the valid pixel count (coverage >= min in both images).
void Accumulate(const Image& ref, const Image& test, double min_coverage, double* sum_sq,
                long* pixels) {
  for (int y = 0; y < ref.height; ++y) {
    for (int x = 0; x < ref.width; ++x) {
      if (ref.at(x, y, 3) < min_coverage || test.at(x, y, 3) < min_coverage) continue;
      for (int c = 0; c < 3; ++c) {
        const double d = static_cast<double>(test.at(x, y, c)) - ref.at(x, y, c);
        *sum_sq += d * d;
      }
      ++*pixels;
    }
  }
}

}  // namespace

ProbeResult PortabilityProbe(const ProbeInputs& inputs, const PortabilityOptions& o) {
  if (inputs.references.empty()) throw Error("portability", "references", "no reference given");
  for (const ProbeReference& r : inputs.references) ValidateReference(r, o.min_coverage);
  if (inputs.truth) internal::ValidateModel(*inputs.truth);
  for (const ModelUnderTest& m : inputs.models) {
    internal::ValidateModel(m);
    for (const std::string& t : m.trained_on) {
      const bool known = std::any_of(inputs.references.begin(), inputs.references.end(),
                                     [&](const ProbeReference& r) { return r.name == t; });
      if (!known) {
        throw Error(m.label, "trained_on",
                    fmt::format("'{}' is not one of the references given", t));
      }
    }
  }
  ProbeResult result(ProbeKind::kPortability);
  result.notes.push_back(fmt::format(
      "RMSE of linear RGB radiance over pixels with coverage >= {} in both reference and render; "
      "train/test RMSE pooled over the pixels of each set; ratio = test / train; renders by {}",
      o.min_coverage, inputs.renderer ? "GL" : "the C++ twin"));

  std::vector<std::string> ticks;
  for (const ProbeReference& r : inputs.references) ticks.push_back(r.name);
  std::vector<double> xs;
  for (std::size_t i = 0; i < ticks.size(); ++i) xs.push_back(static_cast<double>(i));

  auto evaluate = [&](const ModelUnderTest& m, const std::string& label, bool all_test) {
    nlohmann::json& n = result.numbers[label];
    double sq[2] = {0, 0};
    long px[2] = {0, 0};
    std::vector<double> per_ref;
    for (const ProbeReference& r : inputs.references) {
      if (inputs.renderer == nullptr && !TwinSupportsScene(r.scene)) {
        result.notes.push_back(fmt::format(
            "{} @ {}: skipped, environment lighting needs the GL renderer", label, r.name));
        per_ref.push_back(std::nan(""));
        continue;
      }
      const Image render = internal::RenderModel(inputs, m, r);
      double s = 0;
      long p = 0;
      Accumulate(r.image, render, o.min_coverage, &s, &p);
      const bool train = !all_test && std::find(m.trained_on.begin(), m.trained_on.end(), r.name) !=
                                          m.trained_on.end();
      sq[train ? 0 : 1] += s;
      px[train ? 0 : 1] += p;
      const double rmse = p ? std::sqrt(s / (3.0 * p)) : std::nan("");
      n["rmse"][r.name] = Num(rmse);
      per_ref.push_back(rmse);
    }
    const double train = px[0] ? std::sqrt(sq[0] / (3.0 * px[0])) : std::nan("");
    const double test = px[1] ? std::sqrt(sq[1] / (3.0 * px[1])) : std::nan("");
    n["train_rmse"] = Num(train);
    n["test_rmse"] = Num(test);
    n["test_over_train"] = Num(train > 0 ? test / train : std::nan(""));
    n["train_references"] = static_cast<int>(m.trained_on.size());
    result.curves.push_back({.series = label,
                             .kind = CurveKind::kRmsePerReference,
                             .x = xs,
                             .y = std::move(per_ref),
                             .x_label = "reference",
                             .y_label = "RMSE (linear radiance)",
                             .x_ticks = ticks});
  };

  if (inputs.truth) {
    evaluate(*inputs.truth, "truth", /*all_test=*/true);
    result.notes.push_back("truth: rendered under every reference (noise floor; no training set)");
  }
  int used = 0;
  for (const ModelUnderTest& m : inputs.models) {
    if (m.trained_on.empty()) {
      result.notes.push_back(fmt::format("{}: skipped, trained_on is empty", m.label));
      continue;
    }
    evaluate(m, m.label, /*all_test=*/false);
    ++used;
  }
  if (used == 0) {
    throw Error("portability", "models",
                "no model with trained_on (which references it was fitted to)");
  }
  return result;
}

}  // namespace shadefit::probes
