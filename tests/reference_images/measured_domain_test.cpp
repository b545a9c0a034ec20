// The measured domain of a measured reference (docs/measured_and_imported.md, "The measured
// domain"): the per-pixel extrapolated share RenderMeasured computes, checked against theta_d
// worked out by hand from the scene's geometry; the domain file and sidecar fields
// MakeMeasuredReference writes; and LoadReference's one-line errors on a bad domain file.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>

#include "reference_images_test_util.h"
#include "shadefit/reference_images/measured_brdf.h"
#include "shadefit/reference_images/reference.h"
#include "shadefit/reference_images/render_measured.h"
#include "shadefit/base/error.h"
#include "test_util.h"

namespace shadefit::reference_images {
namespace {

namespace fs = std::filesystem;
constexpr double kDeg = 3.14159265358979323846 / 180.0;

const std::string& AnalyticMerl() {
  static const std::string path = [] {
    const std::string out = testing::OutputDir() + "/domain-analytic.binary";
    const testing::AnalyticBrdf brdf;
    WriteMerlBinary(out, [&](double th, double td, double pd) { return brdf.Angles(th, td, pd); });
    return out;
  }();
  return path;
}

// Two scenes with a directional light, l = (0, -cos a, sin a) towards the light:
// - a unit sphere seen from (0, -6, 0) (fov 22 degrees, +z up), a = 148 degrees from the view of
//   its centre, (0, -1, 0): a rim light, whose lit crescent is seen beyond theta_d = 75 degrees
//   (the perspective view of the crescent turns the angle between l and v wider than a) while
//   the unlit rest reflects nothing and is measured;
// - a 4 x 4 plane (normal +z) seen from 80 degrees off its normal at 5 m (fov 30 degrees), the
//   light at the mirror direction, a = 160 degrees: theta_d ~ 80 degrees at the centre, and the
//   perspective spreads it over 75 degrees, so the lit plane holds both kinds of pixel.
struct HandScene {
  bool sphere = true;
  double light_deg = 148.0;
  Vec3d camera{0.0, -6.0, 0.0};
  double fov_y_deg = 22.0;
  Vec3d Light() const {
    const double a = light_deg * kDeg;
    return {0.0, -std::cos(a), std::sin(a)};
  }
  std::string Toml(int size) const {
    const Vec3d l = Light();
    char text[1024];
    std::snprintf(text, sizeof text,
                  "[camera]\nposition = [%.17g, %.17g, %.17g]\nlook_at = [0.0, 0.0, 0.0]\n"
                  "up = [0.0, 0.0, 1.0]\nfov_y = %.17g\nresolution = [%d, %d]\n"
                  "[[objects]]\n%s\n"
                  "[[lights]]\ntype = \"directional\"\ndirection = [%.17g, %.17g, %.17g]\n"
                  "irradiance = 3.0\n[background]\ntransparent = true\n",
                  camera.x, camera.y, camera.z, fov_y_deg, size, size,
                  sphere ? "type = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0"
                         : "type = \"plane\"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n"
                           "half_size = [2.0, 2.0]",
                  -l.x, -l.y, -l.z);
    return text;
  }
};
HandScene RimSphere() { return {}; }
HandScene GrazingPlane() {
  HandScene s;
  s.sphere = false;
  s.light_deg = 160.0;
  s.camera = {0.0, -5.0 * std::sin(80 * kDeg), 5.0 * std::cos(80 * kDeg)};
  s.fov_y_deg = 30.0;
  return s;
}
std::string RimSceneToml(int size) { return RimSphere().Toml(size); }

// theta_d by hand for pixel (x, y): the pinhole ray through the pixel centre (row 0 on top; the
// camera looks at the origin with +z up, so right = forward x z and up = right x forward), its
// hit on the sphere or the plane, then half the angle between the directions to the light and
// to the camera (theta_d is the angle between wi and h, and h bisects wi and wo). Returns false
// when the ray misses; *lit when both n.l and n.v are > 1e-3.
bool ThetaDByHand(const HandScene& scene, int x, int y, int size, double* theta_d_deg,
                  bool* lit, Vec3d* hit, Vec3d* normal) {
  const Vec3d cam = scene.camera;
  const Vec3d forward = Normalize(cam * -1.0);
  const Vec3d right = Normalize(Cross(forward, Vec3d{0, 0, 1}));
  const Vec3d up = Cross(right, forward);
  const double t = std::tan(0.5 * scene.fov_y_deg * kDeg);
  const double nx = 2.0 * (x + 0.5) / size - 1.0, ny = 1.0 - 2.0 * (y + 0.5) / size;
  const Vec3d d = Normalize(forward + right * (nx * t) + up * (ny * t));
  Vec3d p, n;
  if (scene.sphere) {
    // |cam + s d|^2 = 1: s^2 + 2 s (cam.d) + |cam|^2 - 1 = 0, nearer root.
    const double b = Dot(cam, d), c = Dot(cam, cam) - 1.0;
    const double disc = b * b - c;
    if (disc <= 0) return false;
    p = cam + d * (-b - std::sqrt(disc));
    n = Normalize(p);
  } else {
    if (d.z >= 0) return false;
    p = cam + d * (-cam.z / d.z);
    if (std::abs(p.x) > 2.0 || std::abs(p.y) > 2.0) return false;
    n = {0, 0, 1};
  }
  const Vec3d v = Normalize(cam - p);
  const Vec3d l = scene.Light();
  *theta_d_deg = 0.5 * std::acos(std::clamp(Dot(l, v), -1.0, 1.0)) / kDeg;
  *lit = Dot(n, l) > 1e-3 && Dot(n, v) > 1e-3;
  *hit = p;
  *normal = n;
  return true;
}

struct DomainCounts {
  int checked = 0, measured_lit = 0, extrapolated_lit = 0, unlit = 0, background = 0;
};

// RenderMeasured's share against the hand-made theta_d at every pixel away from the silhouette,
// the terminator and the limit (by 0.1 degree: the G-buffer is float).
DomainCounts CheckAgainstHand(const HandScene& hand, int size) {
  Renderer& renderer = shadefit::testing::SharedRenderer();
  const Scene scene = ParseScene(hand.Toml(size), "hand.toml");
  const GBuffer g = renderer.RenderGBuffer(scene);
  const MerlBrdf merl(AnalyticMerl());
  Image share;
  RenderMeasuredStats stats;
  RenderMeasured(merl, scene, g, {}, nullptr, &stats, &share);
  DomainCounts n;
  EXPECT_EQ(share.width, size);
  EXPECT_EQ(share.channels, 1);
  if (share.width != size || share.channels != 1) return n;
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      double theta_d = 0;
      bool lit = false;
      Vec3d p, normal;
      if (!ThetaDByHand(hand, x, y, size, &theta_d, &lit, &p, &normal)) {
        if (g.Coverage(x, y) == 0) {
          EXPECT_EQ(share.at(x, y, 0), 0.0f) << "no surface at " << x << "," << y;
          ++n.background;
        }
        continue;
      }
      if (g.Coverage(x, y) < 1) continue;  // the silhouette: sub-pixel coverage
      // The hand-made camera is the renderer's: the G-buffer's hit point agrees.
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(g.position.at(x, y, c), p[c], 2e-3) << x << "," << y;
      }
      const bool near_terminator = std::abs(Dot(normal, hand.Light())) < 2e-3;
      if (near_terminator || std::abs(theta_d - kMeasuredThetaDMaxDeg) < 0.1) continue;
      ++n.checked;
      const float want = lit && theta_d > kMeasuredThetaDMaxDeg ? 1.0f : 0.0f;
      EXPECT_EQ(share.at(x, y, 0), want)
          << "pixel " << x << "," << y << " theta_d " << theta_d << " lit " << lit;
      if (!lit) {
        ++n.unlit;
      } else if (theta_d > kMeasuredThetaDMaxDeg) {
        ++n.extrapolated_lit;
      } else {
        ++n.measured_lit;
      }
    }
  }
  EXPECT_EQ(stats.shaded_pixels - stats.measured_pixels,
            static_cast<int>(std::count(share.data.begin(), share.data.end(), 1.0f)));
  std::printf("[ domain ] %s: %d pixels checked: %d lit measured, %d lit extrapolated, %d unlit; "
              "%d background; %d of %d shaded measured\n",
              hand.sphere ? "rim sphere" : "grazing plane", n.checked, n.measured_lit,
              n.extrapolated_lit, n.unlit, n.background, stats.measured_pixels,
              stats.shaded_pixels);
  return n;
}

TEST(MeasuredDomain, ShareMatchesThetaDWorkedOutByHand) {
  // Each scene is meant to hold the kinds of pixel named.
  const DomainCounts rim = CheckAgainstHand(RimSphere(), 96);
  EXPECT_GT(rim.extrapolated_lit, 20);
  EXPECT_GT(rim.unlit, 1000);
  EXPECT_GT(rim.background, 1000);
  const DomainCounts plane = CheckAgainstHand(GrazingPlane(), 96);
  EXPECT_GT(plane.measured_lit, 100);
  EXPECT_GT(plane.extrapolated_lit, 100);
  EXPECT_GT(plane.background, 100);
}

// The uniform light: the share is that of the estimate's luminance. At normal view (wo = n)
// theta_d = theta_i / 2 <= 45 degrees for every sample, so the share is 0; towards the
// silhouette theta_d reaches (theta_o + 90) / 2 and part of the estimate, not all, lies beyond.
TEST(MeasuredDomain, EnvironmentShareIsTheExtrapolatedPartOfTheEstimate) {
  constexpr int kSize = 48;
  Renderer& renderer = shadefit::testing::SharedRenderer();
  const Scene scene = ParseScene(
      shadefit::testing::SphereSceneToml(kSize, kSize,
                                         "[[lights]]\ntype = \"uniform\"\nradiance = 1.0\n"
                                         "samples = 64\n"),
      "furnace.toml");
  const GBuffer g = renderer.RenderGBuffer(scene);
  const MerlBrdf merl(AnalyticMerl());
  Image share;
  RenderMeasured(merl, scene, g, {}, nullptr, nullptr, &share);
  const int c = kSize / 2;
  EXPECT_EQ(share.at(c, c, 0), 0.0f) << "theta_o ~ 0: theta_d <= 45 degrees";
  // Near the silhouette part of the estimate comes from beyond the limit, but not all of it.
  float edge = 0;
  for (int x = c; x < kSize; ++x) {
    if (g.Coverage(x, c) == 1) edge = std::max(edge, share.at(x, c, 0));
  }
  EXPECT_GT(edge, 0.05f);
  EXPECT_LT(edge, 1.0f);
}

// MakeMeasuredReference: the domain file beside the EXR, the sidecar's measured_domain, and
// LoadReference reading it back.
struct Written {
  std::string exr, sidecar, domain;
};
Written WriteReference(const std::string& leaf) {
  const fs::path dir = fs::path(testing::OutputDir()) / leaf;
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path scene = dir / "rim.toml";
  std::ofstream(scene) << RimSceneToml(64);
  MeasuredReferenceRequest request;
  request.brdf_path = AnalyticMerl();
  request.scene_path = scene.string();
  request.output = (dir / "ref.exr").string();
  MakeMeasuredReference(request, shadefit::testing::SharedRenderer());
  return {request.output, (dir / "ref.json").string(), (dir / "ref.domain.png").string()};
}

std::string LoadError(const std::string& exr) {
  try {
    LoadReference(exr);
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(MeasuredDomain, ReferenceRecordsAndLoadsItsDomain) {
  const Written w = WriteReference("domain-ok");
  ASSERT_TRUE(fs::exists(w.domain));
  std::ifstream in(w.sidecar);
  const nlohmann::json sidecar = nlohmann::json::parse(in);
  const nlohmann::json& d = sidecar.at("measured_domain");
  EXPECT_EQ(d.at("file"), "ref.domain.png");
  EXPECT_EQ(d.at("theta_d_max_deg"), 75.0);
  EXPECT_EQ(d.at("measured_share_max"), 0.01);
  EXPECT_NE(d.at("rule").get<std::string>().find("Matusik"), std::string::npos);
  const int covered = d.at("counts").at("covered"), measured = d.at("counts").at("measured");
  EXPECT_GT(covered, measured);
  EXPECT_GT(measured, 0);

  const Reference ref = LoadReference(w.exr);
  ASSERT_FALSE(ref.extrapolated_share.empty());
  EXPECT_EQ(ref.measured_share_max, 0.01);
  EXPECT_EQ(ref.domain_path, fs::path(w.domain).lexically_normal().string());
  int n_covered = 0, n_measured = 0;
  for (int y = 0; y < ref.image.height; ++y) {
    for (int x = 0; x < ref.image.width; ++x) {
      if (!(ref.image.at(x, y, 3) > 0)) continue;
      ++n_covered;
      if (IsMeasuredPixel(ref, x, y)) ++n_measured;
    }
  }
  EXPECT_EQ(n_covered, covered);
  EXPECT_EQ(n_measured, measured);
}

TEST(MeasuredDomain, BadDomainFileIsOneLineErrorNamingFileAndField) {
  const Written w = WriteReference("domain-bad");
  auto expect_error = [&](const std::string& what, const std::string& file,
                          const std::string& field) {
    const std::string msg = LoadError(w.exr);
    EXPECT_NE(msg.find(file), std::string::npos) << what << ": " << msg;
    EXPECT_NE(msg.find(field), std::string::npos) << what << ": " << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << what << ": one line: " << msg;
  };
  const std::string saved = w.domain + ".saved";
  fs::copy_file(w.domain, saved);

  fs::remove(w.domain);
  expect_error("missing", "ref.json", "measured_domain.file");

  Image small(32, 32, 1, 0.0f);
  WritePng8(w.domain, small);
  expect_error("wrong size", "ref.domain.png", "resolution");

  Image rgb(64, 64, 3, 0.0f);
  WritePng8(w.domain, rgb);
  expect_error("three channels", "ref.domain.png", "channels");

  std::ofstream(w.domain, std::ios::binary | std::ios::trunc) << "not a png";
  expect_error("not an image", "ref.domain.png", "header");

  fs::remove(w.domain);
  fs::copy_file(saved, w.domain);
  EXPECT_EQ(LoadError(w.exr), "no error");

  // The sidecar's fields.
  std::string text;
  {
    std::ifstream in(w.sidecar);
    text.assign(std::istreambuf_iterator<char>(in), {});
  }
  nlohmann::json j = nlohmann::json::parse(text);
  j["measured_domain"].erase("file");
  std::ofstream(w.sidecar, std::ios::trunc) << j.dump(1);
  expect_error("no file field", "ref.json", "measured_domain.file");
  j = nlohmann::json::parse(text);
  j["measured_domain"]["measured_share_max"] = "a lot";
  std::ofstream(w.sidecar, std::ios::trunc) << j.dump(1);
  expect_error("bad threshold", "ref.json", "measured_domain.measured_share_max");
  j = nlohmann::json::parse(text);
  j["measured_domain"] = 3;
  std::ofstream(w.sidecar, std::ios::trunc) << j.dump(1);
  expect_error("not an object", "ref.json", "measured_domain");
}

}  // namespace
}  // namespace shadefit::reference_images
