// Fresnel rim probe (docs/probes.md, "Fresnel"). Curve points sit at the weighted mean angle of
// their bin. The effective Fresnel curve divides the specular
// residual by the same BRDF's specular term evaluated with F = 1: for a Cook-Torrance model
// (Cook and Torrance 1982; Walter et al. 2007) that ratio is F(theta_d) itself, for the classic
// Blinn-Phong lobe (Blinn 1977) it is the constant ks.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "probe_common.h"
#include "shadefit/base/error.h"

namespace shadefit::probes {
namespace {

using internal::Num;

struct Binned {
  std::vector<double> num, den, x_sum;  // x_sum: sum of den * theta (den-weighted mean angle)
  std::vector<int> count;
  explicit Binned(int n) : num(n, 0.0), den(n, 0.0), x_sum(n, 0.0), count(n, 0) {}
  void Add(int b, double numerator, double denominator, double theta) {
    num[b] += numerator;
    den[b] += denominator;
    x_sum[b] += denominator * theta;
    count[b] += 1;
  }
  // Bins with data: den-weighted mean angle and num/den.
  void Points(std::vector<double>* x, std::vector<double>* y) const {
    for (std::size_t i = 0; i < num.size(); ++i) {
      if (count[i] > 0 && den[i] > 0) {
        x->push_back(x_sum[i] / den[i]);
        y->push_back(num[i] / den[i]);
      }
    }
  }
  // Ratio of sums over bins whose centre lies in [lo, hi].
  double Band(double width, double lo, double hi) const {
    double a = 0, b = 0;
    for (std::size_t i = 0; i < num.size(); ++i) {
      const double c = (i + 0.5) * width;
      if (count[i] > 0 && c >= lo && c <= hi) {
        a += num[i];
        b += den[i];
      }
    }
    return b > 0 ? a / b : std::nan("");
  }
};

int BinOf(double deg, double width, int n) {
  if (deg < 0) return -1;
  return std::clamp(static_cast<int>(deg / width), 0, n - 1);
}

// RMSE between two binned curves over the bins both have.
void AccumulateCurveError(const Binned& a, const Binned& b, double* sum_sq, int* n) {
  for (std::size_t i = 0; i < a.num.size(); ++i) {
    if (a.count[i] > 0 && b.count[i] > 0 && a.den[i] > 0 && b.den[i] > 0) {
      const double d = a.num[i] / a.den[i] - b.num[i] / b.den[i];
      *sum_sq += d * d;
      ++*n;
    }
  }
}

struct LabelState {
  std::map<std::string, Binned> theta_v;  // per reference
  Binned theta_d;                         // pooled
  bool has_lobe = false;
  explicit LabelState(int n) : theta_d(n) {}
};

// One image (the reference or a model's render) under one reference, whose shading points are
// `points`: its theta_v curve and centre/rim numbers go to `result`, its theta_d sums into the
// label's pooled state.
void MeasureImage(const FresnelOptions& o, const std::string& label, const ModelUnderTest* known,
                  const ProbeReference& ref, const std::vector<ShadingPoint>& points,
                  const internal::ShadingAngles& angles, const Image& image, LabelState* st,
                  ProbeResult* result) {
  const int nbins = static_cast<int>(st->theta_d.num.size());
  const double w = o.bin_width_deg;
  const internal::Decomposition dec =
      internal::Decompose(points, angles, image, known, o.min_coverage, o.diffuse_percentile);
  st->has_lobe = dec.has_lobe;
  Binned tv(nbins);
  double max_lobe = 0;
  for (const auto& p : dec.pixels) max_lobe = std::max(max_lobe, p.lobe);
  double centre_sum = 0, rim_sum = 0;
  int centre_n = 0, rim_n = 0;
  for (const auto& p : dec.pixels) {
    const int b = BinOf(p.theta_v_deg, w, nbins);
    tv.Add(b, p.specular, 1.0, p.theta_v_deg);
    if (p.theta_v_deg <= o.centre_max_deg) centre_sum += p.specular, ++centre_n;
    if (p.theta_v_deg >= o.rim_min_deg) rim_sum += p.specular, ++rim_n;
    if (dec.has_lobe && max_lobe > 0 && p.lobe >= o.lobe_min_fraction * max_lobe) {
      const int bd = BinOf(p.theta_d_deg, w, nbins);
      if (bd >= 0) st->theta_d.Add(bd, p.specular, p.lobe, p.theta_d_deg);
    }
  }
  const double centre = centre_n ? centre_sum / centre_n : std::nan("");
  const double rim = rim_n ? rim_sum / rim_n : std::nan("");
  nlohmann::json& n = result->numbers[label][ref.name];
  n["specular_centre"] = Num(centre);
  n["specular_rim"] = Num(rim);
  n["rim_to_centre_theta_v"] = Num(centre > 1e-9 ? rim / centre : std::nan(""));
  n["pixels"] = dec.pixels.size();
  std::vector<double> x, y;
  tv.Points(&x, &y);
  result->curves.push_back({.series = label,
                            .reference = ref.name,
                            .lighting = ref.lighting,
                            .kind = CurveKind::kSpecularVsThetaV,
                            .x = std::move(x),
                            .y = std::move(y),
                            .x_label = "theta_v (deg)",
                            .y_label = "mean specular luminance"});
  result->notes.push_back(
      fmt::format("{} @ {}: diffuse estimate from {}", label, ref.name, dec.diffuse_source));
  st->theta_v.emplace(ref.name, tv);
}

// Per label: the pooled F(theta_d) curve and its centre/rim numbers, and for models the curve
// RMSEs against the reference (states.front()).
void Summarise(const FresnelOptions& o,
               const std::vector<std::pair<std::string, LabelState>>& states,
               ProbeResult* result) {
  const double w = o.bin_width_deg;
  const LabelState& reference = states.front().second;
  for (const auto& [label, st] : states) {
    nlohmann::json& n = result->numbers[label];
    if (st.has_lobe) {
      const double f_centre = st.theta_d.Band(w, 0.0, o.centre_max_deg);
      const double f_rim = st.theta_d.Band(w, o.rim_min_deg, 90.0);
      n["F_centre"] = Num(f_centre);
      n["F_rim"] = Num(f_rim);
      n["rim_to_centre"] = Num(f_centre > 0 ? f_rim / f_centre : std::nan(""));
      std::vector<double> x, y;
      st.theta_d.Points(&x, &y);
      result->curves.push_back({.series = label,
                                .kind = CurveKind::kFresnelVsThetaD,
                                .x = std::move(x),
                                .y = std::move(y),
                                .x_label = "theta_d (deg)",
                                .y_label = "effective Fresnel sum(spec) / sum(lobe_F=1)"});
    } else {
      n["F_centre"] = nullptr;
      n["F_rim"] = nullptr;
      n["rim_to_centre"] = nullptr;
    }
    if (label == "reference") continue;
    double sq = 0;
    int cnt = 0;
    if (reference.has_lobe) AccumulateCurveError(st.theta_d, reference.theta_d, &sq, &cnt);
    n["curve_rmse_theta_d"] = Num(cnt ? std::sqrt(sq / cnt) : std::nan(""));
    sq = 0;
    cnt = 0;
    for (const auto& [ref_name, curve] : st.theta_v) {
      AccumulateCurveError(curve, reference.theta_v.at(ref_name), &sq, &cnt);
    }
    n["curve_rmse_theta_v"] = Num(cnt ? std::sqrt(sq / cnt) : std::nan(""));
  }
}

}  // namespace

ProbeResult FresnelProbe(const ProbeInputs& inputs, const FresnelOptions& o) {
  if (!(o.bin_width_deg > 0 && o.bin_width_deg <= 90)) {
    throw Error("fresnel", "bin_width_deg",
                fmt::format("must be in (0, 90], got {}", o.bin_width_deg));
  }
  if (inputs.references.empty()) throw Error("fresnel", "references", "no reference given");
  for (const ProbeReference& r : inputs.references) ValidateReference(r, o.min_coverage);
  if (inputs.truth) internal::ValidateModel(*inputs.truth);
  for (const ModelUnderTest& m : inputs.models) internal::ValidateModel(m);

  ProbeResult result(ProbeKind::kFresnel);
  const auto refs = internal::SelectTwinReferences(inputs, o.lightings, &result.notes);
  if (refs.empty()) {
    throw Error("fresnel", "references",
                "no reference with point/directional lighting among the selected ones");
  }
  const int nbins = static_cast<int>(std::ceil(90.0 / o.bin_width_deg));
  result.notes.push_back(fmt::format(
      "specular = Y(image) - Y(diffuse estimate), Y = Rec.709 luminance; pixels with coverage >= "
      "{}; theta bins of {} deg; centre band theta <= {} deg, rim band theta >= {} deg",
      o.min_coverage, o.bin_width_deg, o.centre_max_deg, o.rim_min_deg));
  result.notes.push_back(
      "F(theta_d) = sum(specular) / sum(unit-Fresnel lobe) per bin, pooled over references, "
      "pixels whose lobe >= " +
      fmt::format("{}", o.lobe_min_fraction) +
      " x the image's max lobe; theta_d = acos(l.h) of the dominant light");

  // Each reference's shading points (its scene and G-buffer), shared by every image under it.
  std::vector<std::vector<ShadingPoint>> points;
  std::vector<internal::ShadingAngles> angles;
  for (const ProbeReference* ref : refs) {
    points.push_back(
        PrepareShading(ref->scene, ref->gbuffer, static_cast<float>(o.min_coverage)));
    angles.push_back(internal::AnglesOf(points.back()));
  }
  // The reference first, then every model.
  std::vector<std::pair<std::string, LabelState>> states;
  {
    LabelState st(nbins);
    const ModelUnderTest* truth = inputs.truth ? &*inputs.truth : nullptr;
    for (std::size_t i = 0; i < refs.size(); ++i) {
      MeasureImage(o, "reference", truth, *refs[i], points[i], angles[i], refs[i]->image, &st,
                   &result);
    }
    if (!truth) {
      result.notes.push_back(
          "reference: no truth BRDF, so no unit-Fresnel lobe: F(theta_d) not measured and "
          "theta_d curve errors are null");
    }
    states.emplace_back("reference", std::move(st));
  }
  for (const ModelUnderTest& m : inputs.models) {
    LabelState st(nbins);
    for (std::size_t i = 0; i < refs.size(); ++i) {
      MeasureImage(o, m.label, &m, *refs[i], points[i], angles[i],
                   internal::RenderModel(inputs, m, *refs[i]), &st, &result);
    }
    states.emplace_back(m.label, std::move(st));
  }
  Summarise(o, states, &result);
  return result;
}

}  // namespace shadefit::probes
