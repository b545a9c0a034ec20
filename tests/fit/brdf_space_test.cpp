// BRDF-space fits (fit/brdf_space.h): the cell weights against integrals over directions done
// by hand, recovery of analytic BRDFs written out here (independently of render/brdf.h), the
// thread-count independence of the samples, and the errors.
#include "shadefit/fit/brdf_space.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "shadefit/base/error.h"

namespace shadefit::testing {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

// An analytic isotropic BRDF given as a function of the local directions.
class AnalyticBrdf : public reference_images::MeasuredBrdf {
 public:
  using Fn = Vec3d (*)(const Vec3d& wi, const Vec3d& wo);
  explicit AnalyticBrdf(Fn f) : f_(f) {}
  Vec3d Eval(const Vec3d& wi, const Vec3d& wo) const override {
    if (wi.z <= 0 || wo.z <= 0) return Vec3d{0, 0, 0};
    return f_(wi, wo);
  }
  std::vector<std::string> SourceFiles() const override { return {}; }
  std::string Format() const override { return "analytic"; }

 private:
  Fn f_;
};

Vec3d Half(const Vec3d& wi, const Vec3d& wo) {
  const Vec3d h{wi.x + wo.x, wi.y + wo.y, wi.z + wo.z};
  const double len = std::sqrt(h.x * h.x + h.y * h.y + h.z * h.z);
  return Vec3d{h.x / len, h.y / len, h.z / len};
}

// Lambert kd + GGX (Walter et al. 2007, eq. 33) with the height-correlated Smith G2 (Heitz
// 2014, eq. 99) and Schlick's Fresnel per channel: the "ggx" model's terms.
constexpr double kKd[3] = {0.30, 0.12, 0.05};
constexpr double kF0[3] = {0.90, 0.60, 0.30};
constexpr double kRoughness = 0.35;

Vec3d LambertGgx(const Vec3d& wi, const Vec3d& wo) {
  const double a = kRoughness * kRoughness, a2 = a * a;
  const Vec3d h = Half(wi, wo);
  const double k = h.z * h.z * (a2 - 1) + 1;
  const double d = a2 / (kPi * k * k);
  auto lambda = [&](double c) { return 0.5 * (-1 + std::sqrt(1 + a2 * (1 - c * c) / (c * c))); };
  const double g2 = 1 / (1 + lambda(wi.z) + lambda(wo.z));
  const double hd = wi.x * h.x + wi.y * h.y + wi.z * h.z;
  double f[3];
  for (int c = 0; c < 3; ++c) {
    const double fresnel = kF0[c] + (1 - kF0[c]) * std::pow(1 - hd, 5);
    f[c] = kKd[c] / kPi + fresnel * d * g2 / (4 * wi.z * wo.z);
  }
  return Vec3d{f[0], f[1], f[2]};
}

// Normalised Blinn-Phong as the model defines it: kd / pi + ks (n + 8) / (8 pi) (n.h)^n.
constexpr double kShininess = 850.0, kKs = 0.05, kKdGrey = 0.2;
Vec3d NormalisedBlinnPhong(const Vec3d& wi, const Vec3d& wo) {
  const double lobe = (kShininess + 8) / (8 * kPi) * std::pow(Half(wi, wo).z, kShininess);
  const double f = kKdGrey / kPi + kKs * lobe;
  return Vec3d{f, f, f};
}

Vec3d Lambert(const Vec3d&, const Vec3d&) { return Vec3d{0.5 / kPi, 0.5 / kPi, 0.5 / kPi}; }

double Value(const fit::FitResult& r, const std::string& name) {
  for (const fit::ParameterEstimate& p : r.parameters) {
    if (p.name == name) return p.value;
  }
  ADD_FAILURE() << "no parameter " << name;
  return std::numeric_limits<double>::quiet_NaN();
}

// Over directions with theta <= T, the mean of cos theta_i cos theta_o under the measure
// dwi dwo is (int cos dw / int dw)^2 = (pi sin^2 T / (2 pi (1 - cos T)))^2; and the mean of
// cos theta_i alone is its square root. The weights must give both, whatever the grid.
TEST(BrdfSpaceSampling, WeightsAreTheMeasureOfPairsOfDirections) {
  const AnalyticBrdf brdf(Lambert);
  for (double cut : {80.0, 89.0}) {
    for (int cells : {24, 45}) {
      fit::BrdfSpaceSampling s;
      s.theta_d_cells = s.phi_d_cells = cells;
      s.max_theta_deg = cut;
      const fit::BrdfSpaceData data = fit::SampleBrdfSpace(brdf, s);
      double w_sum = 0, ci = 0, cico = 0;
      for (std::size_t k = 0; k < data.points.size(); ++k) {
        const double zi = data.points[k].lights[0].l.z, zo = data.points[k].v.z;
        w_sum += data.weights[k];
        ci += data.weights[k] * zi;
        cico += data.weights[k] * zi * zo;
      }
      const double t = cut * kDeg;
      const double one = std::sin(t) * std::sin(t) / (2 * (1 - std::cos(t)));
      SCOPED_TRACE("cut " + std::to_string(cut) + ", cells " + std::to_string(cells));
      EXPECT_NEAR(w_sum / data.points.size(), 1.0, 1e-12);  // normalised to mean 1
      EXPECT_NEAR(ci / w_sum, one, 0.01 * one);
      EXPECT_NEAR(cico / w_sum, one * one, 0.01 * one * one);
    }
  }
}

// The irradiance is sqrt(w) and the target sqrt(w) f cos theta_i, so the twin's radiance for
// the Lambert BRDF's own values equals the target.
TEST(BrdfSpaceSampling, TargetsAreTheWeightedCosineBrdf) {
  const AnalyticBrdf brdf(Lambert);
  const fit::BrdfSpaceData data = fit::SampleBrdfSpace(brdf, fit::BrdfSpaceSampling{});
  ASSERT_GT(data.points.size(), 10000u);
  for (std::size_t k = 0; k < data.points.size(); k += 997) {
    const ShadingPoint& p = data.points[k];
    const double s = std::sqrt(data.weights[k]);
    EXPECT_NEAR(p.lights[0].irradiance.x, s, 1e-12);
    EXPECT_NEAR(data.targets[3 * k], s * 0.5 / kPi * p.lights[0].l.z, 1e-12);
    EXPECT_LE(std::acos(p.lights[0].l.z), 80 * kDeg);
    EXPECT_LE(std::acos(p.v.z), 80 * kDeg);
  }
  // Cells with theta_d > 75 deg exist inside the 80 deg cut (theta_h small, both directions
  // near 75-80 deg on opposite sides).
  EXPECT_GT(data.extrapolated_fraction, 0.0);
  EXPECT_LT(data.extrapolated_fraction, 0.2);
}

TEST(BrdfSpaceFit, RecoversAnalyticGgx) {
  const AnalyticBrdf brdf(LambertGgx);
  const fit::BrdfSpaceData data = fit::SampleBrdfSpace(brdf, fit::BrdfSpaceSampling{});
  const fit::FitResult r = fit::FitBrdfSpace(FindModel("ggx"), {}, data);
  EXPECT_TRUE(r.converged) << fit::TerminationName(r.termination);
  EXPECT_NEAR(Value(r, "roughness"), kRoughness, 0.01 * kRoughness);
  const char* ch[3] = {"r", "g", "b"};
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(Value(r, std::string("kd.") + ch[c]), kKd[c], 0.01 * kKd[c]) << ch[c];
    EXPECT_NEAR(Value(r, std::string("f0.") + ch[c]), kF0[c], 0.01 * kF0[c]) << ch[c];
  }
  EXPECT_LT(r.rmse, 1e-6);
  ASSERT_EQ(r.references.size(), 1u);
  EXPECT_EQ(r.references[0].name, "brdf-space");
  EXPECT_EQ(r.inputs["brdf_space"]["cells"].get<std::size_t>(), data.points.size());
}

TEST(BrdfSpaceFit, RecoversANarrowNormalisedBlinnPhongLobe) {
  const AnalyticBrdf brdf(NormalisedBlinnPhong);
  const fit::FitResult r = fit::FitBrdfSpace(FindModel("blinn-phong-normalized"), {},
                                             fit::SampleBrdfSpace(brdf, fit::BrdfSpaceSampling{}));
  EXPECT_NEAR(Value(r, "shininess"), kShininess, 0.01 * kShininess);
  EXPECT_NEAR(Value(r, "ks.g"), kKs, 0.01 * kKs);
  EXPECT_NEAR(Value(r, "kd.b"), kKdGrey, 0.01 * kKdGrey);
}

// The rows are sampled in parallel and joined in row order, so a rerun gives the same bytes
// (the study's byte-identical reruns need it).
TEST(BrdfSpaceSampling, RepeatsToTheBit) {
  const AnalyticBrdf brdf(LambertGgx);
  const fit::BrdfSpaceData a = fit::SampleBrdfSpace(brdf, fit::BrdfSpaceSampling{});
  const fit::BrdfSpaceData b = fit::SampleBrdfSpace(brdf, fit::BrdfSpaceSampling{});
  ASSERT_EQ(a.targets.size(), b.targets.size());
  for (std::size_t i = 0; i < a.targets.size(); ++i) ASSERT_EQ(a.targets[i], b.targets[i]) << i;
}

Vec3d NotANumber(const Vec3d&, const Vec3d& wo) {
  return Vec3d{wo.z > 0.5 ? 1.0 : std::numeric_limits<double>::quiet_NaN(), 0, 0};
}

TEST(BrdfSpaceErrors, BadValuesSamplingAndSettingsAreNamed) {
  auto message = [](auto&& f) {
    try {
      f();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const AnalyticBrdf nan(NotANumber);
  EXPECT_NE(message([&] { fit::SampleBrdfSpace(nan, fit::BrdfSpaceSampling{}); }).find("value"),
            std::string::npos);
  fit::BrdfSpaceSampling bad;
  bad.theta_h_cells = 1;
  EXPECT_NE(message([&] { fit::ValidateBrdfSpaceSampling(bad, "s.toml"); })
                .find("brdf_space.theta_h_cells"),
            std::string::npos);
  bad = {};
  bad.max_theta_deg = 90;
  EXPECT_NE(message([&] { fit::ValidateBrdfSpaceSampling(bad, ""); }).find("max_theta_deg"),
            std::string::npos);
  const AnalyticBrdf lambert(Lambert);
  fit::BrdfSpaceSampling small;
  small.theta_d_cells = small.phi_d_cells = 8;
  const fit::BrdfSpaceData data = fit::SampleBrdfSpace(lambert, small);
  fit::FitOptions cube;
  cube.loss = fit::Loss::kCubeRoot;
  // The library's words (the CLI says --loss: tests/cli/bad_input_test.cpp).
  EXPECT_EQ(message([&] { fit::FitBrdfSpace(FindModel("ggx"), {}, data, cube); }).rfind("loss: ", 0),
            0u);
  fit::FitOptions free;
  free.exposure = fit::Exposure::kFree;
  EXPECT_EQ(
      message([&] { fit::FitBrdfSpace(FindModel("ggx"), {}, data, free); }).rfind("exposure: ", 0),
      0u);
  EXPECT_NE(message([&] { fit::FitBrdfSpace(FindModel("ggx-typo"), {}, data); }).find("ggx"),
            std::string::npos);
}

}  // namespace
}  // namespace shadefit::testing
