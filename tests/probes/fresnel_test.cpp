// Fresnel probe on synthetic renders with known BRDFs (docs/probes.md, "Validation").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "probe_test_util.h"

namespace shadefit::testing {
namespace {

using probes::CurveKind;
using probes::FresnelProbe;
using probes::ProbeInputs;

double Schlick(double f0, double theta_deg) {
  return f0 + (1 - f0) * std::pow(1 - std::cos(theta_deg * kPi / 180.0), 5);
}

ProbeInputs GgxInputs() {
  ProbeInputs in;
  in.renderer = &SharedRenderer();
  in.truth = MakeModel("ggx", "ggx", {"kd=0.3", "f0=0.04", "roughness=0.3"});
  for (const char* l : {"camera", "side", "rim", "mirror60", "mirror75", "mirror85"}) {
    in.references.push_back(MakeReference(*in.truth, l));
  }
  in.models.push_back(*in.truth);
  in.models.back().label = "ggx-truth";
  // A perturbed truth (f0 doubled): its curve error against the reference must be the Schlick
  // difference, not the noise floor.
  in.models.push_back(MakeModel("ggx-f0x2", "ggx", {"kd=0.3", "f0=0.08", "roughness=0.3"}));
  in.models.push_back(
      MakeModel("blinn-phong", "blinn-phong", {"kd=0.3", "ks=0.3", "shininess=40"}));
  return in;
}

// A Schlick GGX render returns F0 at normal incidence and the Schlick curve in theta_d.
TEST(FresnelProbe, SchlickGgxGivesF0AndSchlickCurve) {
  const ProbeInputs in = GgxInputs();
  const probes::ProbeResult r = FresnelProbe(in);
  const double f_centre = r.numbers["reference"]["F_centre"].get<double>();
  std::printf("[ fresnel ] reference F_centre %.5f (F0 0.04), F_rim %.4f, rim/centre %.3f\n",
              f_centre, r.numbers["reference"]["F_rim"].get<double>(),
              r.numbers["reference"]["rim_to_centre"].get<double>());
  EXPECT_NEAR(f_centre, 0.04, 1e-3);
  const auto pts = CurvePoints(CurveOf(r, CurveKind::kFresnelVsThetaD, "reference"));
  // The camera light gives theta_d = 0, rim and mirror85 the grazing end: the curve must span
  // both, so the loop below cannot pass on a handful of flat-region bins.
  ASSERT_GE(pts.size(), 5u);
  double worst = 0, x_min = 90, x_max = 0, sq_perturbed = 0;
  int compared = 0;
  for (const auto& [x, y] : pts) {
    // x is the lobe-weighted mean theta_d of a 5 deg bin; F is the lobe-weighted mean of a
    // convex curve over the bin, so allow a quarter of Schlick's change across +-2.5 deg.
    const double tol =
        0.25 * std::abs(Schlick(0.04, std::min(90.0, x + 2.5)) - Schlick(0.04, x - 2.5)) + 1e-3;
    EXPECT_NEAR(y, Schlick(0.04, x), tol) << "theta_d " << x;
    worst = std::max(worst, std::abs(y - Schlick(0.04, x)) / tol);
    x_min = std::min(x_min, x);
    x_max = std::max(x_max, x);
    sq_perturbed += std::pow(Schlick(0.08, x) - Schlick(0.04, x), 2);
    ++compared;
    std::printf("[ fresnel ] theta_d %5.1f  F %.5f  Schlick %.5f\n", x, y, Schlick(0.04, x));
  }
  EXPECT_GE(compared, 5);
  EXPECT_LT(x_min, 10.0);
  EXPECT_GT(x_max, 80.0);
  // Noise floor: the truth as a model.
  const double floor_d = r.numbers["ggx-truth"]["curve_rmse_theta_d"].get<double>();
  EXPECT_LT(floor_d, 1e-3);
  EXPECT_LT(r.numbers["ggx-truth"]["curve_rmse_theta_v"].get<double>(), 1e-3);
  // f0 = 0.08 against 0.04: the curve RMSE is the RMS of Schlick(0.08) - Schlick(0.04) =
  // 0.04 (1 - (1 - cos)^5) over the bins (to the bins' angle spread).
  const double perturbed = r.numbers["ggx-f0x2"]["curve_rmse_theta_d"].get<double>();
  const double expected = std::sqrt(sq_perturbed / compared);
  std::printf("[ fresnel ] f0 0.08 vs 0.04: curve RMSE %.5f (closed form %.5f, floor %.2g)\n",
              perturbed, expected, floor_d);
  EXPECT_NEAR(perturbed, expected, 0.05 * expected);
  EXPECT_GT(perturbed, 20 * floor_d);
  EXPECT_NEAR(r.numbers["ggx-f0x2"]["F_centre"].get<double>(), 0.08, 2e-3);
  // Grazing reflectance rises: F(85) / F0 > 5 (Schlick: 0.04 -> 0.40 at 85 deg).
  EXPECT_GT(r.numbers["reference"]["rim_to_centre"].get<double>(), 5.0);
}

// The probes' truth for every shipped Cycles reference is cycles-principled: its diffuse/lobe
// split must leave the whole Principled Fresnel in the specular, so the effective curve is
// Cycles' interpolate_fresnel_color, written out here from Cycles 3.4 (bsdf_util.h:
// fresnel_dielectric_cos, remapped from cspec0 at normal incidence to 1 at grazing) rather than
// taken from render/: specular 0.5 gives cspec0 = 0.08 * 0.5 = 0.04 and ior 1.5.
double CyclesFresnel(double cspec0, double ior, double theta_deg) {
  auto dielectric = [ior](double cosi) {
    const double g2 = ior * ior - 1 + cosi * cosi;
    const double g = std::sqrt(g2);
    const double a = (g - cosi) / (g + cosi);
    const double b = (cosi * (g + cosi) - 1) / (cosi * (g - cosi) + 1);
    return 0.5 * a * a * (1 + b * b);
  };
  const double f0 = dielectric(1.0);
  const double fh = (dielectric(std::cos(theta_deg * kPi / 180.0)) - f0) / (1 - f0);
  return cspec0 * (1 - fh) + fh;
}

TEST(FresnelProbe, PrincipledTruthGivesCyclesFresnelCurve) {
  ProbeInputs in;
  in.renderer = &SharedRenderer();
  in.truth = MakeModel("truth", "cycles-principled",
                       {"base_color=0.8,0.05,0.05", "metallic=0", "specular=0.5",
                        "roughness=0.3"});
  for (const char* l : {"camera", "side", "rim", "mirror60", "mirror75", "mirror85"}) {
    in.references.push_back(MakeReference(*in.truth, l));
  }
  const double ior = 2 / (1 - std::sqrt(0.08 * 0.5)) - 1;  // Cycles' specular -> ior: 1.5.
  const probes::ProbeResult r = FresnelProbe(in);
  const double f_centre = r.numbers["reference"]["F_centre"].get<double>();
  std::printf("[ fresnel ] principled F_centre %.5f (cspec0 0.04), rim/centre %.3f\n", f_centre,
              r.numbers["reference"]["rim_to_centre"].get<double>());
  EXPECT_NEAR(f_centre, 0.04, 2e-3);
  const auto pts = CurvePoints(CurveOf(r, CurveKind::kFresnelVsThetaD, "reference"));
  ASSERT_GE(pts.size(), 5u);
  double x_min = 90, x_max = 0;
  for (const auto& [x, y] : pts) {
    // Same bin allowance as the Schlick test above: a quarter of the curve's change over the bin.
    const double tol = 0.25 * std::abs(CyclesFresnel(0.04, ior, std::min(90.0, x + 2.5)) -
                                       CyclesFresnel(0.04, ior, x - 2.5)) +
                       1e-3;
    EXPECT_NEAR(y, CyclesFresnel(0.04, ior, x), tol) << "theta_d " << x;
    std::printf("[ fresnel ] theta_d %5.1f  F %.5f  Cycles %.5f\n", x, y,
                CyclesFresnel(0.04, ior, x));
    x_min = std::min(x_min, x);
    x_max = std::max(x_max, x);
  }
  EXPECT_LT(x_min, 10.0);
  EXPECT_GT(x_max, 80.0);
}

// Classic Blinn-Phong has no Fresnel factor: its effective Fresnel is ks at every angle.
TEST(FresnelProbe, BlinnPhongCurveIsFlat) {
  const ProbeInputs in = GgxInputs();
  const probes::ProbeResult r = FresnelProbe(in);
  const auto pts = CurvePoints(CurveOf(r, CurveKind::kFresnelVsThetaD, "blinn-phong"));
  ASSERT_GE(pts.size(), 4u);
  for (const auto& [x, y] : pts) EXPECT_NEAR(y, 0.3, 2e-3) << "theta_d " << x;
  EXPECT_NEAR(r.numbers["blinn-phong"]["rim_to_centre"].get<double>(), 1.0, 0.01);
  // It cannot follow the reference's rise: a large curve error against the Schlick reference.
  EXPECT_GT(r.numbers["blinn-phong"]["curve_rmse_theta_d"].get<double>(), 0.1);
  // A per-reference curve carries its reference's lighting as a field.
  for (const probes::ProbeCurve& c : r.curves) {
    if (c.reference.empty()) continue;
    const auto ref = std::find_if(in.references.begin(), in.references.end(),
                                  [&](const auto& x) { return x.name == c.reference; });
    ASSERT_NE(ref, in.references.end()) << c.reference;
    EXPECT_EQ(c.lighting, ref->lighting) << c.reference;
    EXPECT_FALSE(c.lighting.empty());
  }
}

// Without a truth the reference's diffuse part is estimated by the Lambert percentile fit: a
// pure Lambert image leaves no specular residual, and F(theta_d) is reported as unknown.
TEST(FresnelProbe, LambertPercentileEstimateLeavesNoSpecular) {
  ProbeInputs in;
  in.renderer = &SharedRenderer();
  const auto lambert = MakeModel("lambert", "lambert", {"kd=0.6"});
  in.references.push_back(MakeReference(lambert, "key"));
  in.references.push_back(MakeReference(lambert, "side"));
  const probes::ProbeResult r = FresnelProbe(in);
  EXPECT_TRUE(r.numbers["reference"]["F_centre"].is_null());
  for (const probes::ProbeCurve& curve : r.curves) {
    for (const auto& [x, y] : CurvePoints(curve)) {
      EXPECT_NEAR(y, 0.0, 2e-4) << curve.series << " @ " << curve.reference << ": "
                                << probes::CurveKindName(curve.kind) << " " << x;
    }
  }
}

// The twin path (no renderer) and the GL path give the same non-flat Fresnel curve of a Schlick
// GGX model, bin by bin.
TEST(FresnelProbe, TwinPathMatchesGlPath) {
  ProbeInputs in = GgxInputs();
  const probes::ProbeResult gl = FresnelProbe(in);
  in.renderer = nullptr;  // models by the C++ twin
  const probes::ProbeResult twin = FresnelProbe(in);
  for (const char* label : {"ggx-f0x2", "blinn-phong"}) {
    const auto a = CurvePoints(CurveOf(gl, CurveKind::kFresnelVsThetaD, label)),
               b = CurvePoints(CurveOf(twin, CurveKind::kFresnelVsThetaD, label));
    ASSERT_EQ(a.size(), b.size()) << label;
    ASSERT_GE(a.size(), 5u) << label;
    double lo = 1e9, hi = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      EXPECT_NEAR(a[i].first, b[i].first, 1e-2) << label << " bin " << i;
      EXPECT_NEAR(a[i].second, b[i].second, 1e-3 * a[i].second) << label << " theta_d " << a[i].first;
      lo = std::min(lo, a[i].second);
      hi = std::max(hi, a[i].second);
    }
    // GGX's curve rises from F0 = 0.08 to well above 0.5 at grazing: a curve the two paths
    // could only share by both computing Fresnel.
    if (std::string(label) == "ggx-f0x2") {
      EXPECT_GT(hi / lo, 5.0);
    }
    for (const char* number : {"F_centre", "F_rim", "curve_rmse_theta_d"}) {
      EXPECT_NEAR(gl.numbers[label][number].get<double>(),
                  twin.numbers[label][number].get<double>(),
                  1e-3 * std::abs(gl.numbers[label][number].get<double>()) + 1e-6)
          << label << " " << number;
    }
  }
}

}  // namespace
}  // namespace shadefit::testing
