#include "prepared_reference.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "shadefit/base/error.h"
#include "shadefit/base/statistics.h"

namespace shadefit::fit::internal {
namespace {

// Reference alpha counts as full coverage from here (float EXRs store 1 exactly; half would too).
constexpr float kFullCoverage = 1.0f - 1e-5f;
// Our G-buffer's coverage a pixel needs (its camera samples all hit): ShadeScene's points and
// UsablePixels' pixels.
constexpr float kGBufferCoverage = 1.0f;

std::string LabelOf(const FitReference& ref) {
  return ref.image_path.empty() ? ref.name : ref.image_path;
}

// The image's channels and size, and the mask's size, against the scene (Error naming the file).
void CheckSizes(const FitReference& ref) {
  const std::string label = LabelOf(ref);
  const Image& image = ref.image;
  if (image.channels < 3) {
    throw Error(label, "channels", fmt::format("expected RGB or RGBA, got {}", image.channels));
  }
  if (image.width != ref.scene.camera.width || image.height != ref.scene.camera.height_px) {
    throw Error(label, "resolution",
                fmt::format("image is {}x{} but its scene renders {}x{}", image.width, image.height,
                            ref.scene.camera.width, ref.scene.camera.height_px));
  }
  if (!ref.mask.empty() && (ref.mask.width != image.width || ref.mask.height != image.height)) {
    throw Error(ref.mask_path.empty() ? label : ref.mask_path, "resolution",
                "mask and reference differ in size");
  }
}

// Which of the G-buffer's fully covered pixels a fit uses: the reference's rule, shared by
// PrepareFrom and UsablePixels. visit(x, y, rgb) is called on each used pixel in the order met;
// the reference's degenerate cases throw DegenerateReferenceError after the last.
class PixelRule {
 public:
  explicit PixelRule(const FitReference& ref) : ref_(ref) {}

  // False for a pixel the fit leaves out; rgb receives the used pixel's value.
  bool Use(int x, int y, double rgb[3]) {
    const Image& image = ref_.image;
    if (image.channels >= 4 && !(image.at(x, y, 3) >= kFullCoverage)) return false;
    if (!ref_.mask.empty() && !(ref_.mask.at(x, y, 0) > 0.5f)) return false;
    bool finite = true, clipped = false;
    for (int c = 0; c < 3; ++c) {
      rgb[c] = image.at(x, y, c);
      finite = finite && std::isfinite(rgb[c]);
      clipped = clipped || rgb[c] >= ref_.clip_level;
    }
    if (!finite) {
      if (non_finite_++ == 0) first_x_ = x, first_y_ = y;
      return false;
    }
    if (clipped) return false;
    ++used_;
    for (int c = 0; c < 3; ++c) any_light_ = any_light_ || rgb[c] > 0;
    return true;
  }

  // Throws when a used pixel was not finite, none was used, or all were black.
  void Check() const {
    const std::string label = LabelOf(ref_);
    if (non_finite_ > 0) {
      throw DegenerateReferenceError(
          label, "pixels",
          fmt::format("{} non-finite (NaN or infinite) pixel(s) on the object, first at ({}, {})",
                      non_finite_, first_x_, first_y_));
    }
    if (used_ == 0) {
      throw DegenerateReferenceError(
          label, "pixels",
          "nothing to fit: no pixel is fully covered in both the reference and the scene, inside "
          "the mask and unclipped");
    }
    if (!any_light_) {
      throw DegenerateReferenceError(
          label, "pixels", fmt::format("nothing to fit: all {} valid pixels are black", used_));
    }
  }

 private:
  const FitReference& ref_;
  int non_finite_ = 0, first_x_ = -1, first_y_ = -1;
  std::size_t used_ = 0;
  bool any_light_ = false;
};

}  // namespace

void SubsampleForEnvironment(PreparedReference* r, int want) {
  r->all_pixels = r->pixels;
  r->all_linear = r->linear;
  const std::size_t n = r->points.size();
  if (static_cast<long>(n) <= want) return;
  std::vector<double> norms(n);
  for (std::size_t k = 0; k < n; ++k) {
    norms[k] = std::hypot(r->linear[3 * k], r->linear[3 * k + 1], r->linear[3 * k + 2]);
  }
  std::vector<double> sorted = norms;
  const double p90 = Percentile(sorted, 0.9);
  std::size_t bright = 0;
  for (double v : norms) bright += v >= p90 ? 1 : 0;
  const std::size_t half = static_cast<std::size_t>(want) / 2;
  const std::size_t bright_stride = std::max<std::size_t>(1, (bright + half - 1) / half);
  const std::size_t dim_stride = std::max<std::size_t>(1, (n - bright + half - 1) / half);
  std::vector<ShadingPoint> points;
  std::vector<int> pixels;
  std::vector<double> linear;
  std::size_t bright_seen = 0, dim_seen = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const bool is_bright = norms[k] >= p90;
    const std::size_t seen = is_bright ? bright_seen++ : dim_seen++;
    if (seen % (is_bright ? bright_stride : dim_stride) != 0) continue;
    points.push_back(std::move(r->points[k]));
    pixels.push_back(r->pixels[k]);
    for (int c = 0; c < 3; ++c) linear.push_back(r->linear[3 * k + c]);
  }
  r->points = std::move(points);
  r->pixels = std::move(pixels);
  r->linear = std::move(linear);
}

std::vector<double> ProposalAlphas(ModelId model, const std::vector<double>& params, bool fitted) {
  const double alpha = SpecularLobeAlpha(model, params.data());
  if (!(alpha > 0)) return {};
  if (!fitted) return {0.02, 0.08, 0.3};
  const double a = std::clamp(alpha, 1e-3, 1.0);
  return {a, std::min(1.0, 3 * a)};
}

void AttachQuadrature(std::vector<PreparedReference>& refs, std::vector<double> lobe_alphas,
                      int samples) {
  EnvironmentQuadrature q;
  q.samples_per_technique = samples;
  q.lobe_alphas = std::move(lobe_alphas);
  for (PreparedReference& r : refs) {
    if (r.environment) AttachEnvironmentSamples(r.scene, q, &r.points);
  }
}

ShadedScene ShadeScene(const FitReference& ref, Renderer& renderer, int environment_samples,
                       long* gbuffer_renders) {
  ShadedScene out;
  out.scene = ref.scene;
  if (environment_samples > 0) {
    for (Light& light : out.scene.lights) light.samples = environment_samples;
  }
  CheckSizes(ref);
  const GBuffer gbuffer = renderer.RenderGBuffer(out.scene);
  ++*gbuffer_renders;
  out.points = PrepareShading(out.scene, gbuffer, kGBufferCoverage);
  return out;
}

PreparedReference Prepare(const FitReference& ref, Renderer& renderer, int environment_samples,
                          long* gbuffer_renders) {
  return PrepareFrom(ref, ShadeScene(ref, renderer, environment_samples, gbuffer_renders));
}

PreparedReference PrepareFrom(const FitReference& ref, ShadedScene shaded) {
  PreparedReference out;
  out.source = &ref;
  out.label = LabelOf(ref);
  out.scene = std::move(shaded.scene);
  const Image& image = ref.image;
  std::vector<ShadingPoint>& all = shaded.points;
  std::vector<double> norms;
  norms.reserve(all.size());
  out.points.reserve(all.size());
  out.pixels.reserve(all.size());
  out.linear.reserve(3 * all.size());
  PixelRule rule(ref);
  for (ShadingPoint& sp : all) {
    double rgb[3];
    if (!rule.Use(sp.x, sp.y, rgb)) continue;
    for (int c = 0; c < 3; ++c) out.linear.push_back(rgb[c]);
    norms.push_back(std::sqrt(rgb[0] * rgb[0] + rgb[1] * rgb[1] + rgb[2] * rgb[2]));
    out.pixels.push_back(sp.y * image.width + sp.x);
    out.points.push_back(std::move(sp));
  }
  rule.Check();
  std::sort(norms.begin(), norms.end());
  out.p99_norm = norms[static_cast<std::size_t>(0.99 * (norms.size() - 1))];
  return out;
}

UsablePixelValues UsablePixels(const FitReference& ref, Renderer& renderer) {
  CheckSizes(ref);
  const GBuffer g = renderer.RenderGBuffer(ref.scene);
  UsablePixelValues out;
  PixelRule rule(ref);
  for (int y = 0; y < g.height; ++y) {  // PrepareShading's points, in its order.
    for (int x = 0; x < g.width; ++x) {
      if (!g.Hit(x, y) || g.Coverage(x, y) < kGBufferCoverage) continue;
      double rgb[3];
      if (!rule.Use(x, y, rgb)) continue;
      for (int c = 0; c < 3; ++c) out.linear.push_back(rgb[c]);
      out.pixels.push_back(y * ref.image.width + x);
    }
  }
  rule.Check();
  return out;
}

RendererHolder::RendererHolder(Renderer* given) {
  if (given) {
    renderer = given;
    return;
  }
  context = std::make_unique<GlContext>();
  context->MakeCurrent();
  owned = std::make_unique<Renderer>(*context);
  renderer = owned.get();
}

}  // namespace shadefit::fit::internal
