#include "problem.h"

#include <algorithm>
#include <cmath>

#include "shadefit/base/statistics.h"

namespace shadefit::fit::internal {
namespace {

ceres::Problem::Options ProblemOptions() {
  ceres::Problem::Options options;
  options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return options;
}

// Fixed entries on a SubsetManifold (every entry fixed: a constant block); a fixed exposure is a
// constant block.
void HoldFixed(CeresProblems& p, ceres::Problem& problem) {
  if (static_cast<int>(p.fixed.size()) == p.n) {
    problem.SetParameterBlockConstant(p.u.data());
  } else if (!p.fixed.empty()) {
    problem.SetManifold(p.u.data(), new ceres::SubsetManifold(p.n, p.fixed));
  }
  if (!p.exposure_free) problem.SetParameterBlockConstant(p.log_exposure);
}

// The full problem: every valid pixel of every reference, pixels_per_block pixels per block.
void AddFullResiduals(const ModelInfo& model, const ResidualSettings& settings,
                      const FitOptions& options, bool gl, Renderer* renderer,
                      std::vector<PreparedReference>& refs, CeresProblems& p) {
  const int block = p.pixels_per_block;
  for (auto& r : refs) {
    for (std::size_t k = 0; k < r.points.size(); ++k) {
      for (int c = 0; c < 3; ++c) {
        const double t = CompressRadiance(options.loss, r.linear[3 * k + c]);
        r.targets.push_back(t);
        p.cost_scale += 0.5 * t * t;
      }
    }
    if (gl) {
      // Capacity: the centre, the trial point and one (two when central) per entry.
      r.cache = std::make_unique<GlRenderCache>(renderer, &r.scene, model.id,
                                                (options.central_differences ? 2 : 1) * p.n + 3);
    }
    const int count = static_cast<int>(r.points.size());
    for (int k = 0; k < count; k += block) {
      const int m = std::min(block, count - k);
      ceres::CostFunction* cost =
          gl ? static_cast<ceres::CostFunction*>(
                   new GlBlockResidual(settings, r.cache.get(), &r.pixels[k], &r.targets[3 * k], m,
                                       options.fd_step, options.central_differences))
             : CreateGBufferResidual(settings, &r.points[k], &r.targets[3 * k], m);
      p.full.AddResidualBlock(cost, p.loss_function.get(), p.u.data(), p.log_exposure);
      p.residual_count += 3 * m;
    }
  }
}

// Coarse stage (G-buffer path, large problems): every start first runs on a subsample.
// All pixels at or above the reference's 90th percentile (highlights are few and carry the
// shape information) plus a regular stride through the rest, kCoarseTarget pixels in all; the
// starts that end near the best coarse cost are then polished on every pixel (multistart.h).
// A polish from a nearby point takes a few iterations, so N starts cost about N coarse fits + a
// few full ones instead of N full fits.
constexpr long kCoarseThreshold = 16384;  // Valid pixels over all references.
constexpr long kCoarseTarget = 4096;

void AddCoarseResiduals(const ResidualSettings& settings,
                        const std::vector<PreparedReference>& refs, long total_points,
                        CeresProblems& p) {
  const int block = p.pixels_per_block;
  for (std::size_t ri = 0; ri < refs.size(); ++ri) {
    const auto& r = refs[ri];
    const long want =
        std::max<long>(64, kCoarseTarget * static_cast<long>(r.points.size()) / total_points);
    std::vector<double> norms;
    for (std::size_t k = 0; k < r.points.size(); ++k) {
      norms.push_back(std::hypot(r.linear[3 * k], r.linear[3 * k + 1], r.linear[3 * k + 2]));
    }
    std::vector<double> sorted = norms;
    const double p90 = Percentile(sorted, 0.9);
    const long stride = std::max<long>(1, static_cast<long>(r.points.size()) / want);
    for (std::size_t k = 0; k < r.points.size(); ++k) {
      if (norms[k] < p90 && k % stride != 0) continue;
      p.coarse_points[ri].push_back(r.points[k]);
      for (int c = 0; c < 3; ++c) p.coarse_targets[ri].push_back(r.targets[3 * k + c]);
    }
    const int count = static_cast<int>(p.coarse_points[ri].size());
    for (int k = 0; k < count; k += block) {
      const int m = std::min(block, count - k);
      p.coarse_problem.AddResidualBlock(
          CreateGBufferResidual(settings, &p.coarse_points[ri][k], &p.coarse_targets[ri][3 * k], m),
          p.loss_function.get(), p.u.data(), p.log_exposure);
    }
  }
}

}  // namespace

bool IsRobust(Loss loss) { return loss == Loss::kHuber || loss == Loss::kCauchy; }

double RobustLossScale(const FitOptions& options, const std::vector<PreparedReference>& refs) {
  if (!IsRobust(options.loss)) return 0;
  if (options.loss_scale > 0) return options.loss_scale;
  double p99 = 0;
  for (const auto& r : refs) p99 = std::max(p99, r.p99_norm);
  return kRobustScaleFraction * p99;
}

CeresProblems::CeresProblems() : full(ProblemOptions()), coarse_problem(ProblemOptions()) {}

void BuildProblems(const ModelInfo& model, const Parametrization& param, const FitOptions& options,
                   bool gl, Renderer* renderer, std::vector<PreparedReference>& refs,
                   CeresProblems* out) {
  CeresProblems& p = *out;
  p.n = param.size();
  p.fixed = param.FixedIndices();
  p.exposure_free = options.exposure == Exposure::kFree;
  p.u = param.DefaultInternal();
  p.loss_scale = RobustLossScale(options, refs);
  if (options.loss == Loss::kHuber)
    p.loss_function = std::make_unique<ceres::HuberLoss>(p.loss_scale);
  if (options.loss == Loss::kCauchy) {
    p.loss_function = std::make_unique<ceres::CauchyLoss>(p.loss_scale);
  }
  p.pixels_per_block = IsRobust(options.loss) ? 1 : std::max(1, options.pixels_per_block);
  // The GL context is current on this thread only: the GL path evaluates on it.
  p.threads = gl ? 1 : std::max(1, options.num_threads);

  const ResidualSettings settings{model.id, options.loss, &param};
  AddFullResiduals(model, settings, options, gl, renderer, refs, p);
  HoldFixed(p, p.full);

  long total_points = 0;
  for (const auto& r : refs) total_points += static_cast<long>(r.points.size());
  p.coarse = !gl && options.coarse_to_fine && total_points > kCoarseThreshold;
  p.coarse_points.resize(refs.size());
  p.coarse_targets.resize(refs.size());
  if (p.coarse) {
    AddCoarseResiduals(settings, refs, total_points, p);
    HoldFixed(p, p.coarse_problem);
  }

  // Robust losses act on squared pixel norms (ceres::LossFunction's corrections); the GL path
  // differences renders: both stay with Ceres. So do free-exposure fits for now: on the photo
  // workflow's 8-bit sRGB set the bounded LM stopped at exposure 2.84 (truth 4; the staged Ceres
  // solve reaches 3.96), where exposure and the colour scales trade off along a valley.
  const bool bounded =
      options.solver == Solver::kBoundedLm ||
      (options.solver == Solver::kAuto && ProjectionApplies(options.loss, p.exposure_free));
  p.solver = bounded && !gl && !IsRobust(options.loss) && !p.exposure_free ? Solver::kBoundedLm
                                                                            : Solver::kCeres;
  if (p.Native()) {
    for (BoundedLmProblem* q : {&p.native_full, &p.native_coarse}) {
      q->model = model.id;
      q->loss = options.loss;
      q->param = &param;
      q->exposure_free = p.exposure_free;
      q->threads = p.threads;
    }
    for (std::size_t ri = 0; ri < refs.size(); ++ri) {
      const PreparedReference& r = refs[ri];
      p.native_full.spans.push_back(
          {r.points.data(), r.targets.data(), static_cast<int>(r.points.size())});
      if (p.coarse) {
        p.native_coarse.spans.push_back({p.coarse_points[ri].data(), p.coarse_targets[ri].data(),
                                         static_cast<int>(p.coarse_points[ri].size())});
      }
    }
  }
}

}  // namespace shadefit::fit::internal
