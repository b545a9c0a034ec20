// Photographs, end to end (issue 12, item 4; docs/measured_and_imported.md, "Photographs"), on
// the real executable and an 8-bit set rendered here: a GGX sphere under eight directional
// lights, scaled by an exposure the workflow is not told, stored as a pure power (gamma 2.2, not
// sRGB) in 8 bits with its highlight clipped, a grey stand painted over the lower part of the
// sphere and masked out; and a dark mirror ball (black Phong lobe of exponent 500 on a dim
// ambient term, in a dim room) photographed under the same lights for the calibration. Every
// truth below is a number the renders were made with, never a result of the code under test.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "shadefit/render/image.h"

namespace {
namespace fs = std::filesystem;
using json = nlohmann::json;

constexpr double kPi = 3.14159265358979323846;

// The camera of every photograph: orthographic on -Y looking at +Y, +Z up, 2.4 world units
// high over 128 rows, so one world unit is 128 / 2.4 px and the origin is at pixel (96, 64).
constexpr int kW = 192, kH = 128;
constexpr double kPxPerUnit = kH / 2.4;
const char* kCamera =
    "[camera]\ntype = \"orthographic\"\nposition = [0.0, -10.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\n"
    "up = [0.0, 0.0, 1.0]\nheight = 2.4\nresolution = [192, 128]\nsupersample = 4\n";
// The mirror ball: radius 0.8 at (0.35, 0, 0.1), i.e. centre (114.67, 58.67) px, radius 42.67 px.
constexpr double kBallX = 0.35, kBallZ = 0.1, kBallR = 0.8;

// The material and the exposure of the set: GGX (kd, f0 = 0.04, roughness 0.35) under
// directional lights of irradiance 4: with the scenes' irradiance 1, the exposure to recover is 4.
constexpr double kKd[3] = {0.6, 0.4, 0.25};
constexpr double kRoughness = 0.35;
constexpr double kIrradiance = 4.0;
constexpr double kGamma = 2.2;  // stored = linear^(1 / 2.2): a pure power, not sRGB
constexpr double kBackground = 0.01, kStand = 0.3;

struct Light {
  std::string name;
  double to_light[3];
};

// Eight lights around the view axis (-Y): 30 degrees off it at even azimuths, 50 at odd ones.
std::vector<Light> Lights() {
  std::vector<Light> out;
  for (int i = 0; i < 8; ++i) {
    const double theta = (i % 2 == 0 ? 30.0 : 50.0) * kPi / 180.0, phi = 45.0 * i * kPi / 180.0;
    std::string name = "L";  // appended, not "L" + ...: GCC 12's -Wrestrict false positive
    name += std::to_string(i);
    out.push_back(
        {name, {std::sin(theta) * std::cos(phi), -std::cos(theta), std::sin(theta) * std::sin(phi)}});
  }
  return out;
}

std::string LightToml(const Light& l, double irradiance) {
  std::ostringstream s;
  s.precision(17);
  s << "[[lights]]\ntype = \"directional\"\ndirection = [" << -l.to_light[0] << ", "
    << -l.to_light[1] << ", " << -l.to_light[2] << "]\nirradiance = " << irradiance << "\n";
  return s.str();
}

void WriteText(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out << text;
}

json ReadJson(const fs::path& p) {
  std::ifstream in(p);
  return json::parse(in);
}

class PhotoWorkflow : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(SHADEFIT_TEST_OUTPUT) / "photo_workflow" / info->name();
    fs::remove_all(dir_);
    for (const char* d : {"truth", "balls", "photos", "scenes", "refs"}) {
      fs::create_directories(dir_ / d);
    }
  }

  // Runs `shadefit <args>` in dir_; stdout and stderr go to <dir>/last.{out,err}.
  int Shadefit(const std::string& args) {
    const std::string cmd =
        "cd '" + dir_.string() + "' && '" + SHADEFIT_EXE + "' " + args + " > last.out 2> last.err";
    const int status = std::system(cmd.c_str());
    std::ifstream err(dir_ / "last.err");
    std::ostringstream ss;
    ss << err.rdbuf();
    err_ = ss.str();
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

  // Renders `scene_text` with `model_args` and returns the linear RGBA render.
  shadefit::Image Render(const std::string& name, const std::string& scene_text,
                         const std::string& model_args) {
    const fs::path scene = dir_ / "truth" / (name + ".toml");
    WriteText(scene, scene_text);
    const std::string exr = "truth/" + name + ".exr";
    EXPECT_EQ(Shadefit("render --scene truth/" + name + ".toml " + model_args + " -o " + exr +
                       " --no-preview"),
              0)
        << err_;
    return shadefit::ReadImage((dir_ / exr).string());
  }

  // The dark mirror ball under light l, composited over the dim room, stored as sRGB 8-bit (a
  // camera's JPEG would be).
  void MirrorBallPhoto(const Light& l, const fs::path& png, bool with_light = true) {
    std::ostringstream scene;
    scene << kCamera << "\n[[objects]]\ntype = \"sphere\"\ncenter = [" << kBallX << ", 0.0, "
          << kBallZ << "]\nradius = " << kBallR << "\n\n"
          << LightToml(l, with_light ? 1.0 : 0.0)
          << "\n[[lights]]\ntype = \"ambient\"\nradiance = [0.05, 0.05, 0.05]\n"
          << "\n[background]\ntransparent = true\n";
    // kd 0, a Phong lobe of exponent 500 (peak exactly at the mirror direction) that clips,
    // ka 0.05: the ball is 0.0025, darker than the room (0.02), with a highlight of a few px.
    const shadefit::Image r = Render(png.stem().string(), scene.str(),
                                     "--model phong --set ka=0.05 --set kd=0 --set ks=50 "
                                     "--set shininess=500");
    shadefit::Image out(kW, kH, 3);
    for (int y = 0; y < kH; ++y) {
      for (int x = 0; x < kW; ++x) {
        const float a = r.at(x, y, 3);
        for (int c = 0; c < 3; ++c) {
          const float v = r.at(x, y, c) + (1.0f - a) * 0.02f;
          out.at(x, y, c) =
              std::round(255.0f * shadefit::SrgbOetf(std::clamp(v, 0.0f, 1.0f))) / 255.0f;
        }
      }
    }
    shadefit::WritePng8(png.string(), out);
  }

  // Whether pixel (x, y) is on the stand: a grey post 28 px wide under the sphere, from 0.7
  // radii below its centre to the bottom of the frame (it hides the sphere's lowest rows).
  static bool OnStand(int x, int y) {
    return std::abs(x + 0.5 - 96.0) < 14.0 && y + 0.5 > 64.0 + 0.7 * kPxPerUnit;
  }

  // The set: one 8-bit photograph per light (gamma 2.2 or sRGB, exposure 4, clipped, stand
  // painted in),
  // and the mask: the sphere's disc less a 1.5 px rim, less the stand and a 2 px margin.
  void SpherePhotos(bool srgb = false, const std::vector<Light>& lights = Lights()) {
    for (const Light& l : lights) {
      const std::string scene =
          std::string(kCamera) +
          "\n[[objects]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n\n" +
          LightToml(l, kIrradiance) + "\n[background]\ntransparent = true\n";
      std::ostringstream model;
      model << "--model ggx --set kd=" << kKd[0] << "," << kKd[1] << "," << kKd[2]
            << " --set f0=0.04 --set roughness=" << kRoughness;
      const shadefit::Image r = Render("sphere-" + l.name, scene, model.str());
      shadefit::Image out(kW, kH, 3);
      for (int y = 0; y < kH; ++y) {
        for (int x = 0; x < kW; ++x) {
          const float a = r.at(x, y, 3);
          for (int c = 0; c < 3; ++c) {
            double v = r.at(x, y, c) + (1.0f - a) * kBackground;
            if (OnStand(x, y)) v = kStand;
            v = std::clamp(v, 0.0, 1.0);
            v = srgb ? shadefit::SrgbOetf(static_cast<float>(v)) : std::pow(v, 1.0 / kGamma);
            out.at(x, y, c) = std::round(255.0 * v) / 255.0;
          }
        }
      }
      shadefit::WritePng8((dir_ / "photos" / ("sphere-" + l.name + ".png")).string(), out);
    }
    shadefit::Image mask(kW, kH, 1, 0.0f);
    for (int y = 0; y < kH; ++y) {
      for (int x = 0; x < kW; ++x) {
        const double d = std::hypot(x + 0.5 - 96.0, y + 0.5 - 64.0);
        const bool near_stand =
            OnStand(x, y) || OnStand(x - 2, y) || OnStand(x + 2, y) || OnStand(x, y + 2);
        mask.at(x, y, 0) = d < kPxPerUnit - 1.5 && !near_stand ? 1.0f : 0.0f;
      }
    }
    shadefit::WritePng8((dir_ / "mask.png").string(), mask);
  }

  // The template of the set's scenes: camera and sphere, no light.
  void Template() {
    WriteText(dir_ / "sphere.toml",
              std::string(kCamera) +
                  "\n[[objects]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n"
                  "\n[background]\ntransparent = true\n");
  }

  // Degrees between the light written into `scene` and the truth.
  static double AngleToTruth(const fs::path& lights_json, const Light& l) {
    const json lights = ReadJson(lights_json);
    for (const json& e : lights["lights"]) {
      if (e["lighting"] != l.name) continue;
      const double d = e["to_light"][0].get<double>() * l.to_light[0] +
                       e["to_light"][1].get<double>() * l.to_light[1] +
                       e["to_light"][2].get<double>() * l.to_light[2];
      return std::acos(std::clamp(d, -1.0, 1.0)) * 180.0 / kPi;
    }
    ADD_FAILURE() << l.name << " not in " << lights_json;
    return 180.0;
  }

  fs::path dir_;
  std::string err_;
};

// The calibration: `refs lights` on the dark mirror ball, without a mask (the ball is found by
// its contrast with the room, not taken for its few-pixel highlight) and with the ball's mask,
// recovers every light within 0.5 degree.
TEST_F(PhotoWorkflow, MirrorBallLightsWithinHalfADegree) {
  Template();
  std::string balls;
  for (const Light& l : Lights()) {
    MirrorBallPhoto(l, dir_ / "balls" / ("ball-" + l.name + ".png"));
    balls += " --ball balls/ball-" + l.name + ".png";
  }
  ASSERT_EQ(Shadefit("refs lights" + balls + " --scene-template sphere.toml -o scenes"), 0) << err_;
  double worst = 0;
  for (const Light& l : Lights()) {
    const double a = AngleToTruth(dir_ / "scenes" / "sphere-lights.json", l);
    EXPECT_LT(a, 0.5) << l.name;
    worst = std::max(worst, a);
    EXPECT_TRUE(fs::exists(dir_ / "scenes" / ("sphere-" + l.name + ".toml"))) << l.name;
  }
  std::printf("worst light direction error, no mask: %.4f deg\n", worst);
  const json found = ReadJson(dir_ / "scenes" / "sphere-lights.json");
  for (const json& e : found["lights"]) {
    EXPECT_EQ(e["found_by"], "contrast with the background");
    EXPECT_NEAR(e["ball_radius_px"].get<double>(), kBallR * kPxPerUnit, 0.75);
    EXPECT_NEAR(e["ball_center_px"][0].get<double>(), 96.0 + kBallX * kPxPerUnit, 0.5);
    EXPECT_NEAR(e["ball_center_px"][1].get<double>(), 64.0 - kBallZ * kPxPerUnit, 0.5);
  }

  // With the ball's mask: the disc is the mask's.
  shadefit::Image mask(kW, kH, 1, 0.0f);
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      const double d = std::hypot(x + 0.5 - (96.0 + kBallX * kPxPerUnit),
                                  y + 0.5 - (64.0 - kBallZ * kPxPerUnit));
      mask.at(x, y, 0) = d < kBallR * kPxPerUnit ? 1.0f : 0.0f;
    }
  }
  shadefit::WritePng8((dir_ / "ball-mask.png").string(), mask);
  fs::create_directories(dir_ / "scenes-masked");
  ASSERT_EQ(Shadefit("refs lights" + balls +
                     " --mask ball-mask.png --scene-template sphere.toml -o scenes-masked"),
            0)
      << err_;
  worst = 0;
  for (const Light& l : Lights()) {
    const double a = AngleToTruth(dir_ / "scenes-masked" / "sphere-lights.json", l);
    EXPECT_LT(a, 0.5) << l.name;
    worst = std::max(worst, a);
  }
  std::printf("worst light direction error, ball mask: %.4f deg\n", worst);
  const json found_masked = ReadJson(dir_ / "scenes-masked" / "sphere-lights.json");
  for (const json& e : found_masked["lights"]) {
    EXPECT_EQ(e["found_by"], "mask");
  }
}

// `refs import --auto-sphere` on the dark mirror ball: without a mask it finds the ball (32 px),
// not its highlight; with a mask it takes the mask's disc, even one that is not the ball's.
TEST_F(PhotoWorkflow, AutoSphereOnADarkMirrorBall) {
  const Light l = Lights()[1];
  MirrorBallPhoto(l, dir_ / "balls" / "ball.png");
  ASSERT_EQ(Shadefit("refs import balls/ball.png --auto-sphere -o refs/ball.exr"), 0) << err_;
  const json s = ReadJson(dir_ / "refs" / "ball.json")["auto_sphere"];
  EXPECT_NEAR(s["radius_px"].get<double>(), kBallR * kPxPerUnit, 0.75);
  EXPECT_NEAR(s["center_px"][0].get<double>(), 96.0 + kBallX * kPxPerUnit, 0.5);
  EXPECT_NEAR(s["center_px"][1].get<double>(), 64.0 - kBallZ * kPxPerUnit, 0.5);

  // A mask disc of radius 40 px at (90, 60): the sphere must be that disc.
  shadefit::Image mask(kW, kH, 1, 0.0f);
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      mask.at(x, y, 0) = std::hypot(x + 0.5 - 90.0, y + 0.5 - 60.0) < 40.0 ? 1.0f : 0.0f;
    }
  }
  shadefit::WritePng8((dir_ / "disc.png").string(), mask);
  ASSERT_EQ(Shadefit("refs import balls/ball.png --auto-sphere --mask disc.png -o refs/m.exr"), 0)
      << err_;
  const json m = ReadJson(dir_ / "refs" / "m.json")["auto_sphere"];
  EXPECT_EQ(m["found_by"], "mask");
  EXPECT_NEAR(m["radius_px"].get<double>(), 40.0, 0.75);
  EXPECT_NEAR(m["center_px"][0].get<double>(), 90.0, 0.5);
  EXPECT_NEAR(m["center_px"][1].get<double>(), 60.0, 0.5);
}

// The whole workflow: calibrate the lights from the ball, import each photograph with its mask,
// fit GGX jointly on four lights with a free exposure and a fitted encoding, test on the other
// four (a study), and check what it recovered against the numbers the set was made with.
TEST_F(PhotoWorkflow, GammaSetEndToEnd) {
  Template();
  SpherePhotos();
  std::string balls;
  for (const Light& l : Lights()) {
    MirrorBallPhoto(l, dir_ / "balls" / ("ball-" + l.name + ".png"));
    balls += " --ball balls/ball-" + l.name + ".png";
  }
  ASSERT_EQ(Shadefit("refs lights" + balls + " --scene-template sphere.toml -o scenes"), 0) << err_;
  long clipped = 0, masked_out = 0;
  for (const Light& l : Lights()) {
    ASSERT_EQ(Shadefit("refs import photos/sphere-" + l.name + ".png --scene scenes/sphere-" +
                       l.name + ".toml --mask mask.png -o refs/sphere-" + l.name + ".exr"),
              0)
        << err_;
    const json counts = ReadJson(dir_ / "refs" / ("sphere-" + l.name + ".json"))["counts"];
    clipped += counts["clipped"].get<long>();
    masked_out += counts["masked_out"].get<long>();
  }
  EXPECT_GT(clipped, 0) << "the set must have clipped highlights";
  EXPECT_GT(masked_out, 0);

  // The study template of the docs, as shipped: it names the lightings L0..L7 as here.
  fs::copy_file(std::string(SHADEFIT_SOURCE_DIR) + "/studies/photo_set_template.toml",
                dir_ / "photo.toml");
  ASSERT_EQ(Shadefit("study run photo.toml -o out -j 1 -q"), 0) << err_;

  // Every model of the template fitted, each with its own pin of the free exposure's scale
  // (fit/exposure_pin.h), and none left a parameter undetermined: the Blinn-Phongs at exposure 1
  // (their reflectances in the photographs' units), the microfacet models with f0.g held at the
  // truth's 0.04.
  const fs::path jobs = dir_ / "out" / "photo_set" / "jobs";
  std::map<std::string, json> fits;
  for (const auto& e : fs::directory_iterator(jobs)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("fit.", 0) == 0 && name.find(".timing.") == std::string::npos) {
      const json j = ReadJson(e.path());
      fits[j["model"].get<std::string>()] = j;
    }
  }
  ASSERT_EQ(fits.size(), 5u);
  for (const auto& [model, j] : fits) {
    ASSERT_EQ(j["status"], "ok") << model << ": " << j.dump(1);
    EXPECT_FALSE(j["fit"]["exposure"]["pinned"].get<std::string>().empty()) << model;
    for (const json& p : j["parameters"]) {
      EXPECT_FALSE(p["undetermined"].get<bool>()) << model << " " << p["name"];
    }
    std::printf("%s: exposure %.4g, pinned: %.60s...\n", model.c_str(),
                j["exposure"].get<double>(),
                j["fit"]["exposure"]["pinned"].get<std::string>().c_str());
  }
  EXPECT_EQ(fits["blinn-phong"]["exposure"].get<double>(), 1.0);
  {  // The report's parameter table says why f0.g is fixed although the study fixes nothing.
    std::ifstream in(dir_ / "out" / "photo_set" / "report" / "tables" / "parameters.md");
    std::ostringstream table;
    table << in.rdbuf();
    EXPECT_NE(table.str().find("fixed (free exposure)"), std::string::npos) << table.str();
    EXPECT_NE(table.str().find("fixed (no ambient light)"), std::string::npos);
  }
  const json& job = fits["ggx"];

  // The encoding: the pure power wins, at 2.2.
  const json& enc = job["encoding"];
  EXPECT_EQ(enc["chosen"], "gamma");
  EXPECT_NEAR(enc["gamma"].get<double>(), kGamma, 0.05);
  double srgb = 0, linear = 0, power = 0;
  for (const json& c : enc["candidates"]) {
    (c["encoding"] == "srgb"     ? srgb
     : c["encoding"] == "linear" ? linear
                                 : power) = c["stored_rmse"].get<double>();
  }
  std::printf("stored-value RMSE x255: srgb %.3f, linear %.3f, gamma %.3f (gamma %.4f)\n",
              255 * srgb, 255 * linear, 255 * power, enc["gamma"].get<double>());
  EXPECT_LT(power * 255, 1.0);  // Quantisation alone is 1 / sqrt(12) = 0.29 codes.

  // The score means what it says: recomputed here from the fitted values, a render by
  // `shadefit render`, the chosen power and the photographs' own 8-bit codes, over the pixels the
  // fit used (alpha 1 in the imports: covered, in the mask, not clipped).
  {
    std::ostringstream set;
    set.precision(17);
    std::vector<double> values = job["values"].get<std::vector<double>>();
    set << "--model ggx --set kd=" << values[0] << "," << values[1] << "," << values[2]
        << " --set f0=" << values[3] << "," << values[4] << "," << values[5]
        << " --set roughness=" << values[6];
    const double exposure = job["exposure"], g = enc["gamma"];
    double sq = 0;
    long n = 0;
    for (const char* l : {"L0", "L3", "L4", "L7"}) {
      const std::string name = std::string("sphere-") + l;
      ASSERT_EQ(Shadefit("render --scene scenes/" + name + ".toml " + set.str() + " -o truth/" +
                         name + ".check.exr --no-preview"),
                0)
          << err_;
      const shadefit::Image r =
          shadefit::ReadImage((dir_ / "truth" / (name + ".check.exr")).string());
      const shadefit::Image imp = shadefit::ReadImage((dir_ / "refs" / (name + ".exr")).string());
      const shadefit::Image png = shadefit::ReadImage((dir_ / "photos" / (name + ".png")).string());
      for (int y = 0; y < kH; ++y) {
        for (int x = 0; x < kW; ++x) {
          if (!(imp.at(x, y, 3) >= 1.0f - 1e-5f)) continue;
          for (int c = 0; c < 3; ++c) {
            const double e = std::pow(std::clamp(exposure * r.at(x, y, c), 0.0, 1.0), 1.0 / g);
            sq += std::pow(e - png.at(x, y, c), 2);
            ++n;
          }
        }
      }
    }
    const double rmse = std::sqrt(sq / n);
    std::printf("stored-value RMSE recomputed: %.4f codes over %ld values\n", 255 * rmse, n);
    EXPECT_NEAR(enc["stored_rmse"].get<double>(), rmse, 0.02 * rmse);
    EXPECT_EQ(enc["scored_values"].get<long>(), n);
  }

  // GGX's material and the exposure (f0.g held at the truth, 0.04, which fixes the scale).
  for (const json& p : job["parameters"]) {
    const std::string n = p["name"];
    const double v = p["value"];
    const char* kd_names[3] = {"kd.r", "kd.g", "kd.b"};
    if (n == "roughness") {
      EXPECT_NEAR(v, kRoughness, 0.02 * kRoughness) << n;
    }
    for (int c = 0; c < 3; ++c) {
      if (n == kd_names[c]) {
        EXPECT_NEAR(v, kKd[c], 0.03 * kKd[c]) << n;
      }
    }
  }
  EXPECT_NEAR(job["exposure"].get<double>(), kIrradiance, 0.03 * kIrradiance);

  // Held out: the four lights not trained on, in the chosen decoding.
  int tests = 0;
  for (const json& e : job["evaluations"]) {
    if (e["split"] != "test") continue;
    ++tests;
    const double rel = e["metrics"]["relative_rmse"];
    std::printf("held out %s: relative RMSE %.4f\n", e["lighting"].get<std::string>().c_str(), rel);
    EXPECT_LT(rel, 0.02) << e["lighting"];  // measured 0.0085 - 0.0135; test lightings left in
                                            // the import's sRGB decoding give 0.029 - 0.036
  }
  EXPECT_EQ(tests, 4);

  // The report says which encoding won.
  std::ifstream md(dir_ / "out" / "photo_set" / "report" / "summary.md");
  std::ostringstream mss;
  mss << md.rdbuf();
  EXPECT_NE(mss.str().find("the fit chose the encoding **gamma 2."), std::string::npos)
      << mss.str();
  std::ifstream html(dir_ / "out" / "photo_set" / "report" / "index.html");
  std::ostringstream hss;
  hss << html.rdbuf();
  EXPECT_NE(hss.str().find("the fit chose the encoding <b>gamma 2."), std::string::npos);
  // The template's free exposure turns on the data floor (docs/measured_and_imported.md, "Data
  // floor"): its sentence, in the decoding the fit chose, is under the answers of both pages.
  // Each model's free-exposure pin is said in words on both pages.
  EXPECT_NE(mss.str().find("## Free exposure"), std::string::npos);
  EXPECT_NE(mss.str().find("- blinn-phong: the exposure: the radiance is linear in ka, kd, ks"),
            std::string::npos);
  EXPECT_NE(mss.str().find("- ggx: f0.g = 0.04 (a dielectric's"), std::string::npos);
  EXPECT_NE(hss.str().find("<li>ggx: f0.g = 0.04"), std::string::npos);
  for (const std::string& page : {mss.str(), hss.str()}) {
    EXPECT_NE(page.find("Data floor"), std::string::npos);
    EXPECT_NE(page.find("in the decoding ggx chose (gamma 2."), std::string::npos);
  }
  EXPECT_TRUE(fs::exists(dir_ / "out" / "photo_set" / "report" / "floor.json"));
}

// The same search on a set stored as sRGB (two lights, the true scenes, `shadefit fit`): sRGB
// must win over the fitted power, which can only approximate its linear toe.
TEST_F(PhotoWorkflow, SrgbPairChoosesSrgb) {
  const std::vector<Light> lights = {Lights()[1], Lights()[4]};
  SpherePhotos(/*srgb=*/true, lights);
  std::string refs;
  for (const Light& l : lights) {
    WriteText(dir_ / "scenes" / ("sphere-" + l.name + ".toml"),
              std::string(kCamera) +
                  "\n[[objects]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n\n" +
                  LightToml(l, 1.0) + "\n[background]\ntransparent = true\n");
    ASSERT_EQ(Shadefit("refs import photos/sphere-" + l.name + ".png --scene scenes/sphere-" +
                       l.name + ".toml --mask mask.png -o refs/sphere-" + l.name + ".exr"),
              0)
        << err_;
    refs += " --ref refs/sphere-" + l.name + ".exr";
  }
  ASSERT_EQ(Shadefit("fit" + refs +
                     " --model ggx --exposure free --encoding fit --fix f0=0.04 "
                     "--no-images -o fit.json"),
            0)
      << err_;
  const json fit = ReadJson(dir_ / "fit.json");
  EXPECT_EQ(fit["encoding"]["chosen"], "srgb") << fit["encoding"].dump(1);
  for (const json& c : fit["encoding"]["candidates"]) {
    std::printf("sRGB set: %s stored-value RMSE x255 %.3f\n", c["name"].get<std::string>().c_str(),
                255 * c["stored_rmse"].get<double>());
  }
  EXPECT_NEAR(fit["exposure"]["value"].get<double>(), kIrradiance, 0.03 * kIrradiance);
}

}  // namespace
