// Energy probe: Lambert albedo = kd, the normalised Blinn-Phong over-normalisation caught by the
// verdict, GGX conserving, and the flux sweep (classic Blinn-Phong's flux changes with n,
// normalised Blinn-Phong's follows its closed form).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "probe_test_util.h"

namespace shadefit::testing {
namespace {

// Computed once for the three tests (about 4 s on 2 cores).
const probes::ProbeResult& RunEnergy() {
  static const probes::ProbeResult result = [] {
    probes::ProbeInputs in;
    in.renderer = &SharedRenderer();
    in.truth = MakeModel("lambert", "lambert", {"kd=0.4,0.5,0.6"});
    in.models.push_back(
        MakeModel("bpn10", "blinn-phong-normalized", {"kd=0", "ks=1", "shininess=10"}));
    in.models.push_back(MakeModel("ggx", "ggx", {"kd=0", "f0=1", "roughness=0.5"}));
    probes::EnergyOptions o;
    o.furnace_resolution = 48;
    o.furnace_samples = 128;
    return probes::EnergyProbe(in, o);
  }();
  return result;
}

TEST(EnergyProbe, LambertAlbedoIsKdAndFurnaceAgrees) {
  const auto& r = RunEnergy();
  const auto& n = r.numbers["truth"];
  std::printf(
      "[ energy ] lambert: max albedo %.5f +- %.1e (%s), furnace mean %.4f, furnace vs "
      "quadrature RMSE %.2e, strata %d\n",
      n["max_albedo"].get<double>(), n["max_albedo_std_error"].get<double>(),
      n["verdict"].get<std::string>().c_str(), n["furnace_mean"].get<double>(),
      n["furnace_vs_quadrature_rmse"].get<double>(), n["strata_per_axis"].get<int>());
  EXPECT_NEAR(n["max_albedo"].get<double>(), 0.6, 1e-3);
  EXPECT_EQ(n["max_albedo_channel"], "b");
  EXPECT_EQ(n["verdict"], "conserves");
  EXPECT_TRUE(n["error_target_met"].get<bool>());
  EXPECT_LE(n["max_std_error"].get<double>(), 1e-3);
  for (const double y : CurveOf(r, probes::CurveKind::kAlbedo, "truth").y) {
    EXPECT_NEAR(y, 0.6, 1e-3);
  }
  EXPECT_LT(n["furnace_vs_quadrature_rmse"].get<double>(), 0.01);
}

TEST(EnergyProbe, VerdictCatchesNormalisedBlinnPhongExcess) {
  const auto& r = RunEnergy();
  const auto& bpn = r.numbers["bpn10"];
  const auto& ggx = r.numbers["ggx"];
  std::printf(
      "[ energy ] bpn n=10: max %.4f +- %.1e %s; ggx r=0.5 f0=1: max %.4f %s, furnace "
      "max %.4f\n",
      bpn["max_albedo"].get<double>(), bpn["max_albedo_std_error"].get<double>(),
      bpn["verdict"].get<std::string>().c_str(), ggx["max_albedo"].get<double>(),
      ggx["verdict"].get<std::string>().c_str(), ggx["furnace_max"].get<double>());
  // Closed form at normal view, n = 10: 1.0748.
  EXPECT_NEAR(bpn["albedo_normal"].get<double>(), 1.0748, 2e-3);
  EXPECT_EQ(bpn["verdict"], "violates");
  EXPECT_EQ(ggx["verdict"], "conserves");
  EXPECT_LT(ggx["max_albedo"].get<double>(), 1.0);
}

TEST(EnergyProbe, SweepClassicFluxVariesNormalisedFollowsClosedForm) {
  const auto& r = RunEnergy();
  const auto& s = r.numbers["sweep"];
  std::printf(
      "[ energy ] sweep flux max/min: classic %.1f, normalised %.4f (closed-form error "
      "%.1e), ggx %.3f\n",
      s["blinn-phong"]["flux_max_over_min"].get<double>(),
      s["blinn-phong-normalized"]["flux_max_over_min"].get<double>(),
      s["blinn-phong-normalized"]["max_abs_error_vs_closed_form"].get<double>(),
      s["ggx"]["flux_max_over_min"].get<double>());
  EXPECT_GT(s["blinn-phong"]["flux_max_over_min"].get<double>(), 100.0);
  EXPECT_LT(s["blinn-phong-normalized"]["flux_max_over_min"].get<double>(), 1.08);
  EXPECT_LT(s["blinn-phong-normalized"]["max_abs_error_vs_closed_form"].get<double>(), 2e-3);
  EXPECT_LT(s["ggx"]["flux_max"].get<double>(), 1.0 + 3e-3);
}

// The sweep does not depend on the models, so the energy probes of one process share it per
// shininess list and strata (LobeWidthSweep): a probe with other sweep options gets its own.
TEST(EnergyProbe, SweepIsSharedOnlyBetweenProbesWithTheSameSweepOptions) {
  probes::ProbeInputs in;  // no renderer: no furnace, only the quadrature and the sweep
  in.models.push_back(MakeModel("lambert", "lambert", {"kd=0.5"}));
  probes::EnergyOptions o;
  o.strata_per_axis = o.max_strata_per_axis = 8;
  o.sweep_shininess = {10, 100};
  o.sweep_strata_per_axis = 16;
  const auto sweep = [&](const probes::EnergyOptions& options) {
    const probes::ProbeResult r = probes::EnergyProbe(in, options);
    std::vector<double> x;
    for (const probes::ProbeCurve& c : r.curves) {
      if (c.kind == probes::CurveKind::kLobeWidthSweep && c.series.rfind("ggx", 0) == 0) x = c.x;
    }
    return std::pair{r.numbers["sweep"], x};
  };
  const auto first = sweep(o);
  EXPECT_EQ(sweep(o), first);
  probes::EnergyOptions finer = o;
  finer.sweep_strata_per_axis = 32;
  EXPECT_NE(sweep(finer).first, first.first) << "other strata, other estimates";
  probes::EnergyOptions wider = o;
  wider.sweep_shininess = {10, 1000};
  const auto wide = sweep(wider);
  EXPECT_EQ(wide.second, (std::vector<double>{10, 1000}));
  EXPECT_NE(wide.first, first.first);
}

}  // namespace
}  // namespace shadefit::testing
