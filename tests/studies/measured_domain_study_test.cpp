// The measured domain through the study runner (docs/measured_and_imported.md, "The measured
// domain"): an analytic MERL table and the same table with its extrapolated region (theta_d >
// 75 degrees) replaced by garbage, as two materials of one study, fitted jointly to a key light
// (fully measured) and a plane seen at grazing (partly beyond the limit), and tested under a rim
// light (every lit pixel beyond it). The fits, the measured pixels of the references and every
// metric over measured pixels must be identical between the two; the all-pixel metrics of the
// grazing plane and of the rim light must differ. Needs no ../shared: the tables are written here.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "shadefit/reference_images/measured_brdf.h"
#include "shadefit/reference_images/reference.h"
#include "shadefit/studies/runner.h"
#include "shadefit/studies/study.h"

namespace shadefit::studies {
namespace {
namespace fs = std::filesystem;
using json = nlohmann::json;

constexpr double kPi = 3.14159265358979323846;

// Lambert (kd 0.3) + GGX (alpha 0.2, Walter et al. 2007 eq. 33; height-correlated Smith;
// Schlick f0 0.04), grey, in 1/sr.
Vec3d Analytic(double theta_h, double theta_d, double phi_d) {
  Vec3d wi, wo;
  reference_images::FromHalfDiff(theta_h, theta_d, phi_d, &wi, &wo);
  const double lambert = 0.3 / kPi;
  if (wi.z <= 0 || wo.z <= 0) return Vec3d{lambert, lambert, lambert};
  const double a2 = 0.04;
  const double k = std::cos(theta_h) * std::cos(theta_h) * (a2 - 1) + 1;
  const double d = a2 / (kPi * k * k);
  auto lambda = [&](double c) { return 0.5 * (-1 + std::sqrt(1 + a2 * (1 - c * c) / (c * c))); };
  const double g2 = 1 / (1 + lambda(wi.z) + lambda(wo.z));
  const double f = 0.04 + 0.96 * std::pow(1 - std::cos(theta_d), 5);
  const double v = lambert + f * d * g2 / (4 * wi.z * wo.z);
  return Vec3d{v, v, v};
}

// The same, with every cell beyond the measured limit replaced by large, uneven values.
Vec3d Garbage(double theta_h, double theta_d, double phi_d) {
  if (theta_d <= reference_images::kMeasuredThetaDMaxDeg * kPi / 180 + 1e-9) {
    return Analytic(theta_h, theta_d, phi_d);
  }
  const double g = 50.0 * (1.5 + std::sin(13 * theta_h + 7 * phi_d));
  return Vec3d{g, 0.5 * g, 2 * g};
}

// A 128^2 scene under one directional light `angle_deg` from the view of the origin (towards
// the light: (0, -cos a, sin a)): a unit sphere seen from (0, -6, 0), or a 4 x 4 plane (normal +z)
// seen from 80 degrees off its normal at 5 m.
std::string Scene(bool sphere, double angle_deg) {
  const double a = angle_deg * kPi / 180, c = 80 * kPi / 180;
  std::ostringstream s;
  s.precision(17);
  s << "[camera]\nposition = "
    << (sphere ? "[0.0, -6.0, 0.0]"
               : "[0.0, " + std::to_string(-5 * std::sin(c)) + ", " +
                     std::to_string(5 * std::cos(c)) + "]")
    << "\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\n"
    << "fov_y = " << (sphere ? 22.0 : 30.0) << "\nresolution = [128, 128]\n[[objects]]\n"
    << (sphere ? "type = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n"
               : "type = \"plane\"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n"
                 "half_size = [2.0, 2.0]\n")
    << "[[lights]]\ntype = \"directional\"\ndirection = [" << 0.0 << ", " << std::cos(a) << ", "
    << -std::sin(a) << "]\nirradiance = 3.0\n[background]\ntransparent = true\n";
  return s.str();
}

json ReadJson(const fs::path& p) {
  std::ifstream in(p);
  return json::parse(in);
}

TEST(MeasuredDomainStudy, GarbageBeyondTheLimitMovesOnlyTheAllPixelMetrics) {
  const fs::path dir = fs::path(SHADEFIT_TEST_OUTPUT) / "measured_domain_study";
  fs::remove_all(dir);
  fs::create_directories(dir / "merl");
  fs::create_directories(dir / "scenes");
  reference_images::WriteMerlBinary((dir / "merl" / "analytic.binary").string(), Analytic);
  reference_images::WriteMerlBinary((dir / "merl" / "garbage.binary").string(), Garbage);
  std::ofstream(dir / "scenes" / "sphere-key.toml") << Scene(true, 40.0);
  std::ofstream(dir / "scenes" / "plane-grazing.toml") << Scene(false, 160.0);
  std::ofstream(dir / "scenes" / "sphere-rim.toml") << Scene(true, 148.0);
  const std::string text =
      "[study]\nname = \"domain\"\n[[measured]]\nfolder = \"" + (dir / "merl").string() +
      "\"\nscenes = [\"" + (dir / "scenes").string() +
      "/*.toml\"]\n[fit]\nmodels = [\"ggx\"]\ntrain = [[\"key\", \"grazing\"]]\n"
      "loss = \"l2\"\nstarts = 1\nexposure = \"fixed\"\nmax_iterations = 30\npixel_stride = 2\n"
      "[outputs]\npreviews = true\nreport = false\n";
  std::ofstream(dir / "study.toml") << text;
  StudySpec spec = LoadStudy((dir / "study.toml").string(), false);
  MaterialiseMeasuredReferences(&spec, (dir / "out").string(), true);
  RunOptions run;
  run.jobs = 1;
  run.out_dir = (dir / "out").string();
  run.quiet = true;
  const RunSummary summary = RunStudy(spec, run);
  ASSERT_EQ(summary.failed, 0);
  const fs::path study = summary.study_dir;

  // The references: the domain does not depend on the BRDF's values, and the measured pixels
  // are the same; the garbage shows in the others.
  for (const std::string lighting : {"key", "grazing", "rim"}) {
    const reference_images::Reference a = reference_images::LoadReference(
        (study / "references" / ("analytic-" + lighting + ".exr")).string());
    const reference_images::Reference g = reference_images::LoadReference(
        (study / "references" / ("garbage-" + lighting + ".exr")).string());
    ASSERT_FALSE(a.extrapolated_share.empty()) << lighting;
    EXPECT_TRUE(a.extrapolated_share.data == g.extrapolated_share.data) << lighting;
    int measured_differ = 0, extrapolated_differ = 0;
    for (int y = 0; y < a.image.height; ++y) {
      for (int x = 0; x < a.image.width; ++x) {
        bool differ = false;
        for (int c = 0; c < 4; ++c) differ |= a.image.at(x, y, c) != g.image.at(x, y, c);
        (reference_images::IsMeasuredPixel(a, x, y) ? measured_differ : extrapolated_differ) +=
            differ;
      }
    }
    EXPECT_EQ(measured_differ, 0) << lighting;
    if (lighting == "key") {
      EXPECT_EQ(extrapolated_differ, 0);
    } else {
      EXPECT_GT(extrapolated_differ, 50) << lighting;
    }
  }

  const json a = ReadJson(study / "jobs" / "fit.analytic.ggx.key+grazing.json");
  const json g = ReadJson(study / "jobs" / "fit.garbage.ggx.key+grazing.json");
  ASSERT_EQ(a["status"], "ok");
  ASSERT_EQ(g["status"], "ok");
  // The fit saw measured pixels only: the same numbers.
  EXPECT_EQ(a["values"], g["values"]);
  ASSERT_EQ(a["evaluations"].size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    const json& ea = a["evaluations"][i];
    const json& eg = g["evaluations"][i];
    const std::string lighting = ea["lighting"];
    EXPECT_EQ(ea["metrics"], eg["metrics"]) << lighting;
    EXPECT_EQ(ea["measured_fraction"], eg["measured_fraction"]) << lighting;
    EXPECT_EQ(ea["metrics_pixels"], "covered and measured");
    if (lighting == "rim") {
      // Every lit pixel is beyond the limit: the measured ones are unlit and compare 0 with 0,
      // which says nothing of the material. No numbers, and why.
      EXPECT_TRUE(ea["metrics_full"].is_null()) << lighting;
      EXPECT_EQ(ea["metrics_none"],
                "no lit pixel is measured (every lit pixel depends on extrapolated data)");
      for (const auto& [key, value] : ea["metrics"].items()) EXPECT_TRUE(value.is_null()) << key;
    } else {
      // The numbers are pooled over the measured pixels, not over every covered one.
      EXPECT_EQ(ea["metrics_full"]["valid_pixels"], ea["measured_pixels"]) << lighting;
      for (const auto& [key, value] : ea["metrics"].items()) {
        EXPECT_FALSE(value.is_null()) << lighting << " " << key;
      }
    }
    if (lighting == "key") {
      EXPECT_EQ(ea["measured_fraction"], 1.0);
      EXPECT_EQ(ea["metrics_all"], ea["metrics"]);
      EXPECT_EQ(eg["metrics_all"], ea["metrics_all"]);
    } else {
      const double fraction = ea["measured_fraction"];
      EXPECT_GT(fraction, 0.0) << lighting;
      EXPECT_LT(fraction, 1.0) << lighting;
      // The grazing plane has lit pixels on both sides of the limit; the rim light none inside.
      EXPECT_LT(ea["measured_lit_pixels"].get<int>(), ea["lit_pixels"].get<int>()) << lighting;
      if (lighting == "grazing") {
        EXPECT_GT(ea["measured_lit_pixels"].get<int>(), 100);
      } else {
        EXPECT_EQ(ea["measured_lit_pixels"].get<int>(), 0);
      }
      for (const auto& [key, value] : ea["metrics_all"].items()) {
        if (key == "ms_ssim" || key == "ssim") continue;  // structure may not see it
        EXPECT_NE(value, eg["metrics_all"][key])
            << lighting << ": all-pixel " << key << " did not move";
      }
      EXPECT_NE(ea["metrics_all"]["relative_rmse"], ea["metrics"]["relative_rmse"]);
      const json& rel = ea["metrics"]["relative_rmse"];
      std::printf(
          "[ domain ] %s: measured fraction %.4f; relative RMSE measured %.4g (both), "
          "all pixels %.4g (analytic) vs %.4g (garbage)\n",
          lighting.c_str(), fraction, rel.is_null() ? NAN : rel.get<double>(),
          ea["metrics_all"]["relative_rmse"].get<double>(),
          eg["metrics_all"]["relative_rmse"].get<double>());
    }
    EXPECT_EQ(ea["images"]["domain"], "images/analytic-" + lighting + ".domain.png");
    EXPECT_TRUE(fs::exists(study / ea["images"]["domain"].get<std::string>()));
  }

  // results.csv: the measured metrics, measured_fraction, and the _all columns, per row.
  std::ifstream csv(study / "results.csv");
  std::string header;
  std::getline(csv, header);
  EXPECT_NE(header.find(",relative_rmse,"), std::string::npos) << header;
  EXPECT_NE(header.find(",measured_fraction,"), std::string::npos) << header;
  EXPECT_NE(header.find(",relative_rmse_all,"), std::string::npos) << header;
  EXPECT_NE(header.find(",flip_hdr_mean_all"), std::string::npos) << header;
}

}  // namespace
}  // namespace shadefit::studies
