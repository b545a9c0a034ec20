// Highlight shape probe (docs/probes.md, "Highlight"). GGX's long tails (Walter et al. 2007;
// Burley 2012, section 5.4: measured MERL lobes have much longer tails than Blinn-Phong or
// Beckmann) show up as a larger tail fraction at a matched half-width.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "probe_common.h"
#include "shadefit/base/error.h"

namespace shadefit::probes {
namespace {

using internal::kNaN;
using internal::Num;

struct Shape {
  double peak = kNaN, peak_x = kNaN, peak_y = kNaN, mirror_x = kNaN, mirror_y = kNaN;
  double offset_px = kNaN, offset_deg = kNaN, area_px = kNaN, fwhm_px = kNaN;
  double hwhm_deg = kNaN, fwhm_deg = kNaN, aspect = kNaN, orientation_deg = kNaN;
  double tail_fraction = kNaN;
  double peak_fraction = kNaN;  // peak / the brightest pixel's total: how much highlight there is
  std::vector<double> falloff_x, falloff_y;
};

// The half-max region: 4-connected pixels with s >= peak / 2 flood-filled from the peak; its area,
// equivalent FWHM in pixels, and the ellipse of its s-weighted second moments.
void MeasureHalfMaxRegion(const std::vector<double>& spec, int width, int height, int peak,
                          Shape* s) {
  std::vector<char> in(spec.size(), 0);
  std::vector<int> stack = {peak};
  in[peak] = 1;
  double w_sum = 0, mx = 0, my = 0;
  std::vector<int> region;
  while (!stack.empty()) {
    const int i = stack.back();
    stack.pop_back();
    region.push_back(i);
    const int x = i % width, y = i / width;
    const int nb[4][2] = {{x - 1, y}, {x + 1, y}, {x, y - 1}, {x, y + 1}};
    for (const auto& q : nb) {
      if (q[0] < 0 || q[1] < 0 || q[0] >= width || q[1] >= height) continue;
      const int j = q[1] * width + q[0];
      if (!in[j] && spec[j] >= 0.5 * s->peak) {
        in[j] = 1;
        stack.push_back(j);
      }
    }
  }
  for (int i : region) {
    w_sum += spec[i];
    mx += spec[i] * (i % width);
    my += spec[i] * (i / width);
  }
  mx /= w_sum;
  my /= w_sum;
  double m20 = 0, m02 = 0, m11 = 0;
  for (int i : region) {
    const double dx = i % width - mx, dy = -(i / width - my);  // y up
    m20 += spec[i] * dx * dx;
    m02 += spec[i] * dy * dy;
    m11 += spec[i] * dx * dy;
  }
  m20 /= w_sum;
  m02 /= w_sum;
  m11 /= w_sum;
  // Eigenvalues of the covariance: the ellipse's squared semi-axes up to a common factor.
  const double tr = m20 + m02, det = m20 * m02 - m11 * m11;
  const double disc = std::sqrt(std::max(0.0, tr * tr / 4 - det));
  const double l1 = tr / 2 + disc, l2 = tr / 2 - disc;
  s->area_px = static_cast<double>(region.size());
  s->fwhm_px = 2.0 * std::sqrt(s->area_px / kPi);
  if (region.size() >= 3 && l2 > 1e-12) {
    s->aspect = std::sqrt(l1 / l2);
    s->orientation_deg = 0.5 * std::atan2(2 * m11, m20 - m02) * internal::kRadToDeg;
  }
}

// Radial falloff in theta_h, the HWHM where it first drops to half its first bin, and the tail
// fraction beyond tail_hwhm_multiple HWHM.
void MeasureFalloff(const std::vector<double>& spec, const std::vector<double>& theta,
                    const HighlightOptions& o, Shape* s) {
  const int nb = std::max(1, static_cast<int>(std::ceil(o.falloff_max_deg / o.falloff_bin_deg)));
  std::vector<double> sum(nb, 0.0), tsum(nb, 0.0);
  std::vector<int> cnt(nb, 0);
  for (std::size_t i = 0; i < spec.size(); ++i) {
    if (theta[i] < 0 || std::isnan(spec[i])) continue;
    const int b = static_cast<int>(theta[i] / o.falloff_bin_deg);
    if (b >= nb) continue;
    sum[b] += spec[i];
    tsum[b] += theta[i];
    ++cnt[b];
  }
  for (int b = 0; b < nb; ++b) {
    if (cnt[b] == 0) continue;
    s->falloff_x.push_back(tsum[b] / cnt[b]);
    s->falloff_y.push_back(sum[b] / cnt[b] / s->peak);
  }
  if (!s->falloff_y.empty() && s->falloff_y[0] > 0) {
    const double half = 0.5 * s->falloff_y[0];
    for (std::size_t k = 1; k < s->falloff_y.size(); ++k) {
      if (s->falloff_y[k] <= half) {
        const double x0 = s->falloff_x[k - 1], y0 = s->falloff_y[k - 1];
        const double x1 = s->falloff_x[k], y1 = s->falloff_y[k];
        s->hwhm_deg = y0 == y1 ? x1 : x0 + (y0 - half) * (x1 - x0) / (y0 - y1);
        break;
      }
    }
  }
  s->fwhm_deg = 2.0 * s->hwhm_deg;
  if (std::isfinite(s->hwhm_deg)) {
    double total = 0, tail = 0;
    for (std::size_t i = 0; i < spec.size(); ++i) {
      if (theta[i] < 0 || !(spec[i] > 0)) continue;
      total += spec[i];
      if (theta[i] > o.tail_hwhm_multiple * s->hwhm_deg) tail += spec[i];
    }
    s->tail_fraction = total > 0 ? tail / total : kNaN;
  }
}

Shape Measure(const internal::Decomposition& dec, int width, int height,
              const HighlightOptions& o) {
  Shape s;
  std::vector<double> spec(static_cast<std::size_t>(width) * height, kNaN);
  std::vector<double> theta(spec.size(), -1.0);
  int peak = -1, mirror = -1;
  double brightest = 0;
  for (const auto& p : dec.pixels) {
    brightest = std::max(brightest, p.total);
    const int i = p.y * width + p.x;
    spec[i] = p.specular;
    theta[i] = p.theta_h_deg;
    if (p.theta_h_deg >= 0 && (peak < 0 || p.specular > spec[peak])) peak = i;
    if (p.theta_h_deg >= 0 && (mirror < 0 || p.theta_h_deg < theta[mirror])) mirror = i;
  }
  if (peak < 0 || !(spec[peak] > 0)) return s;  // No lit pixel or no highlight.
  s.peak = spec[peak];
  s.peak_fraction = brightest > 0 ? s.peak / brightest : kNaN;
  s.peak_x = peak % width;
  s.peak_y = peak / width;
  s.mirror_x = mirror % width;
  s.mirror_y = mirror / width;
  s.offset_px = std::hypot(s.peak_x - s.mirror_x, s.peak_y - s.mirror_y);
  s.offset_deg = theta[peak];
  MeasureHalfMaxRegion(spec, width, height, peak, &s);
  MeasureFalloff(spec, theta, o, &s);
  return s;
}

nlohmann::json ShapeJson(const Shape& s) {
  return {{"peak", Num(s.peak)},
          {"peak_x", Num(s.peak_x)},
          {"peak_y", Num(s.peak_y)},
          {"mirror_x", Num(s.mirror_x)},
          {"mirror_y", Num(s.mirror_y)},
          {"offset_px", Num(s.offset_px)},
          {"offset_deg", Num(s.offset_deg)},
          {"area_px", Num(s.area_px)},
          {"fwhm_px", Num(s.fwhm_px)},
          {"hwhm_deg", Num(s.hwhm_deg)},
          {"fwhm_deg", Num(s.fwhm_deg)},
          {"aspect", Num(s.aspect)},
          {"orientation_deg", Num(s.orientation_deg)},
          {"tail_fraction", Num(s.tail_fraction)},
          {"peak_fraction", Num(s.peak_fraction)}};
}

}  // namespace

ProbeResult HighlightProbe(const ProbeInputs& inputs, const HighlightOptions& o) {
  if (!(o.falloff_bin_deg > 0) || !(o.falloff_max_deg > o.falloff_bin_deg)) {
    throw Error("highlight", "falloff_bin_deg", "needs 0 < falloff_bin_deg < falloff_max_deg");
  }
  if (!(o.tail_hwhm_multiple > 0)) {
    throw Error("highlight", "tail_hwhm_multiple", "must be > 0");
  }
  if (inputs.references.empty()) throw Error("highlight", "references", "no reference given");
  for (const ProbeReference& r : inputs.references) ValidateReference(r, o.min_coverage);
  if (inputs.truth) internal::ValidateModel(*inputs.truth);
  for (const ModelUnderTest& m : inputs.models) internal::ValidateModel(m);

  ProbeResult result(ProbeKind::kHighlight);
  const auto refs = internal::SelectTwinReferences(inputs, o.lightings, &result.notes);
  if (refs.empty()) {
    throw Error("highlight", "references",
                "no reference with point/directional lighting among the selected ones");
  }
  result.notes.push_back(fmt::format(
      "specular s = Y(image) - Y(diffuse estimate); theta_h = acos(n.h) of the dominant light; "
      "half-max region = 4-connected s >= peak/2 around the peak; falloff bins {} deg; tail = "
      "theta_h > {} x HWHM; sums are over pixels (image space, not solid angle)",
      o.falloff_bin_deg, o.tail_hwhm_multiple));

  for (const ProbeReference* ref : refs) {
    const auto points =
        PrepareShading(ref->scene, ref->gbuffer, static_cast<float>(o.min_coverage));
    const internal::ShadingAngles angles = internal::AnglesOf(points);
    auto run = [&](const std::string& label, const ModelUnderTest* known, const Image& image) {
      const internal::Decomposition dec = internal::Decompose(points, angles, image, known,
                                                              o.min_coverage, o.diffuse_percentile);
      const Shape s = Measure(dec, image.width, image.height, o);
      // A reference without a highlight (a Lambert material: its residual is render noise) has
      // no shape to reproduce: it gets no shape numbers, so its highlight verdicts read "not
      // applicable" rather than "not reproduced".
      if (label == "reference" && !(s.peak_fraction >= o.min_peak_fraction)) {
        result.numbers[label][ref->name] = {{"has_highlight", false},
                                            {"peak_fraction", Num(s.peak_fraction)}};
        result.notes.push_back(fmt::format(
            "reference @ {}: no highlight (specular peak {:.3g} of the brightest pixel < {}): "
            "highlight verdicts not applicable",
            ref->name, s.peak_fraction, o.min_peak_fraction));
        return;
      }
      result.numbers[label][ref->name] = ShapeJson(s);
      result.numbers[label][ref->name]["has_highlight"] = s.peak > 0;
      if (!(s.peak > 0)) {
        result.notes.push_back(
            fmt::format("{} @ {}: no highlight (no positive specular residual)", label, ref->name));
        return;
      }
      result.curves.push_back({.series = label,
                               .reference = ref->name,
                               .lighting = ref->lighting,
                               .kind = CurveKind::kFalloff,
                               .x = s.falloff_x,
                               .y = s.falloff_y,
                               .x_label = "theta_h (deg)",
                               .y_label = "specular / peak (mean per bin)",
                               .y_scale = AxisScale::kLog});
      result.notes.push_back(
          fmt::format("{} @ {}: diffuse estimate from {}", label, ref->name, dec.diffuse_source));
    };
    run("reference", inputs.truth ? &*inputs.truth : nullptr, ref->image);
    for (const ModelUnderTest& m : inputs.models) {
      run(m.label, &m, internal::RenderModel(inputs, m, *ref));
      // Ratios to the reference's shape: 1 = reproduced.
      nlohmann::json& n = result.numbers[m.label][ref->name];
      const nlohmann::json& r = result.numbers["reference"][ref->name];
      for (const char* f : {"fwhm_deg", "tail_fraction", "peak", "area_px"}) {
        const bool ok = n.contains(f) && r.contains(f) && n[f].is_number() &&
                        r[f].is_number() && r[f].get<double>() != 0.0;
        n[std::string(f) + "_ratio"] =
            ok ? Num(n[f].get<double>() / r[f].get<double>()) : nlohmann::json();
      }
    }
  }
  return result;
}

}  // namespace shadefit::probes
