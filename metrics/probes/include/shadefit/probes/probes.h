// Phenomenon probes: measurements of one physical effect each (Fresnel rim, highlight shape,
// energy conservation, portability across lighting) on references and on models rendered under
// the references' scenes (docs/probes.md).
//
// Inputs: references are RGBA linear radiance (HDR), alpha = coverage, premultiplied, with the
// scene and G-buffer that made them. Models are rendered with the GL renderer (times exposure)
// when ProbeInputs::renderer is set, otherwise with the C++ twin (point/directional/ambient
// lights only). Scalars over colour use linear luminance Y = 0.2126 R + 0.7152 G + 0.0722 B
// (ITU-R BT.709). Bad input throws shadefit::Error "<reference or label>: <field>: <problem>".
#pragma once

#include <nlohmann/json.hpp>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "shadefit/probes/probe_kind.h"
#include "shadefit/render/gbuffer.h"
#include "shadefit/render/image.h"
#include "shadefit/render/renderer.h"
#include "shadefit/render/scene.h"

namespace shadefit::reference_images {
class MeasuredBrdf;  // reference_images/measured_brdf.h
}

namespace shadefit::probes {

struct ProbeReference {  // one image of the material under one lighting
  std::string name;      // e.g. "gold-key"
  std::string lighting;  // e.g. "key", "camera", "side", "rim", "env", "mirror75"
  Image image;           // RGBA linear radiance, alpha = coverage (premultiplied)
  Scene scene;
  GBuffer gbuffer;  // from Renderer::RenderGBuffer(scene)
};

// "gold-mirror75" -> "mirror75": the text after a reference name's last '-'.
std::string LightingOfReference(const std::string& name);

// A reference read with reference_images::LoadReference, its G-buffer rendered, and an RGB image
// given the G-buffer's coverage as alpha. Throws shadefit::Error naming the file and field.
ProbeReference LoadProbeReference(const std::string& path, Renderer& renderer);

struct ModelUnderTest {                 // a model with parameters: a fit, or the truth
  std::string label;                    // "ggx", "blinn-phong", "truth", ...
  ModelRef model;                       // resolved where its name was given (FindModel)
  std::vector<double> params;           // flattened, natural units
  double exposure = 1.0;                // global scale applied to renders
  std::vector<std::string> trained_on;  // reference names used to fit it (portability)
};

// The Cycles material of the reference whose sidecar is `sidecar_path` as one of our models,
// labelled "truth" (reference_images::TruthOfSidecar, the one mapping); nullopt when it has no
// exact twin, with the reason in `why_not` (when given). The probe command, the study's probe
// job and the Python module all take the truth from here.
std::optional<ModelUnderTest> TruthOfReference(const std::string& sidecar_path,
                                               std::string* why_not = nullptr);

// Renders of models under references, kept for the other probes of the same inputs: the
// Fresnel, highlight and portability probes each render every model under every reference, the
// same image three times. Found by the model's label, name, parameters and exposure and the
// reference's name (names are unique among one ProbeInputs' references). Renders past the byte
// budget are not kept (a photo set of 96 frames of 612x512 makes 5 MB per render): they are
// rendered again when asked. Not thread-safe: one per ProbeInputs, used on the thread that
// renders.
class ModelRenders {
 public:
  explicit ModelRenders(std::size_t byte_budget = std::size_t{512} << 20)
      : budget_(byte_budget) {}
  // The kept render, or null.
  const Image* Find(const ModelUnderTest& model, const ProbeReference& reference) const;
  // Keeps a copy of `image` while the kept renders stay within the budget.
  void Keep(const ModelUnderTest& model, const ProbeReference& reference, const Image& image);
  std::size_t size() const { return renders_.size(); }

 private:
  struct Key {
    std::string label, model, reference;
    std::vector<double> params;
    double exposure = 1.0;
    auto operator<=>(const Key&) const = default;
  };
  static Key KeyOf(const ModelUnderTest& model, const ProbeReference& reference);
  std::size_t budget_, bytes_ = 0;
  std::map<Key, Image> renders_;
};

struct ProbeInputs {
  std::vector<ProbeReference> references;
  std::vector<ModelUnderTest> models;
  std::optional<ModelUnderTest> truth;  // the true BRDF as one of our models when known
  Renderer* renderer = nullptr;         // GL context current on the calling thread
  const reference_images::MeasuredBrdf* measured_brdf =
      nullptr;  // the BRDF itself (brdf probe only)
  // Optional: keeps each model's render under each reference for the next probe of these
  // inputs (a study's probe job runs several). The numbers are the same without it.
  ModelRenders* renders = nullptr;
};

// What a curve measures. CurveKindName is the curve's "kind" in the JSON and its panel's title.
enum class CurveKind {
  kSpecularVsThetaV,  // Fresnel: mean specular luminance per theta_v bin, per reference.
  kFresnelVsThetaD,   // Fresnel: effective F per theta_d bin, pooled over references.
  kFalloff,           // Highlight: specular / peak per theta_h bin, per reference.
  kAlbedo,            // Energy: E(theta_o) by quadrature (DirectionalAlbedo).
  kWhiteFurnace,      // Energy: E(theta_v) read off the GL white-furnace render.
  kLobeWidthSweep,    // Energy: specular albedo at normal view over the shininess list.
  kRmsePerReference,  // Portability: RMSE under each reference's lighting.
  // BRDF space (brdf_space.h): read off the BRDF itself, no image.
  kFresnelRise,        // (f - floor) cos^2 theta_d / centre mean at theta_h = 0, vs theta_d.
  kSpecularPeak,       // f(theta_h = 0, theta_d), vs theta_d (log y).
  kHighlightF,         // f against theta_h on the small-theta_d slice (log y).
  kHighlightSpecular,  // (f - floor) n.l n.v / peak against theta_h on that slice (log y).
  kBrdfAlbedo,         // E(theta_o) of the BRDF: half-vector quadrature or DirectionalAlbedo.
};

// "specular vs theta_v", "F vs theta_d", "falloff", "albedo (quadrature)", "white furnace (GL)",
// "sweep of the lobe width", "RMSE per reference", "Fresnel rise", "specular peak",
// "highlight f", "highlight specular", "directional albedo".
const char* CurveKindName(CurveKind kind);

enum class AxisScale { kLinear, kLog };

// One curve, typed until WriteProbeOutputs / ProbeResultToJson write it. Every member has an
// initializer so that designated initializers may leave any of them out (-Wextra).
struct ProbeCurve {
  std::string series{};     // Whose: "reference", "truth", a model's label, or a sweep series.
  std::string reference{};  // The reference it was measured on; empty when pooled or BRDF-only.
  std::string lighting{};   // That reference's lighting, a field of its own (never parsed out).
  CurveKind kind = CurveKind::kAlbedo;
  std::vector<double> x{}, y{};  // Same length; non-finite values are written as null.
  std::string x_label{}, y_label{};
  AxisScale x_scale = AxisScale::kLinear, y_scale = AxisScale::kLinear;
  std::vector<std::string> x_ticks{};  // Names of x = 0, 1, ... when x is an index; else empty.
  // Per point: true where the value depends on data outside what was measured (MERL beyond
  // theta_d = 75 deg, brdf_space.h). Empty when no point is; else the length of x.
  std::vector<bool> extrapolated{};
};

struct ProbeResult {
  explicit ProbeResult(ProbeKind kind) : probe(kind) {}
  ProbeKind probe;
  nlohmann::json numbers = nlohmann::json::object();  // {"reference": {...}, "<label>": {...},
                                                      //  ...} named scalars
  std::vector<ProbeCurve> curves;                     // In the order they were measured.
  std::vector<std::string> notes;  // What was measured, assumptions, skipped inputs.
};

// The curve of `kind` for `series` on `reference` (empty: pooled); null when there is none.
const ProbeCurve* FindCurve(const ProbeResult& result, CurveKind kind, std::string_view series,
                            std::string_view reference = {});

// ---------------------------------------------------------------------------------------------
// Fresnel rim. Per pixel (coverage >= min_coverage, twin-supported scenes only): specular
// luminance = image - diffuse estimate. The diffuse estimate is the truth's diffuse term for the
// reference (when ProbeInputs::truth is set), the model's own diffuse term for a model, and
// otherwise a Lambert fit kd * S(x) with S the Lambert shading of the scene for kd = 1 and kd the
// diffuse_percentile-th percentile of Y / S (robust to a highlight that covers few pixels).
// Curves: mean specular luminance per theta_v = acos(n.v) bin, per reference; and the effective
// Fresnel F(theta_d) = sum(specular) / sum(unit-Fresnel lobe) per theta_d = acos(l.h) bin,
// pooled over references, where the lobe is the same BRDF's specular term with F = 1 (its
// own for a model, the truth's for the reference; skipped without truth).
struct FresnelOptions {
  double bin_width_deg = 5.0;          // Width of the theta_v and theta_d bins (degrees), 0..90.
  double centre_max_deg = 20.0;        // "Centre" band: theta <= this (degrees).
  double rim_min_deg = 70.0;           // "Rim" band: theta >= this (degrees).
  double min_coverage = 0.999;         // Pixels with lower coverage (edges) are skipped.
  double lobe_min_fraction = 0.05;     // theta_d bins use pixels whose unit-Fresnel lobe is at
                                       // least this fraction of the image's largest lobe value.
  double diffuse_percentile = 25.0;    // No truth: kd = this percentile of Y / S (see above).
  std::vector<std::string> lightings;  // Use only these lightings; empty = every reference
                                       // whose scene the twin supports (env is skipped).
};

// ---------------------------------------------------------------------------------------------
// Highlight shape, per reference (twin-supported scenes) and per image (reference, models):
// specular luminance s(x) as in the Fresnel probe; theta_h = acos(n.h) for the pixel's dominant
// light. Mirror pixel: smallest theta_h. Peak: largest s. Half-max region: 4-connected pixels
// with s >= peak / 2 around the peak; area, equivalent FWHM in pixels 2 sqrt(area / pi), and
// the s-weighted second moments of the region (ellipse aspect >= 1, orientation in degrees from
// +x, counter-clockwise, y up). Radial falloff: mean s / peak per theta_h bin (log scale);
// HWHM = theta_h where it first falls to 1/2 (linear interpolation); tail fraction = sum of s
// over theta_h > tail_hwhm_multiple * HWHM over the sum of s (pixel sums, image space).
struct HighlightOptions {
  double falloff_bin_deg = 0.5;      // theta_h bin width of the radial falloff (degrees).
  double falloff_max_deg = 60.0;     // Falloff curve range: theta_h in [0, this).
  double tail_hwhm_multiple = 2.0;   // Tail = theta_h beyond this many HWHM.
  double min_coverage = 0.999;       // Pixels with lower coverage (edges) are skipped.
  double diffuse_percentile = 25.0;  // No truth: Lambert-fit diffuse estimate (FresnelOptions).
  // A reference whose specular peak is below this fraction of its brightest pixel has no
  // highlight (render noise on a Lambert material): no shape numbers, verdicts not applicable.
  double min_peak_fraction = 0.05;
  std::vector<std::string> lightings;  // Use only these lightings; empty = every twin-supported.
};

// ---------------------------------------------------------------------------------------------
// Energy. Directional albedo E(theta_o) of every model (and the truth) by DirectionalAlbedo;
// strata are doubled until every channel's std error is <= target_std_error (or
// max_strata_per_axis). Verdict: "conserves" when max albedo (over angles and channels) <=
// 1 + 3 sigma, else "violates". White furnace: a unit sphere under a uniform light of radiance 1
// rendered with GL (skipped without renderer). Sweep: specular-only albedo at normal view of
// classic Blinn-Phong (ks = 1), normalised Blinn-Phong (ks = 1) and GGX (f0 = 1, roughness from
// n = 2 / alpha^2 - 2, Walter et al. 2007 sec. 5.2) over the shininess list.
struct EnergyOptions {
  std::vector<double> view_angles_deg = {0, 10, 20, 30, 40, 50, 60, 70, 80, 85, 89};  // theta_o.
  int strata_per_axis = 128;       // Starting strata per axis (samples = strata^2 per
                                   // technique, two techniques).
  int max_strata_per_axis = 512;   // Upper limit of the doubling.
  double target_std_error = 1e-3;  // Per channel and angle (one sigma).
  double sigma_multiple = 3.0;     // Verdict threshold 1 + sigma_multiple * sigma.
  int furnace_resolution = 64;     // White-furnace render, pixels per side.
  int furnace_samples = 256;       // Uniform-light samples per technique per pixel.
  std::vector<double> sweep_shininess = {1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 5000};
  int sweep_strata_per_axis = 256;  // Strata of the sweep's albedo estimates.
};

// ---------------------------------------------------------------------------------------------
// Portability across lighting. Every model with a non-empty trained_on is rendered under every
// reference's scene (times exposure); RMSE (linear radiance, RGB) over pixels with coverage >=
// min_coverage in both the reference and the render. Train = references named in trained_on,
// test = the others; pooled RMSE over each set's pixels and their ratio test / train. The truth,
// when given, is evaluated on every reference as the noise floor.
struct PortabilityOptions {
  double min_coverage = 0.999;  // "Coverage 1 in both" with float tolerance.
};

ProbeResult FresnelProbe(const ProbeInputs& inputs, const FresnelOptions& options = {});
ProbeResult HighlightProbe(const ProbeInputs& inputs, const HighlightOptions& options = {});
ProbeResult EnergyProbe(const ProbeInputs& inputs, const EnergyOptions& options = {});
ProbeResult PortabilityProbe(const ProbeInputs& inputs, const PortabilityOptions& options = {});

// The probe of `kind` with its default options.
ProbeResult RunProbe(ProbeKind kind, const ProbeInputs& inputs);

// The schema of ProbeResultToJson's object. 3: a curve may carry "extrapolated" flags; 2:
// "curves" is a list of records (1, unnamed: an object keyed "<series> @ <reference>: <kind>").
inline constexpr const char* kProbeResultSchema = "shadefit.probe/4";

// {"schema": kProbeResultSchema, "probe": name, "numbers": {...}, "curves": [{"series",
// "reference" (null when pooled), "kind", "x", "y", "x_label", "y_label", "x_scale", "y_scale"
// ("linear" or "log"), "x_ticks", and "extrapolated" (per point, only when some point is)}, ...],
// "notes": [...]}; non-finite numbers are null. The only
// place a result becomes JSON (docs/probes.md).
nlohmann::json ProbeResultToJson(const ProbeResult& result);

// Writes <dir>/<probe>.png, a plot of the curves (one panel per distinct (x_label, y_label),
// drawn by /usr/bin/python3 with matplotlib), then <dir>/<probe>.json, each through the atomic
// writer (base/files.h); when either fails, neither is left. Throws shadefit::Error naming the
// path.
// plot = false: only the JSON (a study's report draws its own figures from it).
void WriteProbeOutputs(const ProbeResult& result, const std::string& dir, bool plot = true);

// Checks one reference: non-empty RGBA image, its size equals the G-buffer's and the scene
// camera's, finite pixels, at least one pixel with coverage >= min_coverage. Throws
// shadefit::Error "<name>: <field>: <problem>".
void ValidateReference(const ProbeReference& reference, double min_coverage);

}  // namespace shadefit::probes
