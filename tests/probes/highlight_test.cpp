// Highlight probe on camera-lit spheres (light at the camera: l = v, so theta_h = theta_v and
// the highlight profile is the BRDF's specular term along one curve). Expected HWHM comes from
// the C++ twin of the model evaluated along that curve (the analytic lobe, with the small
// falloff of point-light irradiance across the sphere ignored).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "probe_test_util.h"

namespace shadefit::testing {
namespace {

using probes::HighlightProbe;
using probes::ModelUnderTest;
using probes::ProbeInputs;

constexpr int kRes = 96;

// Specular luminance of `m` (its diffuse switched off by the caller) at angle theta between n
// and v = l.
double Lobe(const ModelUnderTest& m, double theta) {
  const Vec3d v{0, 0, 1}, n{std::sin(theta), 0, std::cos(theta)};
  double out[3];
  Reflect(FindModel(m.model).id, m.params.data(), n, v, v, out);
  return out[1];
}

// Angle (deg) where the lobe falls to half its value at theta = 0.
double AnalyticHwhmDeg(const ModelUnderTest& m) {
  const double top = Lobe(m, 0.0);
  double lo = 0, hi = kPi / 2 * 0.999;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (Lobe(m, mid) > 0.5 * top ? lo : hi) = mid;
  }
  return lo * 180.0 / kPi;
}

probes::ProbeResult RunCamera(const std::vector<ModelUnderTest>& models) {
  ProbeInputs in;
  in.renderer = &SharedRenderer();
  in.truth = models.front();
  in.references.push_back(MakeReference(*in.truth, "camera", kRes));
  in.models = models;
  return HighlightProbe(in);
}

TEST(HighlightProbe, GgxFwhmGrowsWithRoughnessAndMatchesLobe) {
  double previous = 0;
  for (const double r : {0.3, 0.4, 0.5, 0.6}) {
    const auto m = MakeModel("ggx", "ggx", {"kd=0.2", "f0=0.5", fmt::format("roughness={}", r)});
    const auto res = RunCamera({m});
    const auto& n = res.numbers["reference"]["ggx-camera"];
    auto spec_only = m;
    spec_only.params[0] = spec_only.params[1] = spec_only.params[2] = 0;
    const double expected = AnalyticHwhmDeg(spec_only);
    const double hwhm = n["hwhm_deg"].get<double>();
    std::printf(
        "[ highlight ] ggx roughness %.1f: HWHM %.2f deg (analytic %.2f), FWHM %.1f px, "
        "tail %.3f, aspect %.3f, offset %.1f px\n",
        r, hwhm, expected, n["fwhm_px"].get<double>(), n["tail_fraction"].get<double>(),
        n["aspect"].get<double>(), n["offset_px"].get<double>());
    EXPECT_NEAR(hwhm, expected, 0.5 + 0.05 * expected) << "roughness " << r;
    EXPECT_GT(n["fwhm_deg"].get<double>(), previous);
    previous = n["fwhm_deg"].get<double>();
    // Round highlight at the mirror point (the sphere's centre pixel).
    EXPECT_LT(n["offset_px"].get<double>(), 1.5);
    EXPECT_LT(n["aspect"].get<double>(), 1.1);
    // The model identical to the truth reproduces the shape.
    EXPECT_NEAR(res.numbers["ggx"]["ggx-camera"]["fwhm_deg_ratio"].get<double>(), 1.0, 1e-3);
  }
}

// Matched half-width: Beckmann alpha_b = 0.25, Blinn-Phong n = 2 / alpha_b^2 - 2 = 30 (Walter et
// al. 2007, sec. 5.2), GGX roughness chosen so that its analytic HWHM equals Beckmann's.
TEST(HighlightProbe, GgxTailExceedsBeckmannAndBlinnPhongAtMatchedWidth) {
  const auto beckmann = MakeModel("beckmann", "beckmann", {"kd=0", "f0=0.5", "roughness=0.5"});
  const auto bp = MakeModel("blinn-phong", "blinn-phong", {"kd=0", "ks=0.5", "shininess=30"});
  const double target = AnalyticHwhmDeg(beckmann);
  double lo = 0.1, hi = 0.9;
  for (int i = 0; i < 40; ++i) {
    const double mid = 0.5 * (lo + hi);
    const auto g = MakeModel("ggx", "ggx", {"kd=0", "f0=0.5", fmt::format("roughness={}", mid)});
    (AnalyticHwhmDeg(g) < target ? lo : hi) = mid;
  }
  const auto ggx = MakeModel("ggx", "ggx", {"kd=0", "f0=0.5", fmt::format("roughness={}", lo)});
  double tail[3], hwhm[3];
  int k = 0;
  for (const auto& m : {ggx, beckmann, bp}) {
    const auto res = RunCamera({m});
    const auto& n = res.numbers["reference"][m.label + "-camera"];
    tail[k] = n["tail_fraction"].get<double>();
    hwhm[k] = n["hwhm_deg"].get<double>();
    std::printf("[ highlight ] matched width: %-12s HWHM %.2f deg (analytic %.2f) tail %.4f\n",
                m.label.c_str(), hwhm[k], AnalyticHwhmDeg(m), tail[k]);
    ++k;
  }
  EXPECT_NEAR(hwhm[0], hwhm[1], 0.1 * hwhm[1]);
  // GGX's long tail: measured 0.354 vs 0.029 (Beckmann) and 0.049 (Blinn-Phong, whose HWHM is
  // 4% narrower because n = 2 / alpha^2 - 2 is an approximation of the Beckmann width).
  EXPECT_GT(tail[0], 4.0 * tail[1]);
  EXPECT_GT(tail[0], 4.0 * tail[2]);
  EXPECT_LT(std::max(tail[1], tail[2]) / std::min(tail[1], tail[2]), 2.0);  // same family
}

TEST(HighlightProbe, KeyLightHighlightIsUpRightAndElongated) {
  const auto m = MakeModel("ggx", "ggx", {"kd=0.2", "f0=0.5", "roughness=0.4"});
  ProbeInputs in;
  in.renderer = &SharedRenderer();
  in.truth = m;
  in.references.push_back(MakeReference(m, "key", kRes));
  const auto res = HighlightProbe(in);
  const auto& n = res.numbers["reference"]["ggx-key"];
  std::printf(
      "[ highlight ] key light: peak (%g, %g) mirror (%g, %g), offset %.2f deg, "
      "aspect %.2f, orientation %.1f deg\n",
      n["peak_x"].get<double>(), n["peak_y"].get<double>(), n["mirror_x"].get<double>(),
      n["mirror_y"].get<double>(), n["offset_deg"].get<double>(), n["aspect"].get<double>(),
      n["orientation_deg"].get<double>());
  // The key light is up and right: the highlight sits in the upper right quadrant.
  EXPECT_GT(n["peak_x"].get<double>(), kRes / 2);
  EXPECT_LT(n["peak_y"].get<double>(), kRes / 2);
  EXPECT_LT(n["offset_deg"].get<double>(), 10.0);
  // Foreshortened along the radial direction (up-right diagonal), so the major axis runs along
  // the other diagonal: orientation -45 deg (y up).
  EXPECT_GT(n["aspect"].get<double>(), 1.005);
  EXPECT_NEAR(n["orientation_deg"].get<double>(), -45.0, 10.0);
}

}  // namespace
}  // namespace shadefit::testing
