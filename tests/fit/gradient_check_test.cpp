// Acceptance 3: ceres::GradientChecker passes on every model's residual (the G-buffer path's
// AutoDiff residual, for every loss that changes it), and on the GL path's finite-difference
// residual with a tolerance that reflects its float renders.
#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

#include <random>

#include "fit_test_util.h"
#include "shadefit/fit/residuals.h"
#include "../../fit/src/bounded_lm.h"  // The bounded LM (internal to fit/).

namespace shadefit {
namespace {

struct Geometry {
  Scene scene;
  std::vector<ShadingPoint> points;
  std::vector<int> pixels;
};

const Geometry& SmallGeometry() {
  static const Geometry g = [] {
    Geometry out;
    // Two point lights and an ambient light so every model's every entry matters.
    out.scene = ParseScene(testing::CameraToml("[0.0, -6.0, 0.0]", 22.0, 24) + testing::kSphere +
                               "[[lights]]\ntype = \"point\"\nposition = [2.5, -3.5, 2.5]\n"
                               "power = 600.0\n[[lights]]\ntype = \"point\"\n"
                               "position = [-3.0, -2.0, -1.0]\npower = 300.0\n"
                               "[[lights]]\ntype = \"ambient\"\nradiance = 0.2\n",
                           "check.toml");
    const GBuffer gbuffer = testing::SharedRenderer().RenderGBuffer(out.scene);
    for (ShadingPoint& p : PrepareShading(out.scene, gbuffer, 1.0f)) {
      // Every 7th pixel: enough configurations, a quick numeric Jacobian.
      if ((p.x + p.y * 24) % 7 == 0) {
        out.pixels.push_back(p.y * 24 + p.x);
        out.points.push_back(std::move(p));
      }
    }
    return out;
  }();
  return g;
}

// An interior point of the internal box (no entry at a bound, where dp/du = 0).
std::vector<double> InteriorPoint(const fit::Parametrization& param, int seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.2, 1.2);
  std::vector<double> x(param.size());
  for (double& v : x) v = u(rng);
  return x;
}

// Independent central difference of one Jacobian entry (block b, residual i, entry j), step h.
double CentralDifference(const ceres::CostFunction& cost, const double* const* params, int b,
                         int i, int j, double h) {
  std::vector<std::vector<double>> plus, minus;
  const auto& sizes = cost.parameter_block_sizes();
  for (std::size_t k = 0; k < sizes.size(); ++k) {
    plus.emplace_back(params[k], params[k] + sizes[k]);
    minus.emplace_back(params[k], params[k] + sizes[k]);
  }
  plus[b][j] += h;
  minus[b][j] -= h;
  std::vector<const double*> pp, pm;
  for (std::size_t k = 0; k < sizes.size(); ++k) {
    pp.push_back(plus[k].data());
    pm.push_back(minus[k].data());
  }
  std::vector<double> rp(cost.num_residuals()), rm(cost.num_residuals());
  cost.Evaluate(pp.data(), rp.data(), nullptr);
  cost.Evaluate(pm.data(), rm.data(), nullptr);
  return (rp[i] - rm[i]) / (2 * h);
}

// ceres::GradientChecker computes both Jacobians; its own verdict is purely relative, which
// fails on entries of 1e-12 where central differences carry 1e-15 of rounding. We accept
// |user - numeric| <= rel * |numeric| + floor * max|J| (max over the block).
// Observed with Ceres 2.1 (Debian 12): for a few entries (phong/blinn-phong, one of three
// probe points) GradientChecker's numeric Jacobian is off by up to 1e-4 relative (or is 0.004
// where the true value is -4e-8), independent of relative_step_size, while our own central
// differences at h = 1e-6 and 1e-5 agree with the AutoDiff value to 1e-9. Such entries are
// re-checked with those independent differences, which must then agree with both steps.
void ExpectJacobiansMatch(const ceres::GradientChecker::ProbeResults& r, double rel,
                          double floor, const std::string& what,
                          const ceres::CostFunction* cost = nullptr,
                          const double* const* params = nullptr) {
  for (std::size_t b = 0; b < r.jacobians.size(); ++b) {
    const auto& user = r.jacobians[b];
    const auto& numeric = r.numeric_jacobians[b];
    const double scale = numeric.cwiseAbs().maxCoeff();
    int bad = 0;
    for (int i = 0; i < user.rows(); ++i) {
      for (int j = 0; j < user.cols(); ++j) {
        const double err = std::abs(user(i, j) - numeric(i, j));
        auto ok = [&](double reference) {
          return std::abs(user(i, j) - reference) <= rel * std::abs(reference) + floor * scale;
        };
        if (err > rel * std::abs(numeric(i, j)) + floor * scale &&
            !(cost && ok(CentralDifference(*cost, params, b, i, j, 1e-6)) &&
              ok(CentralDifference(*cost, params, b, i, j, 1e-5)))) {
          if (bad++ < 5) {
            ADD_FAILURE() << what << " block " << b << " (" << i << ", " << j << "): user "
                          << user(i, j) << " numeric " << numeric(i, j);
          }
        }
      }
    }
    EXPECT_EQ(bad, 0) << what << "\n" << r.error_log;
  }
}

class GradientCheckTest : public ::testing::TestWithParam<std::string> {};

TEST_P(GradientCheckTest, GBufferResidualMatchesNumericDerivatives) {
  const ModelInfo& model = FindModel(GetParam());
  const Geometry& g = SmallGeometry();
  const fit::Parametrization param(model, {});
  for (fit::Loss loss :
       {fit::Loss::kL2, fit::Loss::kLog, fit::Loss::kCubeRoot, fit::Loss::kRelative}) {
    std::vector<double> targets(3 * g.points.size(), 0.05);
    const fit::ResidualSettings settings{model.id, loss, &param};
    std::unique_ptr<ceres::CostFunction> cost(fit::CreateGBufferResidual(
        settings, g.points.data(), targets.data(), static_cast<int>(g.points.size())));
    for (int seed = 0; seed < 3; ++seed) {
      std::vector<double> u = InteriorPoint(param, seed);
      double e = 0.3;
      const double* params[2] = {u.data(), &e};
      ceres::NumericDiffOptions numeric;
      numeric.relative_step_size = 1e-7;
      ceres::GradientChecker checker(cost.get(), static_cast<const std::vector<const ceres::Manifold*>*>(nullptr), numeric);
      ceres::GradientChecker::ProbeResults results;
      checker.Probe(params, 1e-5, &results);
      ASSERT_TRUE(results.return_value);
      ExpectJacobiansMatch(results, 1e-5, 1e-9,
                           model.name + " loss " + fit::LossName(loss) + " seed " +
                               std::to_string(seed),
                           cost.get(), params);
    }
  }
}

// Every registered model (render/CMakeLists.txt), whatever its parameter count.
std::vector<std::string> AllModelNames() {
  std::vector<std::string> names;
  for (const ModelInfo& m : AllModels()) names.push_back(m.name);
  return names;
}

INSTANTIATE_TEST_SUITE_P(Models, GradientCheckTest, ::testing::ValuesIn(AllModelNames()),
                         [](const auto& info) {
                           std::string n = info.param;
                           for (char& ch : n) {
                             if (ch == '-') ch = '_';
                           }
                           return n;
                         });

// The GL residual's forward differences (step 1e-3 in u) against Ceres' central differences of
// the same GL renders: 2% relative (truncation O(h)) plus an absolute 1e-3 of the largest entry
// (float renders: a radiance of ~0.5 has an ulp of 6e-8, which / h = 6e-5 per difference).
TEST(GradientCheckGlTest, GlResidualMatchesNumericDerivatives) {
  const ModelInfo& model = FindModel("ggx");
  const Geometry& g = SmallGeometry();
  const fit::Parametrization param(model, {});
  std::vector<double> targets(3 * g.points.size(), 0.05);
  const fit::ResidualSettings settings{model.id, fit::Loss::kL2, &param};
  fit::GlRenderCache cache(&testing::SharedRenderer(), &g.scene, model.id, 20);
  fit::GlBlockResidual cost(settings, &cache, g.pixels.data(), targets.data(),
                            static_cast<int>(g.pixels.size()), 1e-3, false);
  std::vector<double> u = InteriorPoint(param, 1);
  double e = 0.0;
  const double* params[2] = {u.data(), &e};
  ceres::NumericDiffOptions numeric;
  numeric.relative_step_size = 1e-3;  // Float renders: a step well above their rounding noise.
  ceres::GradientChecker checker(&cost, static_cast<const std::vector<const ceres::Manifold*>*>(nullptr), numeric);
  ceres::GradientChecker::ProbeResults results;
  checker.Probe(params, 2e-2, &results);
  ASSERT_TRUE(results.return_value);
  ExpectJacobiansMatch(results, 2e-2, 1e-3, "ggx GL path");
}

// The bounded LM's one-pass normal equations (fit/src/bounded_lm.h) against central differences
// of its own cost, for every model, with the exposure free or fixed (a fixed one takes the pass's
// plain path: no exposure slot in the sums, the Jet scaled by a number) and with L2 or a
// compressing loss: its
// gradient J^T r entry by entry (relative 1e-5 of the largest, step 1e-6 of the box), and J^T J
// against the outer products of differenced residual rows is implied by the gradient check at
// two targets (the gradient is J^T r for any r). Interior box points, so no entry is at a bound.
class BoundedLmGradientTest : public ::testing::TestWithParam<std::string> {};

TEST_P(BoundedLmGradientTest, GradientMatchesCentralDifferences) {
  const ModelInfo& model = FindModel(GetParam());
  const Geometry& g = SmallGeometry();
  const fit::Parametrization param(model, {});
  for (fit::Loss loss : {fit::Loss::kL2, fit::Loss::kCubeRoot}) {
    for (double target : {0.0, 0.05}) {
      for (bool exposure_free : {true, false}) {
        std::vector<double> targets(3 * g.points.size(), fit::CompressRadiance(loss, target));
        fit::internal::BoundedLmProblem problem;
        problem.model = model.id;
        problem.loss = loss;
        problem.param = &param;
        problem.exposure_free = exposure_free;
        problem.threads = 2;
        problem.spans.push_back(
            {g.points.data(), targets.data(), static_cast<int>(g.points.size())});
        const std::vector<double> y = fit::internal::BoxOfInternal(param, InteriorPoint(param, 3));
        const double e = 0.1;
        std::vector<double> grad, h;
        const double cost = fit::internal::BoundedLmNormalEquations(problem, y, e, &grad, &h);
        ASSERT_TRUE(std::isfinite(cost));
        EXPECT_NEAR(cost, fit::internal::BoundedLmCost(problem, y, e), 1e-12 * std::abs(cost));
        const int n = param.size();
        std::vector<double> numeric(n + 1);
        double largest = 0;
        for (int i = 0; i <= n; ++i) {
          const double width = i < n ? param.entry(i).upper - param.entry(i).lower : 1.0;
          const double step = 1e-6 * std::max(1.0, width);
          std::vector<double> yp = y, ym = y;
          double ep = e, em = e;
          (i < n ? yp[i] : ep) += step;
          (i < n ? ym[i] : em) -= step;
          numeric[i] = (fit::internal::BoundedLmCost(problem, yp, ep) -
                        fit::internal::BoundedLmCost(problem, ym, em)) /
                       (2 * step);
          largest = std::max(largest, std::abs(numeric[i]));
        }
        for (int i = 0; i <= n; ++i) {
          // A fixed exposure is no unknown: its gradient entry and its row of J^T J are zero.
          const double expected = i == n && !exposure_free ? 0.0 : numeric[i];
          EXPECT_NEAR(grad[i], expected, 1e-5 * largest + 1e-9)
              << GetParam() << " entry " << (i < n ? param.entry(i).name : "exposure") << " loss "
              << static_cast<int>(loss) << " target " << target << " exposure free "
              << exposure_free;
          // J^T J is symmetric with a non-negative diagonal.
          EXPECT_GE(h[i * (n + 1) + i], 0.0);
          for (int j = 0; j <= n; ++j) EXPECT_EQ(h[i * (n + 1) + j], h[j * (n + 1) + i]);
          if (i == n && !exposure_free) {
            for (int j = 0; j <= n; ++j) EXPECT_EQ(h[i * (n + 1) + j], 0.0);
          }
        }
      }
    }
  }
}

// J^T J of the one-pass normal equations against J itself, built row by row from the gradient:
// g(t) = J^T (f - t) for any targets t, so g(t) - g(t + e_k) is row k of J (the gradient is held
// to central differences above). Both Jet layouts (one slot per row where the model is
// channel-separable, one per entry), so neither the compressed accumulation nor its scatter onto
// the unknowns can drop or misplace a term. Relative 1e-9 of the largest entry.
TEST_P(BoundedLmGradientTest, GaussNewtonMatrixIsJTransposeJ) {
  const ModelInfo& model = FindModel(GetParam());
  const Geometry& g = SmallGeometry();
  const fit::Parametrization param(model, {});
  const int n = param.size(), N = n + 1;
  const int residuals = 3 * static_cast<int>(g.points.size());
  for (fit::internal::JetLayout layout :
       {fit::internal::JetLayout::kPerRow, fit::internal::JetLayout::kPerEntry}) {
    for (bool exposure_free : {true, false}) {
      std::vector<double> targets(residuals, 0.05);
      fit::internal::BoundedLmProblem problem;
      problem.model = model.id;
      problem.loss = fit::Loss::kL2;
      problem.param = &param;
      problem.exposure_free = exposure_free;
      problem.derivatives = layout;
      problem.spans.push_back({g.points.data(), targets.data(), static_cast<int>(g.points.size())});
      const std::vector<double> y = fit::internal::BoxOfInternal(param, InteriorPoint(param, 5));
      const double e = -0.2;
      std::vector<double> g0, h, gk, hk;
      fit::internal::BoundedLmNormalEquations(problem, y, e, &g0, &h);
      std::vector<double> jtj(N * N, 0.0);
      for (int k = 0; k < residuals; ++k) {
        targets[k] += 1.0;
        fit::internal::BoundedLmNormalEquations(problem, y, e, &gk, &hk);
        targets[k] -= 1.0;
        for (int a = 0; a < N; ++a) {
          for (int b = 0; b < N; ++b) jtj[a * N + b] += (gk[a] - g0[a]) * (gk[b] - g0[b]);
        }
      }
      double largest = 0;
      for (double v : jtj) largest = std::max(largest, std::abs(v));
      ASSERT_GT(largest, 0.0);
      for (int a = 0; a < N; ++a) {
        for (int b = 0; b < N; ++b) {
          EXPECT_NEAR(h[a * N + b], jtj[a * N + b], 1e-9 * largest)
              << GetParam() << " (" << a << ", " << b << ") layout " << static_cast<int>(layout)
              << " exposure free " << exposure_free;
        }
      }
    }
  }
}

// Variable projection moves the linear entries after every trial pass; the solver moves that
// pass's normal equations with them (ShiftLinear in fit/src/bounded_lm.cpp) instead of making a
// fresh pass. Held here to a fresh pass at the moved point, for every model: cost, gradient and
// J^T J to 1e-9 of their largest entry, from an interior point, with varied targets so no
// residual is the same, the linear entries moved by 30% of their value plus 0.02 (inside the box:
// the models are affine in them there). Where a model's pass cannot be moved (a term reading two
// rows, so no one-slot mixed column) the solver falls back to a fresh pass; which models those are
// is held to their structure, so a change that turns the shift off is seen here too.
TEST_P(BoundedLmGradientTest, ShiftedNormalEquationsMatchAFreshPass) {
  const ModelInfo& model = FindModel(GetParam());
  const Geometry& g = SmallGeometry();
  const fit::Parametrization param(model, {});
  const int n = param.size(), N = n + 1;
  std::vector<double> targets(3 * g.points.size());
  for (std::size_t k = 0; k < targets.size(); ++k) targets[k] = 0.01 + 0.02 * ((k * 37) % 11);
  fit::internal::BoundedLmProblem problem;
  problem.model = model.id;
  problem.loss = fit::Loss::kL2;
  problem.param = &param;
  problem.exposure_free = false;
  problem.threads = 2;
  problem.spans.push_back({g.points.data(), targets.data(), static_cast<int>(g.points.size())});
  const std::vector<bool> projected = fit::internal::ProjectedEntries(problem);
  const bool any_projected = std::find(projected.begin(), projected.end(), true) != projected.end();
  const fit::internal::TermRows& rows = fit::internal::RowsOfTerms(model.id);
  const bool expect_shift = fit::internal::ChannelSeparable(model.id) && rows.single;
  for (int seed : {3, 11}) {
    const std::vector<double> y = fit::internal::BoxOfInternal(param, InteriorPoint(param, seed));
    const double e = -0.3;
    std::vector<double> delta(N, 0.0), moved = y;
    for (int i = 0; i < n; ++i) {
      if (!projected[i]) continue;
      delta[i] = (i % 2 == 0 ? -0.3 : 0.3) * y[i] + 0.02;
      moved[i] += delta[i];
    }
    double shifted_cost = 0;
    std::vector<double> shifted_g, shifted_h;
    const bool shifted = fit::internal::BoundedLmShiftedNormalEquations(
        problem, y, e, delta, &shifted_cost, &shifted_g, &shifted_h);
    ASSERT_EQ(shifted, expect_shift) << GetParam();
    if (!shifted || !any_projected) continue;  // Lambert: nothing nonlinear, nothing projected.
    std::vector<double> fresh_g, fresh_h;
    const double fresh_cost =
        fit::internal::BoundedLmNormalEquations(problem, moved, e, &fresh_g, &fresh_h);
    // The move is not a no-op: the cost changed by more than the tolerance.
    std::vector<double> unused_g, unused_h;
    const double before =
        fit::internal::BoundedLmNormalEquations(problem, y, e, &unused_g, &unused_h);
    EXPECT_GT(std::abs(before - fresh_cost), 1e-6 * fresh_cost) << GetParam();
    EXPECT_NEAR(shifted_cost, fresh_cost, 1e-9 * fresh_cost) << GetParam();
    double largest_g = 0, largest_h = 0;
    for (double v : fresh_g) largest_g = std::max(largest_g, std::abs(v));
    for (double v : fresh_h) largest_h = std::max(largest_h, std::abs(v));
    for (int a = 0; a < N; ++a) {
      const std::string entry = a < n ? param.entry(a).name : "exposure";
      EXPECT_NEAR(shifted_g[a], fresh_g[a], 1e-9 * largest_g) << GetParam() << " g " << entry;
      for (int b = 0; b < N; ++b) {
        EXPECT_NEAR(shifted_h[a * N + b], fresh_h[a * N + b], 1e-9 * largest_h)
            << GetParam() << " h " << entry << ", " << (b < n ? param.entry(b).name : "exposure");
      }
    }
  }
}

// Natural values at the ends of every entry's box are inside the model's table, for every model
// (exp(log(1e5)) is 1e5 plus an ulp: a study's probe rejected shininess 100000.00000000001).
TEST(ParametrizationTest, BoundsGiveValuesInsideTheTable) {
  for (const ModelInfo& model : AllModels()) {
    const fit::Parametrization param(model, {});
    for (double end : {-kPi / 2, kPi / 2}) {
      const std::vector<double> p = param.ToNatural(std::vector<double>(param.size(), end));
      for (int i = 0; i < param.size(); ++i) {
        const ParamSpec& spec = model.SpecOfEntry(i);
        EXPECT_GE(p[i], spec.min) << model.name << " " << model.EntryName(i);
        EXPECT_LE(p[i], spec.max) << model.name << " " << model.EntryName(i);
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Models, BoundedLmGradientTest, ::testing::ValuesIn(AllModelNames()),
                         [](const auto& info) {
                           std::string n = info.param;
                           for (char& ch : n) ch = std::isalnum(static_cast<unsigned char>(ch)) ? ch : '_';
                           return n;
                         });

}  // namespace
}  // namespace shadefit
