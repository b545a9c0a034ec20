#include "shadefit/reference_images/render_measured.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <thread>

#include "shadefit/base/cpus.h"
#include "shadefit/base/files.h"
#include "shadefit/render/brdf.h"
#include "shadefit/render/environment.h"
#include "shadefit/render/shadows.h"
#include "shadefit/base/error.h"

namespace shadefit::reference_images {
namespace {

// Same offset as kRayEpsilon in render/shaders/render.frag and gbuffer_shading.cpp.
constexpr double kRayEpsilon = 1e-4;

// SplitMix64 (Steele, Lea, Flood 2014, "Fast Splittable Pseudorandom Number Generators"): one
// independent stream per pixel, seeded from (seed, pixel index), so results do not depend on
// which thread shades which pixel.
class PixelRng {
 public:
  PixelRng(std::uint64_t seed, std::uint64_t pixel)
      : state_(seed ^ (pixel * 0x9E3779B97F4A7C15ull + 0x632BE59BD9B4E019ull)) {
    Next();
  }
  std::uint64_t Next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }  // [0, 1)

 private:
  std::uint64_t state_;
};

// Orthonormal frame around n (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
// The tangent's azimuth is arbitrary: every BRDF here is isotropic.
struct Frame {
  Vec3d t, b, n;
  explicit Frame(const Vec3d& normal) : n(normal) {
    const double sign = std::copysign(1.0, n.z);
    const double a = -1.0 / (sign + n.z);
    const double bb = n.x * n.y * a;
    t = {1.0 + sign * n.x * n.x * a, sign * bb, -sign * n.x};
    b = {bb, sign + n.y * n.y * a, -n.y};
  }
  Vec3d ToLocal(const Vec3d& v) const { return {Dot(v, t), Dot(v, b), Dot(v, n)}; }
  Vec3d ToWorld(const Vec3d& v) const { return t * v.x + b * v.y + n * v.z; }
};

// GGX distribution of normals (Walter et al. 2007, eq. 33), cos theta_h = h.z.
double D_GGX(double alpha, double NoH) {
  const double a2 = alpha * alpha;
  const double d = NoH * NoH * (a2 - 1.0) + 1.0;
  return a2 / (kPi * d * d);
}

// Density over solid angle of wi when h is drawn from D(h) cos(theta_h) and wi is wo reflected
// about h: p(h) / (4 |wo.h|) (Walter et al. 2007, eqs. 14 and 38).
double LobePdf(double alpha, const Vec3d& wi, const Vec3d& wo) {
  const Vec3d h = Normalize(wi + wo);
  const double woh = std::abs(Dot(wo, h));
  if (h.z <= 0 || woh <= 0) return 0.0;
  return D_GGX(alpha, h.z) * h.z / (4.0 * woh);
}

// wi for one draw of h ~ D(h) cos(theta_h): tan^2 theta_h = alpha^2 u1 / (1 - u1) (Walter et al.
// 2007, eqs. 35 and 36).
Vec3d SampleLobe(double alpha, const Vec3d& wo, double u1, double u2) {
  const double tan2 = alpha * alpha * u1 / std::max(1.0 - u1, 1e-12);
  const double cos_t = 1.0 / std::sqrt(1.0 + tan2),
               sin_t = std::sqrt(std::max(0.0, 1 - cos_t * cos_t));
  const double phi = 2.0 * kPi * u2;
  const Vec3d h{sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t};
  return h * (2.0 * Dot(wo, h)) - wo;
}

// BT.709 luminance: the weight of each channel in a pixel's extrapolated share.
double Luminance(const Vec3d& c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }

// Whether a light or sample direction wi makes f(wi, wo) depend on data beyond the measured
// domain: it must reach the surface (both directions above the horizon, where Eval reads the
// table at all) and lie beyond the limit.
bool Extrapolated(const Vec3d& wi, const Vec3d& wo) {
  return wi.z > 0 && wo.z > 0 && !InMeasuredDomain(wi, wo);
}

// The extrapolated share as the domain file stores it: 8-bit codes, share = code / 255.
Image QuantiseShare(const Image& share) {
  Image out = share;
  for (float& v : out.data) v = std::round(std::clamp(v, 0.0f, 1.0f) * 255.0f) / 255.0f;
  return out;
}

}  // namespace

double EstimateLobeAlpha(const MeasuredBrdf& brdf) {
  // Luminance of f along theta_h at theta_d = 0.1 rad, phi_d = 0 (off the exact retro direction).
  auto lum = [&](double theta_h) {
    Vec3d wi, wo;
    FromHalfDiff(theta_h, 0.1, 0.0, &wi, &wo);
    const Vec3d f = brdf.Eval(wi, wo);
    return 0.2126 * f.x + 0.7152 * f.y + 0.0722 * f.z;
  };
  const double peak = lum(0.0), far = lum(kPi / 3);
  if (!(peak > 4.0 * far) || !(peak > 0)) return 0.0;  // no specular peak worth sampling
  // For GGX, D(theta_h) falls to half of D(0) at tan^2 theta = (sqrt(2) - 1) alpha^2, i.e.
  // theta_half = 0.644 alpha for small alpha: alpha = theta_half / 0.644.
  const double half = far + 0.5 * (peak - far);
  for (double t = 0.0005; t < kPi / 3; t *= 1.05) {
    if (lum(t) <= half) return std::clamp(t / 0.644, 0.005, 1.0);
  }
  return 1.0;
}

std::string SidecarPath(const std::string& exr_path) {
  return std::filesystem::path(exr_path).replace_extension(".json").string();
}

std::string DomainPath(const std::string& exr_path) {
  return std::filesystem::path(exr_path).replace_extension(".domain.png").string();
}

namespace {

// What every pixel of one measured render shares: the BRDF, the scene and its G-buffer, and the
// distant light with the way it is sampled.
struct MeasuredShading {
  const MeasuredBrdf& brdf;
  const Scene& scene;
  const GBuffer& g;
  const DistantLight& distant;
  int n_samples;       // Per technique; 0 without a distant light.
  double lobe_alpha;   // Of the GGX lobe technique; 0 leaves it out.
  bool occlusion;      // Whether another object can block a sample ray.
  std::uint64_t seed;  // Of the per-pixel random streams.
};

// One shaded pixel: its radiance, the standard error of its Monte Carlo part, and the share of
// it that depends on the BRDF beyond the measured domain.
struct ShadedPixel {
  Vec3d radiance{0, 0, 0};
  Vec3d se{0, 0, 0};
  float share = 0;
};

// The distant light, set up from the scene's environment light (none: no samples); fills the
// stats' environment, samples and ambient fields.
DistantLight DistantLightOf(const Scene& scene, int env_index, const RenderMeasuredOptions& options,
                            RenderMeasuredStats* stats) {
  for (const Light& light : scene.lights) {
    if (light.type == Light::Type::kAmbient) stats->ambient_ignored = true;
  }
  DistantLight distant;
  if (env_index >= 0) {
    const Light& light = scene.lights[env_index];
    stats->environment = true;
    if (light.type == Light::Type::kEnvironment) {
      distant.map = LoadEnvironmentCached(light.file, light.strength, light.rotation_z_deg);
    } else {
      distant.uniform = light.value;
    }
    stats->samples_per_technique = options.samples > 0 ? options.samples : light.samples;
    if (stats->samples_per_technique < 2) {
      throw Error(scene.path, "samples", "need at least 2 samples per technique (noise estimate)");
    }
  }
  return distant;
}

// Background of uncovered pixels (and of partly covered ones, weighted by 1 - coverage).
void FillBackground(const Scene& scene, const GBuffer& g, const DistantLight& distant,
                    int env_index, Image* out) {
  if (scene.background.transparent) return;
  for (int y = 0; y < g.height; ++y) {
    for (int x = 0; x < g.width; ++x) {
      const Ray ray = CameraRay(scene.camera, x + 0.5, y + 0.5);
      const Vec3d bg = distant.map      ? distant.map->Radiance(ray.direction)
                       : env_index >= 0 ? distant.uniform
                                        : scene.background.color;
      const double w = 1.0 - g.Coverage(x, y);
      for (int c = 0; c < 3; ++c) out->at(x, y, c) = static_cast<float>(bg[c] * w);
      out->at(x, y, 3) = 1.0f;
    }
  }
}

// The distant light's Monte Carlo estimate at one point, added to `px`'s radiance, with its
// standard error; returns the sum over samples of the luminance of the extrapolated ones.
double EstimateDistant(const MeasuredShading& m, const ShadingPoint& sp, const Frame& frame,
                       const Vec3d& wo, ShadedPixel* px) {
  const GBuffer& g = m.g;
  double beyond_y = 0;  // Sum over samples of the luminance of the extrapolated ones.
  const Vec3d p{g.position.at(sp.x, sp.y, 0), g.position.at(sp.x, sp.y, 1),
                g.position.at(sp.x, sp.y, 2)};
  PixelRng rng(m.seed, static_cast<std::uint64_t>(sp.y) * g.width + sp.x);
  // One MIS sample of a world direction. With equal sample counts the balance heuristic
  // (Veach 1997, eq. 9.13) weights a sample by its pdf over the sum of all techniques'
  // pdfs, so each technique's weighted estimate is f L cos / (p_env + p_cos [+ p_lobe]).
  // Samples beyond the measured domain add their luminance to beyond_y.
  auto contribution = [&](const Vec3d& dir) -> Vec3d {
    const Vec3d wi = frame.ToLocal(dir);
    if (wi.z <= 0 || wo.z <= 0) return {0, 0, 0};
    double pdf = m.distant.Pdf(dir) + wi.z / kPi;
    if (m.lobe_alpha > 0) pdf += LobePdf(m.lobe_alpha, wi, wo);
    if (!(pdf > 0)) return {0, 0, 0};
    // Surface objects: the renderer's shadow rays (LightReaches); analytic ones as before.
    if (m.scene.ray_caster
            ? !LightReaches(m.scene, sp.object, sp.p, sp.n, dir, 1e30)
            : m.occlusion &&
                  Intersect(m.scene, Ray{p + sp.n * kRayEpsilon, dir}, 1e-4, 1e30, nullptr)) {
      return {0, 0, 0};
    }
    const Vec3d f = m.brdf.Eval(wi, wo);
    const Vec3d l = m.distant.Radiance(dir);
    const Vec3d c{f.x * l.x * wi.z / pdf, f.y * l.y * wi.z / pdf, f.z * l.z * wi.z / pdf};
    if (Extrapolated(wi, wo)) beyond_y += Luminance(c);
    return c;
  };
  // Welford running mean and variance of the per-pair estimate X_j (one sample of each
  // technique); the standard error of the mean is sqrt(var / N).
  const int n_samples = m.n_samples;
  double mean[3] = {0, 0, 0}, m2[3] = {0, 0, 0};
  for (int j = 0; j < n_samples; ++j) {
    const Vec3d d_env = m.distant.Sample(rng.Uniform(), rng.Uniform());
    // Cosine-weighted hemisphere (Malley's method).
    const double u1 = rng.Uniform(), u2 = rng.Uniform();
    const double r = std::sqrt(u1), phi = 2.0 * kPi * u2;
    const Vec3d d_cos =
        frame.ToWorld({r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0, 1.0 - u1))});
    Vec3d x = contribution(d_env) + contribution(d_cos);
    if (m.lobe_alpha > 0) {
      const Vec3d wi = SampleLobe(m.lobe_alpha, wo, rng.Uniform(), rng.Uniform());
      if (wi.z > 0) x += contribution(frame.ToWorld(wi));
    }
    for (int c = 0; c < 3; ++c) {
      const double delta = x[c] - mean[c];
      mean[c] += delta / (j + 1);
      m2[c] += delta * (x[c] - mean[c]);
    }
  }
  for (int c = 0; c < 3; ++c) {
    px->radiance[c] += mean[c];
    px->se[c] = std::sqrt(m2[c] / (n_samples - 1) / n_samples);
  }
  return beyond_y;
}

// Shades one point: point and directional lights exactly, the distant light by Monte Carlo.
ShadedPixel ShadePoint(const MeasuredShading& m, const ShadingPoint& sp) {
  ShadedPixel px;
  const Frame frame(sp.n);
  const Vec3d wo = frame.ToLocal(sp.v);
  // Point and directional lights: exact. PrepareShading already dropped lights below the
  // surface or occluded; E is the irradiance at normal incidence, so the cosine is applied.
  // One light beyond the measured domain makes the whole pixel extrapolated, whatever f is
  // there (the share must not depend on values the table only extrapolates).
  bool light_extrapolated = false;
  for (const PixelLight& light : sp.lights) {
    const Vec3d wi = frame.ToLocal(light.l);
    const Vec3d f = m.brdf.Eval(wi, wo);
    for (int c = 0; c < 3; ++c) px.radiance[c] += f[c] * light.irradiance[c] * wi.z;
    const bool lit = light.irradiance.x > 0 || light.irradiance.y > 0 || light.irradiance.z > 0;
    if (lit && Extrapolated(wi, wo)) light_extrapolated = true;
  }
  const double beyond_y = m.n_samples > 0 ? EstimateDistant(m, sp, frame, wo, &px) : 0.0;
  // The environment's extrapolated luminance (the mean of beyond_y over the sample sets)
  // over the pixel's whole radiance; 0 for a pixel that reflects nothing.
  const double total_y = Luminance(px.radiance);
  const double env_share =
      m.n_samples > 0 && total_y > 0 ? std::min(1.0, beyond_y / m.n_samples / total_y) : 0.0;
  px.share = light_extrapolated ? 1.0f : static_cast<float>(env_share);
  return px;
}

// The mean standard error and the relative one, over the shaded pixels, of an environment render.
void SummariseNoise(const std::vector<ShadingPoint>& points, const Image& out, const Image& error,
                    RenderMeasuredStats* stats) {
  if (!stats->environment || points.empty()) return;
  double mean_value = 0;
  for (const ShadingPoint& sp : points) {
    for (int c = 0; c < 3; ++c) {
      stats->mean_standard_error[c] += error.at(sp.x, sp.y, c) / points.size();
      mean_value += out.at(sp.x, sp.y, c) / (3.0 * points.size());
    }
  }
  const double mean_se = (stats->mean_standard_error[0] + stats->mean_standard_error[1] +
                          stats->mean_standard_error[2]) /
                         3.0;
  stats->relative_standard_error = mean_value > 0 ? mean_se / mean_value : 0.0;
}

}  // namespace

Image RenderMeasured(const MeasuredBrdf& brdf, const Scene& scene, const GBuffer& g,
                     const RenderMeasuredOptions& options, Image* standard_error,
                     RenderMeasuredStats* stats_out, Image* extrapolated_share) {
  const auto start = std::chrono::steady_clock::now();
  RenderMeasuredStats stats;
  const std::vector<ShadingPoint> points = PrepareShading(scene, g, 0.0f);
  const int env_index = scene.EnvironmentLight();
  const DistantLight distant = DistantLightOf(scene, env_index, options, &stats);
  const int n_samples = stats.samples_per_technique;
  const double lobe_alpha = !stats.environment        ? 0.0
                            : options.lobe_alpha >= 0 ? options.lobe_alpha
                                                      : EstimateLobeAlpha(brdf);
  stats.lobe_alpha = lobe_alpha;
  const bool occlusion = scene.objects.size() > 1 || scene.HasSurfaceObjects();
  const MeasuredShading shading{brdf,      scene,      g,         distant,
                                n_samples, lobe_alpha, occlusion, options.seed};

  Image out(g.width, g.height, 4);
  Image error(g.width, g.height, 3);
  Image share(g.width, g.height, 1);
  FillBackground(scene, g, distant, env_index, &out);

  std::atomic<std::size_t> next{0};
  auto worker = [&] {
    for (std::size_t idx = next++; idx < points.size(); idx = next++) {
      const ShadingPoint& sp = points[idx];
      const ShadedPixel px = ShadePoint(shading, sp);
      const float coverage = g.Coverage(sp.x, sp.y);
      for (int c = 0; c < 3; ++c) {
        out.at(sp.x, sp.y, c) += static_cast<float>(px.radiance[c] * coverage);
        error.at(sp.x, sp.y, c) = static_cast<float>(px.se[c] * coverage);
      }
      share.at(sp.x, sp.y, 0) = px.share;
      out.at(sp.x, sp.y, 3) = scene.background.transparent ? coverage : 1.0f;
    }
  };
  int threads = options.threads > 0 ? options.threads : UsableCpus();
  threads = std::clamp(threads, 1, 256);
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();

  stats.threads = threads;
  stats.shaded_pixels = static_cast<int>(points.size());
  SummariseNoise(points, out, error, &stats);
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (const ShadingPoint& sp : points) {
    if (share.at(sp.x, sp.y, 0) <= kExtrapolatedShareMax) ++stats.measured_pixels;
  }
  if (standard_error) *standard_error = std::move(error);
  if (extrapolated_share) *extrapolated_share = std::move(share);
  if (stats_out) *stats_out = stats;
  return out;
}

namespace {

// The outputs must be .exr files in existing folders; checked before any work.
void CheckMeasuredOutputs(const MeasuredReferenceRequest& request) {
  namespace fs = std::filesystem;
  for (const std::string* path : {&request.output, &request.noise_output}) {
    if (path->empty()) continue;
    if (fs::path(*path).extension() != ".exr") {
      throw Error(*path, "output", "the output must be an .exr file");
    }
    const fs::path parent = fs::path(*path).parent_path();
    if (!parent.empty() && !fs::is_directory(parent)) {
      throw Error(*path, "output", "output directory does not exist");
    }
  }
  if (request.output.empty()) throw Error("", "output", "no output file given");
}

// Covered pixels whose stored extrapolated share is within kExtrapolatedShareMax.
int CountMeasuredPixels(const GBuffer& gbuffer, const Image& share) {
  int measured = 0;
  for (int y = 0; y < gbuffer.height; ++y) {
    for (int x = 0; x < gbuffer.width; ++x) {
      if (gbuffer.Coverage(x, y) > 0 && share.at(x, y, 0) <= kExtrapolatedShareMax) {
        ++measured;
      }
    }
  }
  return measured;
}

// The sidecar's measured_domain record, but for the domain file's SHA-256 (added when written).
nlohmann::json MeasuredDomainJson(const std::string& domain_path,
                                  const RenderMeasuredStats& stats) {
  namespace fs = std::filesystem;
  nlohmann::json domain;
  domain["rule"] = kMeasuredDomainRule;
  domain["theta_d_max_deg"] = kMeasuredThetaDMaxDeg;
  domain["file"] = fs::path(domain_path).filename().string();  // relative to the sidecar
  domain["value"] =
      "8-bit grey, code / 255 = the share of the pixel's radiance (luminance) that depends on the "
      "BRDF beyond theta_d_max_deg; 0 where no surface is seen";
  domain["share"] = {
      {"point_directional",
       "exact: 1 when any light reaching the pixel is seen at theta_d beyond the limit, else 0 "
       "(independent of the BRDF's values)"},
      {"environment",
       "Monte Carlo: the share of the estimate's luminance from samples beyond "
       "the limit"}};
  domain["measured_share_max"] = kExtrapolatedShareMax;
  domain["counts"] = {{"covered", stats.shaded_pixels}, {"measured", stats.measured_pixels}};
  return domain;
}

// The sidecar of a measured reference: the BRDF and scene it was rendered from, how, its noise
// and its measured domain.
nlohmann::json MeasuredSidecar(const MeasuredReferenceRequest& request, const MeasuredBrdf& brdf,
                               const Scene& scene, const Image& image,
                               const RenderMeasuredStats& stats, const std::string& domain_path) {
  namespace fs = std::filesystem;
  nlohmann::json sidecar;
  sidecar["kind"] = "measured-brdf";
  sidecar["generator"] = "shadefit refs measured";
  sidecar["brdf"]["format"] = brdf.Format();
  if (brdf.Format() == "merl-binary") {
    sidecar["brdf"]["lookup"] = "trilinear in (sqrt theta_h index, theta_d, phi_d)";
  }
  for (const std::string& file : brdf.SourceFiles()) {
    sidecar["brdf"]["files"].push_back(
        {{"path", fs::absolute(file).lexically_normal().string()}, {"sha256", Sha256File(file)}});
  }
  sidecar["scene_file"] = fs::absolute(request.scene_path).lexically_normal().string();
  sidecar["scene_sha256"] = Sha256String(scene.source_text);
  sidecar["scene_toml"] = scene.source_text;
  sidecar["resolution"] = {image.width, image.height};
  sidecar["lights"]["point_directional"] = "exact per pixel";
  if (stats.environment) {
    sidecar["lights"]["environment"] =
        stats.lobe_alpha > 0
            ? "Monte Carlo: environment importance sampling + cosine hemisphere + GGX lobe "
              "sampling (alpha " +
                  fmt::format("{:.4g}", stats.lobe_alpha) + "), balance heuristic"
            : "Monte Carlo: environment importance sampling + cosine hemisphere, balance "
              "heuristic";
    sidecar["lobe_alpha"] = stats.lobe_alpha;
  }
  if (stats.ambient_ignored) sidecar["lights"]["ambient"] = "ignored (no ka for measured BRDFs)";
  sidecar["samples"] = stats.samples_per_technique;
  sidecar["seed"] = request.options.seed;
  sidecar["noise"]["mean_standard_error_rgb"] = {
      stats.mean_standard_error[0], stats.mean_standard_error[1], stats.mean_standard_error[2]};
  sidecar["noise"]["relative_standard_error"] = stats.relative_standard_error;
  sidecar["noise"]["over"] = "pixels with a G-buffer hit";
  sidecar["shaded_pixels"] = stats.shaded_pixels;
  sidecar["threads"] = stats.threads;
  sidecar["render_seconds"] = stats.seconds;
  sidecar["pixel_value"] = "RGB radiance at the pixel centre x coverage; A = coverage";
  sidecar["measured_domain"] = MeasuredDomainJson(domain_path, stats);
  return sidecar;
}

}  // namespace

RenderMeasuredStats MakeMeasuredReference(const MeasuredReferenceRequest& request,
                                          Renderer& renderer) {
  namespace fs = std::filesystem;
  const auto start = std::chrono::steady_clock::now();
  CheckMeasuredOutputs(request);
  const std::unique_ptr<MeasuredBrdf> brdf = LoadMeasuredBrdf(request.brdf_path);
  const Scene scene = LoadScene(request.scene_path);
  const GBuffer gbuffer = renderer.RenderGBuffer(scene);
  Image noise, share;
  RenderMeasuredStats stats;
  const Image image =
      RenderMeasured(*brdf, scene, gbuffer, request.options, &noise, &stats, &share);
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  // The counts are of the share as the file stores it, so that a reader of the file agrees.
  share = QuantiseShare(share);
  stats.measured_pixels = CountMeasuredPixels(gbuffer, share);

  const std::string domain_path = DomainPath(request.output);
  nlohmann::json sidecar = MeasuredSidecar(request, *brdf, scene, image, stats, domain_path);
  ImageMetadata meta{{"shadefit:kind", "measured-brdf"},
                     {"shadefit:brdf", fs::path(request.brdf_path).filename().string()},
                     {"shadefit:scene", scene.source_text},
                     {"shadefit:samples", std::to_string(stats.samples_per_technique)}};
  // Each write is atomic (temporary sibling + rename); when a later one fails, the earlier ones
  // are removed, so a failure leaves none of the outputs. The sidecar, last, records the domain
  // file's SHA-256, so that the study runner's hash of the sidecar covers the domain too.
  const std::string sidecar_path = SidecarPath(request.output);
  std::vector<OutputWrite> writes;
  writes.emplace_back(request.output, [&] { WriteExr(request.output, image, meta); });
  if (!request.noise_output.empty()) {
    writes.emplace_back(request.noise_output,
                        [&] { WriteExr(request.noise_output, noise, meta, {"R", "G", "B"}); });
  }
  writes.emplace_back(domain_path, [&] { WritePng8(domain_path, share); });
  writes.emplace_back(sidecar_path, [&] {
    sidecar["measured_domain"]["sha256"] = Sha256File(domain_path);
    WriteTextAtomic(sidecar_path, sidecar.dump(1) + "\n");
  });
  WriteAllOrNothing(writes);
  return stats;
}

}  // namespace shadefit::reference_images
