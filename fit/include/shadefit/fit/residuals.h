// The fitter's building blocks, public so tests can check them (GradientChecker): the
// reparametrisation of a model's parameter table and the two residual cost functions.
// Library users want fitter.h.
#pragma once

#include <ceres/ceres.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "shadefit/fit/fit_types.h"
#include "shadefit/render/gbuffer.h"
#include "shadefit/render/models.h"

namespace shadefit::fit {

// Internal coordinates u of one flattened parameter entry. Every row is double-bounded and
// mapped with the sine transform of MINUIT (F. James, "MINUIT Function Minimization and Error
// Analysis", CERN D506, sec. 1.3.1), applied to y = p or y = log p:
//     y = lower + (upper - lower) (sin u + 1) / 2,
// so u is unconstrained and Ceres needs no bounds. Why not Ceres' box bounds: its projected
// Levenberg-Marquardt step clips a coordinate at its bound but keeps the other coordinates'
// step, which was computed assuming the clipped one moves; coupled rows (metallic against
// base_color) then crawl along the bound (measured: aluminium, metallic 1, stuck at 0.991 after
// 300 iterations). Bound values are reached at u = +-pi/2, stationary points, where the residual
// is quadratic in u and Gauss-Newton still converges (linearly).
//   log rows (ParamSpec::log_scale: shininess, classic ks; also roughness, f0, f0_dielectric,
//     normalised ks):
//     y = log p in [log max(min, floor), log max] — the rows span decades or act
//     multiplicatively, and a step in u is a relative step in p, which is how their effect on
//     the image scales;
//   other rows: y = p in [min, max] (colours [0, 1], metallic, ior, ...).
struct EntryMap {
  std::string name;
  // Coordinates of the two solvers, both set by one rule (LogSpaceOf, residuals.cpp): the sine
  // path works on log p where `log` (lower and upper are then logs); the bounded LM on log p
  // where `lm_log` (a subset of `log`), else on p itself, which for a `log` entry lies in
  // [exp(lower), exp(upper)] (LmLinearOfLog).
  bool log = false;
  bool lm_log = false;
  bool LmLinearOfLog() const { return log && !lm_log; }
  double lower = 0, upper = 1;              // Box of y (p or log p).
  double start_lower = 0, start_upper = 1;  // Box the multi-start samples y from.
  double default_u = 0;
  bool fixed = false;
  double fixed_value = 0;                   // Natural units; used instead of u when fixed.
};

// Which solver works on log p for a row (residuals.cpp says why): the sine path for log_scale
// rows, roughness and specular scales; the bounded LM for log_scale rows and widths only.
struct LogSpace {
  bool sine = false;
  bool bounded_lm = false;
};
LogSpace LogSpaceOf(const ParamSpec& spec);

// Log rows whose table minimum is 0 get a natural floor (log(0) is -inf): classic ks 1e-6;
// f0 and normalised ks 1e-4 (no real material has F0 below 0.02; 1e-4 is "no specular").
inline constexpr double kLogFloor = 1e-6;
inline constexpr double kSpecularLogFloor = 1e-4;
double LogFloor(const ParamSpec& spec);

class Parametrization {
 public:
  // `fixed`: rows held at values, made for `model` (ParseFixedValue).
  Parametrization(const ModelInfo& model, const std::vector<FixedValue>& fixed);

  const ModelInfo& model() const { return *model_; }
  int size() const { return static_cast<int>(entries_.size()); }
  const EntryMap& entry(int i) const { return entries_[i]; }
  std::vector<int> FixedIndices() const;
  int FreeCount() const;

  // Natural parameters from internal ones; T = double or ceres::Jet.
  template <typename T>
  void ToNatural(const T* u, T* p) const {
    using std::exp;
    using std::sin;
    for (int i = 0; i < size(); ++i) {
      const EntryMap& e = entries_[i];
      if (e.fixed) {
        p[i] = T(e.fixed_value);
        continue;
      }
      const T y = T(e.lower) + T(0.5 * (e.upper - e.lower)) * (sin(u[i]) + T(1));
      p[i] = e.log ? exp(y) : y;
    }
  }
  std::vector<double> ToNatural(const std::vector<double>& u) const;
  // Internal value of natural p for entry i (clamped into its box), in [-pi/2, pi/2].
  double ToInternal(int i, double p) const;
  static double FromBox(const EntryMap& e, double y);
  std::vector<double> ToInternal(const std::vector<double>& p) const;
  // d p_i / d u_i at u; 0 for fixed entries (and at a bound).
  double NaturalDerivative(int i, double u) const;

  std::vector<double> DefaultInternal() const;
  // Start s (internal): s = 0 the table defaults; s >= 1 the s-th point of a Halton sequence
  // (bases 2, 3, 5, ...) over the free entries' start boxes, shifted modulo 1 by a vector drawn
  // from `seed` (Cranley-Patterson rotation) so that seeds give different, deterministic sets.
  // Starts 2 and 3 then take the lobe width from fixed strata, broad first (StartWidth).
  std::vector<double> Start(int s, std::uint64_t seed) const;
  // A start at natural parameters `p` (flattened; a BRDF-space fit's result): fixed entries keep
  // their value, the others are moved into their box and, like the defaults, at least 1% of it
  // from a bound (kStartInside).
  std::vector<double> StartAt(const std::vector<double>& p) const;

  // Holds entry i at natural value p from now on, as a "name=value" of the constructor would
  // (the free exposure's pin of a Fresnel entry, exposure_pin.h).
  void Pin(int i, double p);

 private:
  void StartWidth(int s, const std::vector<double>& shifts, std::vector<double>* u) const;

  const ModelInfo* model_;
  std::vector<EntryMap> entries_;
};

// Applies the loss's compression to a (non-negative) radiance; identity for L2, Huber, Cauchy.
template <typename T>
T CompressRadiance(Loss loss, const T& x) {
  using std::cbrt;
  using std::log;
  switch (loss) {
    case Loss::kLog: return log(T(1) + x);
    case Loss::kCubeRoot: return cbrt(x + T(kCubeRootEpsilon));
    case Loss::kRelative: return log(x + T(kRelativeEpsilon));
    default: return x;
  }
}
// d CompressRadiance / dx.
double CompressRadianceDerivative(Loss loss, double x);

// What both paths need to know about the problem.
struct ResidualSettings {
  ModelId model;
  Loss loss = Loss::kL2;
  const Parametrization* parametrization = nullptr;
};

// G-buffer path: residuals of a block of shading points, evaluated on the C++ twin.
// Template dimension kParams = the model's flattened parameter count (Jet size kParams + 1:
// the model block and the 1-entry log-exposure block). Residuals: 3 per point, each
// CompressRadiance(exp(e) * ShadePoint(p(u))) - CompressRadiance(reference).
template <int kParams>
class GBufferBlockResidual {
 public:
  // `points` and `targets` (3 compressed reference values per point) must outlive the functor.
  GBufferBlockResidual(const ResidualSettings& settings, const ShadingPoint* points,
                       const double* targets, int count)
      : settings_(settings), points_(points), targets_(targets), count_(count) {}

  template <typename T>
  bool operator()(const T* u, const T* log_exposure, T* residuals) const {
    using std::exp;
    T p[kParams];
    settings_.parametrization->ToNatural(u, p);
    const T scale = exp(log_exposure[0]);
    for (int i = 0; i < count_; ++i) {
      T rgb[3];
      ShadePoint(settings_.model, p, points_[i], rgb);
      for (int c = 0; c < 3; ++c) {
        residuals[3 * i + c] =
            CompressRadiance(settings_.loss, scale * rgb[c]) - T(targets_[3 * i + c]);
      }
    }
    return true;
  }

  static ceres::CostFunction* Create(const ResidualSettings& settings,
                                     const ShadingPoint* points, const double* targets,
                                     int count) {
    // <functor, residuals (3 per point, set at run time), model block, log-exposure block>
    return new ceres::AutoDiffCostFunction<GBufferBlockResidual, ceres::DYNAMIC, kParams, 1>(
        new GBufferBlockResidual(settings, points, targets, count), 3 * count);
  }

 private:
  ResidualSettings settings_;
  const ShadingPoint* points_;
  const double* targets_;
  int count_;
};

// Creates the G-buffer residual for the model's parameter count (dispatch over kParams).
ceres::CostFunction* CreateGBufferResidual(const ResidualSettings& settings,
                                           const ShadingPoint* points, const double* targets,
                                           int count);

// GL path: renders of one reference, keyed on the exact natural parameter values, so that every
// residual block of one Ceres evaluation shares the renders of that evaluation (the centre and
// one per perturbed parameter). Not thread-safe: the GL context lives on one thread.
class GlRenderCache {
 public:
  GlRenderCache(Renderer* renderer, const Scene* scene, ModelId model, int capacity);
  const Image& Get(const std::vector<double>& params);
  long renders() const { return renders_; }

 private:
  Renderer* renderer_;
  const Scene* scene_;
  ModelId model_;
  int capacity_;
  long renders_ = 0;
  long tick_ = 0;
  struct Entry {
    std::vector<double> key;
    Image image;
    long used = 0;
  };
  std::vector<Entry> entries_;
};

// GL path: residuals of a block of pixels of one reference. The model Jacobian comes from
// forward (or central) differences of GL renders in the internal coordinates u (step h); the
// exposure and compression derivatives are analytic. Fixed entries get
// zero columns without rendering.
class GlBlockResidual : public ceres::CostFunction {
 public:
  GlBlockResidual(const ResidualSettings& settings, GlRenderCache* cache, const int* pixels,
                  const double* targets, int count, double step, bool central);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  ResidualSettings settings_;
  GlRenderCache* cache_;
  const int* pixels_;      // Pixel index y * width + x, per point.
  const double* targets_;  // 3 compressed reference values per point.
  int count_;
  double step_;
  bool central_;
};

}  // namespace shadefit::fit
