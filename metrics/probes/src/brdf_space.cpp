// BRDF-space probes (docs/probes.md, "BRDF-space probes"): the Fresnel rise of the specular peak
// (Burley 2012, "Physically-Based Shading at Disney", sec. 5.3 and fig. 12), the highlight's
// shape against theta_h, and the directional albedo, of a measured BRDF and of fitted models.
#include "shadefit/probes/brdf_space.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <string>

#include "probe_common.h"
#include "shadefit/base/error.h"
#include "shadefit/render/albedo.h"

namespace shadefit::probes {
namespace {

using internal::kNaN;
using internal::kRadToDeg;
using internal::Luma;
using internal::Num;

constexpr double kDegToRad = 1.0 / kRadToDeg;

// f(wi, wo) in 1/sr per channel, local frame (n = +z), cosine not included.
using BrdfFn = std::function<Vec3d(const Vec3d& wi, const Vec3d& wo)>;

double LumaOf(const Vec3d& c) { return Luma(c.x, c.y, c.z); }

// Y of f at Rusinkiewicz angles (degrees; phi_h = 0, isotropic BRDFs do not depend on it).
double FAt(const BrdfFn& f, double theta_h_deg, double theta_d_deg, double phi_d_deg) {
  Vec3d wi, wo;
  reference_images::FromHalfDiff(theta_h_deg * kDegToRad, theta_d_deg * kDegToRad,
                                 phi_d_deg * kDegToRad, &wi, &wo);
  if (wi.z <= 0 || wo.z <= 0) return 0.0;
  return LumaOf(f(wi, wo));
}

// Integral over [lo, hi] of the piecewise-linear interpolant of (x, g) (x increasing).
double Integrate(const std::vector<double>& x, const std::vector<double>& g, double lo, double hi) {
  double sum = 0;
  for (std::size_t i = 1; i < x.size(); ++i) {
    const double a = std::max(x[i - 1], lo), b = std::min(x[i], hi);
    if (!(b > a)) continue;
    const double dx = x[i] - x[i - 1];
    auto at = [&](double t) { return g[i - 1] + (g[i] - g[i - 1]) * (t - x[i - 1]) / dx; };
    sum += 0.5 * (at(a) + at(b)) * (b - a);
  }
  return sum;
}

// Mean of y over the x in [lo, hi] (inclusive, 1e-9 slack for the float grid); NaN when none.
double BandMean(const std::vector<double>& x, const std::vector<double>& y, double lo, double hi) {
  double sum = 0;
  int n = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (x[i] >= lo - 1e-9 && x[i] <= hi + 1e-9) {
      sum += y[i];
      ++n;
    }
  }
  return n ? sum / n : kNaN;
}

// --- Highlight ----------------------------------------------------------------------------------

struct Highlight {
  std::vector<double> theta_h;  // degrees
  std::vector<double> f;        // Y of f on the slice
  std::vector<double> s;        // specular part (f - floor) n.l n.v, normalised to its peak
  double floor = kNaN;          // diffuse floor, 1/sr
  double peak_f = kNaN;         // f at the peak of s
  double peak_s = kNaN;         // (f - floor) n.l n.v at its peak
  double hwhm_deg = kNaN;       // where s first falls to 1/2 beyond its peak
  double tail_fraction = kNaN;  // projected-solid-angle weighted share beyond k HWHM
};

Highlight MeasureHighlight(const BrdfFn& f, const BrdfSpaceOptions& o) {
  Highlight h;
  const int n = o.highlight_samples;
  const double cos_d = std::cos(o.highlight_theta_d_deg * kDegToRad);
  for (int i = 0; i < n; ++i) {
    const double u = static_cast<double>(i) / (n - 1);
    h.theta_h.push_back(u * u * o.highlight_max_deg);
    h.f.push_back(FAt(f, h.theta_h.back(), o.highlight_theta_d_deg, 90.0));
  }
  // The floor: the smallest f in the band, the sample least raised by the lobe's tail (a GGX
  // tail rises again toward grazing through its 1 / (4 n.l n.v)). Never above the curve's
  // minimum over the band, so the specular part stays >= 0 there.
  h.floor = std::numeric_limits<double>::infinity();
  for (int i = 0; i < n; ++i) {
    if (h.theta_h[i] >= o.floor_min_deg - 1e-9 && h.theta_h[i] <= o.floor_max_deg + 1e-9) {
      h.floor = std::min(h.floor, h.f[i]);
    }
  }
  std::vector<double> s(n);
  for (int i = 0; i < n; ++i) {
    // n.l = n.v = cos theta_h cos theta_d at phi_d = 90 deg (brdf_space.h).
    const double c = std::cos(h.theta_h[i] * kDegToRad) * cos_d;
    s[i] = (h.f[i] - h.floor) * c * c;
  }
  const int peak = static_cast<int>(std::max_element(s.begin(), s.end()) - s.begin());
  h.peak_s = s[peak];
  h.peak_f = h.f[peak];
  h.s.resize(n);
  for (int i = 0; i < n; ++i) h.s[i] = h.peak_s > 0 ? s[i] / h.peak_s : kNaN;
  if (!(h.peak_s > 0)) return h;  // No specular part above the floor: no half-width.
  for (int i = peak + 1; i < n; ++i) {
    if (s[i] <= 0.5 * h.peak_s) {
      const double t = (s[i - 1] - 0.5 * h.peak_s) / (s[i - 1] - s[i]);
      h.hwhm_deg = h.theta_h[i - 1] + t * (h.theta_h[i] - h.theta_h[i - 1]);
      break;
    }
  }
  if (!std::isfinite(h.hwhm_deg)) return h;
  // Tail fraction: the share of the specular part, weighted by the projected solid angle of the
  // half vector (sin cos dtheta_h: for a microfacet BRDF, the share of the projected microfacet
  // area, whose total is 1), beyond tail_hwhm_multiple * HWHM, up to tail_max_deg.
  std::vector<double> g(n);
  for (int i = 0; i < n; ++i) {
    const double t = h.theta_h[i] * kDegToRad;
    g[i] = std::max(s[i], 0.0) * std::sin(t) * std::cos(t);
  }
  const double total = Integrate(h.theta_h, g, 0.0, o.tail_max_deg);
  const double tail = Integrate(h.theta_h, g, o.tail_hwhm_multiple * h.hwhm_deg, o.tail_max_deg);
  h.tail_fraction = total > 0 ? tail / total : kNaN;
  return h;
}

// --- Fresnel rise -------------------------------------------------------------------------------

struct FresnelRise {
  std::vector<double> theta_d;  // degrees
  std::vector<double> peak_f;   // Y of f(0, theta_d)
  std::vector<double> rise;     // (f - floor) cos^2 theta_d / its centre-band mean
  std::vector<bool> extrapolated;
  double centre_mean = kNaN;          // centre-band mean of (f - floor) cos^2 theta_d, 1/sr
  double rim_centre = kNaN;           // rim-band mean / centre-band mean
  double rim_centre_measured = kNaN;  // the same over the rim band cut at the extrapolation limit
  double rim_extrapolated_fraction = 0;  // share of the rim band's samples beyond the limit
};

FresnelRise MeasureFresnel(const BrdfFn& f, double floor, const BrdfSpaceOptions& o) {
  FresnelRise r;
  std::vector<double> s;
  const int n = static_cast<int>(std::floor(o.fresnel_max_deg / o.fresnel_step_deg + 1e-9)) + 1;
  for (int i = 0; i < n; ++i) {
    const double td = i * o.fresnel_step_deg;
    const double c = std::cos(td * kDegToRad);  // n.l = n.v at theta_h = 0
    r.theta_d.push_back(td);
    r.peak_f.push_back(FAt(f, 0.0, td, 90.0));
    s.push_back((r.peak_f.back() - floor) * c * c);
    r.extrapolated.push_back(td > o.extrapolated_theta_d_deg + 1e-9);
  }
  r.centre_mean = BandMean(r.theta_d, s, o.centre_min_deg, o.centre_max_deg);
  for (double v : s) r.rise.push_back(r.centre_mean > 0 ? v / r.centre_mean : kNaN);
  r.rim_centre = BandMean(r.theta_d, r.rise, o.rim_min_deg, o.rim_max_deg);
  r.rim_centre_measured = BandMean(r.theta_d, r.rise, o.rim_min_deg,
                                   std::min(o.rim_max_deg, o.extrapolated_theta_d_deg));
  int in_band = 0, beyond = 0;
  for (std::size_t i = 0; i < r.theta_d.size(); ++i) {
    if (r.theta_d[i] >= o.rim_min_deg - 1e-9 && r.theta_d[i] <= o.rim_max_deg + 1e-9) {
      ++in_band;
      if (r.extrapolated[i]) ++beyond;
    }
  }
  r.rim_extrapolated_fraction = in_band ? static_cast<double>(beyond) / in_band : 0.0;
  return r;
}

// --- Energy -------------------------------------------------------------------------------------

struct BrdfAlbedoCurve {
  std::vector<double> theta_o;                // degrees
  std::vector<double> y;                      // Y of E(theta_o)
  std::vector<double> max_channel;            // largest channel of E(theta_o)
  std::vector<double> extrapolated_fraction;  // share of E from theta_d beyond the limit
  std::vector<bool> extrapolated;
};

// E(wo) = integral of f(wi, wo) cos theta_i over wi, written over the half vector: wi = 2 (wo.h)
// h - wo, dwi = 4 (wo.h) dwh (Walter et al. 2007, eq. 14). theta_h = (pi / 2) x^2 with x at the
// midpoints of albedo_theta_steps cells (dtheta_h = pi x dx), phi_h at midpoints over 2 pi:
// samples crowd at h = n, where every specular peak of a measured table lies. theta_d = the
// angle between wo and h, so the extrapolated share is read off the same sum.
BrdfAlbedoCurve MeasuredAlbedo(const BrdfFn& f, const BrdfSpaceOptions& o) {
  BrdfAlbedoCurve a;
  const int nx = o.albedo_theta_steps, np = o.albedo_phi_steps;
  const double dx = 1.0 / nx, dphi = 2 * kPi / np;
  const double cos_limit = std::cos(o.extrapolated_theta_d_deg * kDegToRad);
  for (const double theta_o : o.view_angles_deg) {
    const double to = theta_o * kDegToRad;
    const Vec3d wo{std::sin(to), 0.0, std::cos(to)};
    double sum[3] = {0, 0, 0}, sum_y = 0, beyond_y = 0;
    for (int i = 0; i < nx; ++i) {
      const double x = (i + 0.5) * dx;
      const double th = 0.5 * kPi * x * x;
      const double st = std::sin(th), ct = std::cos(th);
      const double w_theta = st * kPi * x * dx * dphi;
      for (int j = 0; j < np; ++j) {
        const double ph = (j + 0.5) * dphi;
        const Vec3d h{st * std::cos(ph), st * std::sin(ph), ct};
        const double c = Dot(wo, h);
        if (c <= 0) continue;
        const Vec3d wi = h * (2 * c) - wo;
        if (wi.z <= 0) continue;
        const Vec3d v = f(wi, wo) * (w_theta * 4 * c * wi.z);
        for (int ch = 0; ch < 3; ++ch) sum[ch] += v[ch];
        const double y = LumaOf(v);
        sum_y += y;
        if (c < cos_limit) beyond_y += y;
      }
    }
    a.theta_o.push_back(theta_o);
    a.y.push_back(sum_y);
    a.max_channel.push_back(std::max({sum[0], sum[1], sum[2]}));
    const double frac = sum_y > 0 ? beyond_y / sum_y : 0.0;
    a.extrapolated_fraction.push_back(frac);
    a.extrapolated.push_back(frac > o.extrapolated_point_fraction);
  }
  return a;
}

BrdfAlbedoCurve ModelAlbedo(const ModelUnderTest& m, const BrdfSpaceOptions& o) {
  const ModelInfo& info = *m.model;
  BrdfAlbedoCurve a;
  AlbedoOptions ao;
  ao.strata_per_axis = o.model_strata_per_axis;
  for (const double theta_o : o.view_angles_deg) {
    const AlbedoEstimate e =
        DirectionalAlbedo(info.id, m.params, std::cos(theta_o * kDegToRad), ao);
    a.theta_o.push_back(theta_o);
    a.y.push_back(m.exposure * Luma(e.value[0], e.value[1], e.value[2]));
    a.max_channel.push_back(m.exposure * std::max({e.value[0], e.value[1], e.value[2]}));
    a.extrapolated_fraction.push_back(0.0);
    a.extrapolated.push_back(false);
  }
  return a;
}

// --- Assembly -----------------------------------------------------------------------------------

struct SeriesResult {
  std::string label;
  bool measured = false;
  Highlight highlight;
  FresnelRise fresnel;
  BrdfAlbedoCurve albedo;
};

BrdfFn ModelBrdf(const ModelUnderTest& m) {
  const ModelInfo& info = *m.model;
  return
      [id = info.id, params = m.params, exposure = m.exposure](const Vec3d& wi, const Vec3d& wo) {
        double out[3];
        Reflect(id, params.data(), Vec3d{0, 0, 1}, wi, wo, out);  // f (n . l)
        const double k = wi.z > 0 ? exposure / wi.z : 0.0;
        return Vec3d{out[0] * k, out[1] * k, out[2] * k};
      };
}

nlohmann::json SeriesNumbers(const SeriesResult& s) {
  nlohmann::json n;
  const FresnelRise& fr = s.fresnel;
  n["fresnel_centre_peak"] = Num(fr.centre_mean);
  n["fresnel_rim_centre_ratio"] = Num(fr.rim_centre);
  n["fresnel_rim_centre_ratio_to_limit"] = Num(fr.rim_centre_measured);
  n["fresnel_rim_extrapolated_fraction"] = s.measured ? fr.rim_extrapolated_fraction : 0.0;
  const Highlight& h = s.highlight;
  n["highlight_floor"] = Num(h.floor);
  n["highlight_peak_f"] = Num(h.peak_f);
  n["highlight_hwhm_deg"] = Num(h.hwhm_deg);
  n["highlight_tail_fraction"] = Num(h.tail_fraction);
  const BrdfAlbedoCurve& a = s.albedo;
  n["albedo_normal"] = Num(a.y.front());
  double max_y = -1, max_ch = -1, at = kNaN;
  bool max_extrapolated = false;
  std::vector<double> views;
  for (std::size_t i = 0; i < a.y.size(); ++i) {
    if (a.y[i] > max_y) {
      max_y = a.y[i];
      at = a.theta_o[i];
      max_extrapolated = a.extrapolated[i];
    }
    max_ch = std::max(max_ch, a.max_channel[i]);
    if (a.extrapolated[i]) views.push_back(a.theta_o[i]);
  }
  n["albedo_max"] = Num(max_y);
  n["albedo_max_view_deg"] = Num(at);
  n["albedo_max_channel"] = Num(max_ch);
  n["albedo_max_extrapolated"] = max_extrapolated;
  n["albedo_extrapolated_views_deg"] = views;
  n["albedo_extrapolated_fraction"] = a.extrapolated_fraction;  // per view, share of E
  return n;
}

// Model against measured: ratios and differences of the numbers, and the albedo's RMS difference
// over the view angles whose measured albedo is not marked extrapolated (and over all).
nlohmann::json Comparison(const SeriesResult& model, const SeriesResult& measured) {
  nlohmann::json c;
  auto ratio = [](double a, double b) { return b != 0 ? a / b : kNaN; };
  c["hwhm_ratio"] = Num(ratio(model.highlight.hwhm_deg, measured.highlight.hwhm_deg));
  c["tail_fraction_difference"] =
      Num(model.highlight.tail_fraction - measured.highlight.tail_fraction);
  c["rim_centre_ratio_ratio"] = Num(ratio(model.fresnel.rim_centre, measured.fresnel.rim_centre));
  c["rim_centre_ratio_to_limit_ratio"] =
      Num(ratio(model.fresnel.rim_centre_measured, measured.fresnel.rim_centre_measured));
  double sq = 0, sq_all = 0;
  int n = 0;
  const auto& a = model.albedo;
  const auto& b = measured.albedo;
  for (std::size_t i = 0; i < a.y.size(); ++i) {
    const double d = a.y[i] - b.y[i];
    sq_all += d * d;
    if (!b.extrapolated[i]) {
      sq += d * d;
      ++n;
    }
  }
  c["albedo_rms_difference"] = Num(n ? std::sqrt(sq / n) : kNaN);
  c["albedo_rms_difference_all"] = Num(std::sqrt(sq_all / a.y.size()));
  return c;
}

// The five curves of one series, in the order a figure shows them. Only the measured series has
// extrapolation flags: a model is defined at every angle.
void AddSeriesCurves(const SeriesResult& s, const BrdfSpaceOptions& o,
                     std::vector<ProbeCurve>* curves) {
  const std::string td_label = "theta_d (deg), theta_h = 0";
  const std::string th_label =
      fmt::format("theta_h (deg), theta_d = {:g}, phi_d = 90", o.highlight_theta_d_deg);
  const std::vector<bool> fresnel_flags = s.measured ? s.fresnel.extrapolated : std::vector<bool>{};
  const std::vector<bool> albedo_flags = s.measured ? s.albedo.extrapolated : std::vector<bool>{};
  auto flags = [](const std::vector<bool>& v) {  // empty when no point is extrapolated
    return std::find(v.begin(), v.end(), true) == v.end() ? std::vector<bool>{} : v;
  };
  curves->push_back({.series = s.label,
                     .kind = CurveKind::kFresnelRise,
                     .x = s.fresnel.theta_d,
                     .y = s.fresnel.rise,
                     .x_label = td_label,
                     .y_label = "Fresnel rise: (f - floor) cos^2 theta_d / centre mean",
                     .extrapolated = flags(fresnel_flags)});
  curves->push_back({.series = s.label,
                     .kind = CurveKind::kSpecularPeak,
                     .x = s.fresnel.theta_d,
                     .y = s.fresnel.peak_f,
                     .x_label = td_label,
                     .y_label = "specular peak f (1/sr)",
                     .y_scale = AxisScale::kLog,
                     .extrapolated = flags(fresnel_flags)});
  curves->push_back({.series = s.label,
                     .kind = CurveKind::kHighlightF,
                     .x = s.highlight.theta_h,
                     .y = s.highlight.f,
                     .x_label = th_label,
                     .y_label = "f (1/sr)",
                     .y_scale = AxisScale::kLog});
  curves->push_back({.series = s.label,
                     .kind = CurveKind::kHighlightSpecular,
                     .x = s.highlight.theta_h,
                     .y = s.highlight.s,
                     .x_label = th_label,
                     .y_label = "specular (f - floor) n.l n.v / peak",
                     .y_scale = AxisScale::kLog});
  curves->push_back({.series = s.label,
                     .kind = CurveKind::kBrdfAlbedo,
                     .x = s.albedo.theta_o,
                     .y = s.albedo.y,
                     .x_label = "theta_o (deg)",
                     .y_label = "directional albedo (Y)",
                     .extrapolated = flags(albedo_flags)});
}

void ValidateOptions(const BrdfSpaceOptions& o) {
  auto fail = [](const char* field, const std::string& why) { throw Error("brdf", field, why); };
  if (!(o.fresnel_step_deg > 0)) fail("fresnel_step_deg", "must be > 0");
  if (!(o.fresnel_max_deg > 0 && o.fresnel_max_deg < 90)) fail("fresnel_max_deg", "in (0, 90)");
  if (!(o.centre_min_deg <= o.centre_max_deg)) fail("centre_max_deg", "below centre_min_deg");
  if (!(o.rim_min_deg <= o.rim_max_deg && o.rim_max_deg <= o.fresnel_max_deg)) {
    fail("rim_max_deg", "needs rim_min_deg <= rim_max_deg <= fresnel_max_deg");
  }
  if (!(o.highlight_theta_d_deg >= 0 && o.highlight_theta_d_deg < 90)) {
    fail("highlight_theta_d_deg", "in [0, 90)");
  }
  if (o.highlight_samples < 16) fail("highlight_samples", "needs >= 16");
  if (!(o.floor_min_deg < o.floor_max_deg && o.floor_max_deg <= o.highlight_max_deg &&
        o.highlight_max_deg < 90)) {
    fail("floor_max_deg", "needs floor_min_deg < floor_max_deg <= highlight_max_deg < 90");
  }
  if (!(o.tail_hwhm_multiple >= 1)) fail("tail_hwhm_multiple", "needs >= 1");
  if (!(o.tail_max_deg > 0 && o.tail_max_deg <= o.highlight_max_deg)) {
    fail("tail_max_deg", "needs 0 < tail_max_deg <= highlight_max_deg");
  }
  if (o.view_angles_deg.empty()) fail("view_angles_deg", "empty");
  for (double t : o.view_angles_deg) {
    if (!(t >= 0 && t < 90)) fail("view_angles_deg", fmt::format("{} outside [0, 90)", t));
  }
  if (o.albedo_theta_steps < 8 || o.albedo_phi_steps < 8) fail("albedo_theta_steps", ">= 8");
  if (o.model_strata_per_axis < 1) fail("model_strata_per_axis", "needs >= 1");
}

}  // namespace

ProbeResult BrdfSpaceProbe(const reference_images::MeasuredBrdf& measured,
                           const std::vector<ModelUnderTest>& models, const BrdfSpaceOptions& o) {
  ValidateOptions(o);
  for (const ModelUnderTest& m : models) {
    internal::ValidateModel(m);
    if (m.label == "measured") throw Error(m.label, "label", "reserved for the measured BRDF");
  }
  std::vector<SeriesResult> series;
  auto run = [&](const std::string& label, bool is_measured, const BrdfFn& f,
                 const ModelUnderTest* m) {
    SeriesResult s;
    s.label = label;
    s.measured = is_measured;
    s.highlight = MeasureHighlight(f, o);
    s.fresnel = MeasureFresnel(f, s.highlight.floor, o);
    s.albedo = is_measured ? MeasuredAlbedo(f, o) : ModelAlbedo(*m, o);
    series.push_back(std::move(s));
  };
  run(
      "measured", true,
      [&measured](const Vec3d& wi, const Vec3d& wo) { return measured.Eval(wi, wo); }, nullptr);
  for (const ModelUnderTest& m : models) run(m.label, false, ModelBrdf(m), &m);

  ProbeResult r(ProbeKind::kBrdf);
  for (const SeriesResult& s : series) {
    nlohmann::json n = SeriesNumbers(s);
    if (!s.measured) n["vs_measured"] = Comparison(s, series.front());
    r.numbers[s.label] = n;
    AddSeriesCurves(s, o, &r.curves);
  }
  const auto& m = series.front();
  r.notes.push_back(fmt::format("measured BRDF: {} ({})", fmt::join(measured.SourceFiles(), ", "),
                                measured.Format()));
  r.notes.push_back(fmt::format(
      "Fresnel rise: theta_h = 0, theta_d = 0..{:g} step {:g} deg; centre band [{:g}, {:g}], rim "
      "band [{:g}, {:g}] deg; rim_centre_ratio_to_limit cuts the rim band at {:g} deg",
      o.fresnel_max_deg, o.fresnel_step_deg, o.centre_min_deg, o.centre_max_deg, o.rim_min_deg,
      o.rim_max_deg, std::min(o.rim_max_deg, o.extrapolated_theta_d_deg)));
  r.notes.push_back(fmt::format(
      "highlight: theta_d = {:g} deg, phi_d = 90 deg; floor = min f over theta_h in [{:g}, {:g}] "
      "deg (measured: {:.4g} 1/sr); HWHM of (f - floor) n.l n.v; tail beyond {:g} HWHM up to "
      "{:g} deg, weighted by sin cos theta_h",
      o.highlight_theta_d_deg, o.floor_min_deg, o.floor_max_deg, m.highlight.floor,
      o.tail_hwhm_multiple, o.tail_max_deg));
  r.notes.push_back(fmt::format(
      "extrapolation: MERL data beyond theta_d = {:g} deg is extrapolated; measured Fresnel "
      "points beyond it are marked, {:.0f}% of the rim band lies there; measured albedo points "
      "with more than {:g}% of their value from there are marked (views: {})",
      o.extrapolated_theta_d_deg, 100 * m.fresnel.rim_extrapolated_fraction,
      100 * o.extrapolated_point_fraction,
      r.numbers["measured"]["albedo_extrapolated_views_deg"].dump()));
  r.notes.push_back(fmt::format(
      "albedo: measured by half-vector quadrature {}x{}; models by DirectionalAlbedo, {}^2 strata",
      o.albedo_theta_steps, o.albedo_phi_steps, o.model_strata_per_axis));
  for (const SeriesResult& s : series) {
    if (!std::isfinite(s.highlight.hwhm_deg)) {
      r.notes.push_back(s.label +
                        ": no half-width (no specular part above the floor, or it "
                        "does not fall to half before the end of the slice)");
    }
  }
  return r;
}

}  // namespace shadefit::probes
