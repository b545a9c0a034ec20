#include "shadefit/render/albedo.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <utility>

namespace shadefit {
namespace {

// One stratum's jittered point (u1, u2), the azimuth 2 pi u2 as its cosine and sine (both
// techniques sample the same azimuth), and the cosine-weighted direction around +z it maps to
// (Malley's method).
struct StratumPoint {
  double u1, cos_phi, sin_phi;
  Vec3d cosine;
};

// The points of m x m strata jittered by mt19937(seed), stratum (i, j) at [i * m + j]: every
// call with the same seed and strata draws the same points, so they are drawn (and their
// azimuths' cosines and sines taken) once per process rather than once per call; the energy and
// BRDF probes call DirectionalAlbedo hundreds of times a material with a few strata counts and
// one seed. Kept while all kept sets fit kKeptBytes (48 bytes a stratum: 512^2 strata are
// 12.6 MB); a larger set is drawn for its call alone, and a set that does not fit beside the
// kept ones starts the store again.
std::shared_ptr<const std::vector<StratumPoint>> StratumPoints(unsigned seed, int m) {
  constexpr std::size_t kKeptBytes = std::size_t{64} << 20;
  const std::size_t count = static_cast<std::size_t>(std::max(m, 0)) * std::max(m, 0);
  const std::size_t bytes = count * sizeof(StratumPoint);
  static std::mutex mutex;
  static std::map<std::pair<unsigned, int>, std::shared_ptr<const std::vector<StratumPoint>>>
      made;
  static std::size_t kept_bytes = 0;
  std::unique_lock<std::mutex> lock(mutex);
  if (const auto it = made.find({seed, m}); it != made.end()) return it->second;
  lock.unlock();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(0.0, 1.0);
  auto table = std::make_shared<std::vector<StratumPoint>>();
  table->reserve(count);
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j < m; ++j) {
      const double u1 = (i + jitter(rng)) / m, u2 = (j + jitter(rng)) / m;
      const double phi = 2.0 * kPi * u2, cos_phi = std::cos(phi), sin_phi = std::sin(phi);
      const double r = std::sqrt(u1);
      table->push_back({u1, cos_phi, sin_phi,
                        {r * cos_phi, r * sin_phi, std::sqrt(std::max(0.0, 1.0 - u1))}});
    }
  }
  if (bytes > kKeptBytes) return table;
  lock.lock();
  if (kept_bytes + bytes > kKeptBytes) {
    made.clear();
    kept_bytes = 0;
  }
  // Another thread may have drawn the same set meanwhile: the first one kept is returned.
  const auto [it, inserted] = made.emplace(std::pair{seed, m}, std::move(table));
  if (inserted) kept_bytes += bytes;
  return it->second;
}

// GGX half vector around +z (Walter et al. 2007, eqs. 35-36) at the stratum's point, reflected
// about v.
Vec3d SampleGgxReflection(const StratumPoint& s, double alpha, const Vec3d& v) {
  const double a2 = alpha * alpha;
  const double cos2 = (1.0 - s.u1) / (1.0 + (a2 - 1.0) * s.u1);
  const double sin_t = std::sqrt(std::max(0.0, 1.0 - cos2));
  const Vec3d h{sin_t * s.cos_phi, sin_t * s.sin_phi, std::sqrt(cos2)};
  return h * (2.0 * Dot(v, h)) - v;
}

double PdfCosine(const Vec3d& l) { return std::max(l.z, 0.0) * kInvPi; }

double PdfGgxReflection(const Vec3d& l, const Vec3d& v, double alpha) {
  if (alpha <= 0.0 || l.z <= 0.0) return 0.0;
  const Vec3d h = Normalize(l + v);
  const double VoH = Dot(v, h);
  if (h.z <= 0.0 || VoH <= 0.0) return 0.0;
  const double one_minus = std::max(0.0, 1.0 - h.z * h.z);
  return D_GGX(h.z, one_minus, alpha) * h.z / (4.0 * VoH);
}

// DirectionalAlbedo's estimate at cos(theta_v) = cv (already clamped), made anew.
AlbedoEstimate Estimate(ModelId model, const std::vector<double>& params, double cv,
                        const AlbedoOptions& options) {
  const Vec3d n{0, 0, 1};
  const Vec3d v{std::sqrt(std::max(0.0, 1.0 - cv * cv)), 0.0, cv};
  const double alpha = SpecularLobeAlpha(model, params.data());
  const int techniques = alpha > 0.0 ? 2 : 1;
  const int m = options.strata_per_axis;
  const auto points = StratumPoints(options.seed, m);

  // Each stratum yields one sample per technique; their MIS-weighted sum is one estimate of the
  // integral. The standard error comes from pairs of neighbouring strata (j, j + 1), each pair
  // taken as one stratum of two samples (the collapsed-strata estimator, Cochran 1977, "Sampling
  // Techniques", sec. 5A.12): sum over pairs of (a - b)^2, over count^2. It keeps the variance
  // that stratification removes out of the estimate (the spread of all strata around the mean
  // overstated the actual error 1.1-22x, most for sharp lobes at grazing view; the paired one
  // 1.0-3.1x, BrdfPhysics.AlbedoStandardErrorMatchesItsActualError), and stays conservative:
  // the pair's two strata differ in mean too.
  double sum[3] = {0, 0, 0}, sum_sq[3] = {0, 0, 0}, pair_sq[3] = {0, 0, 0}, left[3] = {0, 0, 0};
  const bool paired = m % 2 == 0;
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j < m; ++j) {
      const StratumPoint& point = (*points)[static_cast<std::size_t>(i) * m + j];
      double est[3] = {0, 0, 0};
      for (int t = 0; t < techniques; ++t) {
        const Vec3d l = t == 0 ? point.cosine : SampleGgxReflection(point, alpha, v);
        if (l.z <= 0.0) continue;
        double f[3];
        Reflect(model, params.data(), n, l, v, f);
        const double pdf = PdfCosine(l) + (techniques == 2 ? PdfGgxReflection(l, v, alpha) : 0);
        if (!(pdf > 0.0)) continue;
        for (int c = 0; c < 3; ++c) est[c] += f[c] / pdf;
      }
      for (int c = 0; c < 3; ++c) {
        sum[c] += est[c];
        sum_sq[c] += est[c] * est[c];
        if (j % 2 == 0) {
          left[c] = est[c];
        } else {
          pair_sq[c] += (est[c] - left[c]) * (est[c] - left[c]);
        }
      }
    }
  }
  AlbedoEstimate out;
  const double count = static_cast<double>(m) * m;
  for (int c = 0; c < 3; ++c) {
    out.value[c] = sum[c] / count;
    if (paired) {
      out.std_error[c] = std::sqrt(pair_sq[c]) / count;
    } else {
      // An odd number of strata: the iid bound, which stratification only makes conservative.
      const double var = std::max(0.0, sum_sq[c] / count - out.value[c] * out.value[c]);
      out.std_error[c] = std::sqrt(var / count);
    }
  }
  return out;
}

// What an estimate is a function of: the model, its parameters' bits, the view, the strata and
// the seed.
struct EstimateKey {
  ModelId model;
  std::vector<std::uint64_t> params;
  std::uint64_t cv;
  int strata;
  unsigned seed;
  auto operator<=>(const EstimateKey&) const = default;
};

// The estimates made so far in this process. A study's probe job asks for the same ones twice:
// the energy probe's first pass and the BRDF-space probe's model albedos take 128^2 strata at
// 10 of the same view angles for every fit of the material. Each estimate is deterministic, so a
// kept one is the bits a new call would give. At most kMaxKept (~100 bytes each); full, the
// store starts again.
std::mutex estimates_mutex;
std::map<EstimateKey, AlbedoEstimate> estimates;
constexpr std::size_t kMaxKept = 1 << 14;

}  // namespace

AlbedoEstimate DirectionalAlbedo(ModelId model, const std::vector<double>& params,
                                 double cos_theta_v, const AlbedoOptions& options) {
  const double cv = std::clamp(cos_theta_v, 1e-6, 1.0);
  EstimateKey key{model, {}, std::bit_cast<std::uint64_t>(cv), options.strata_per_axis,
                  options.seed};
  key.params.reserve(params.size());
  for (const double p : params) key.params.push_back(std::bit_cast<std::uint64_t>(p));
  {
    std::lock_guard lock(estimates_mutex);
    if (const auto it = estimates.find(key); it != estimates.end()) return it->second;
  }
  const AlbedoEstimate out = Estimate(model, params, cv, options);
  std::lock_guard lock(estimates_mutex);
  if (estimates.size() >= kMaxKept) estimates.clear();
  estimates.emplace(std::move(key), out);
  return out;
}

}  // namespace shadefit
