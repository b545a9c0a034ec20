// Lights from a published data set (issue 33, item 3; docs/measured_and_imported.md,
// "Photographs"): `shadefit refs lights --directions FILE [--intensities FILE] [--names FILE]
// --axes ...` on the real executable. The truths are world directions and RGB intensities this
// test chooses; it writes them into the data set's convention by hand (y down the picture, z into
// the scene, vectors of any length), and reads them back from the written scenes with toml++, not
// with shadefit's scene parser.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <toml++/toml.h>
#include <vector>

#include "shadefit/render/image.h"

namespace {
namespace fs = std::filesystem;

constexpr double kPi = 3.14159265358979323846;

struct V3 {
  double x, y, z;
};
V3 Normalized(V3 v) {
  const double n = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
  return {v.x / n, v.y / n, v.z / n};
}
double AngleDeg(V3 a, V3 b) {
  a = Normalized(a);
  b = Normalized(b);
  const double d = a.x * b.x + a.y * b.y + a.z * b.z;
  return std::acos(std::max(-1.0, std::min(1.0, d))) * 180.0 / kPi;
}

// The camera of the set: orthographic on -Y looking at +Y, +Z up (as in photo_workflow_test).
// In the camera frame (x right, y up, z towards the viewer) world X is x, world Z is y and world
// -Y is z; the data set's frame has y down the picture and z into the scene, so a world
// direction (X, Y, Z) is written (X, -Z, Y) in the data set's file.
const char* kTemplate =
    "[camera]\ntype = \"orthographic\"\nposition = [0.0, -10.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\n"
    "up = [0.0, 0.0, 1.0]\nheight = 2.4\nresolution = [96, 64]\n\n[[objects]]\ntype = "
    "\"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n";
V3 WorldToDataSet(V3 w) { return {w.x, -w.z, w.y}; }

struct Truth {
  std::string file_name;  // As a data set's filenames.txt lists it.
  V3 to_light;            // World, unit.
  double rgb[3];
};

// Twelve lights on two cones around the view axis (-Y), 20 and 55 degrees off it, with
// intensities that differ per light and per channel, as a data set's do.
std::vector<Truth> Truths() {
  std::vector<Truth> out;
  for (int i = 0; i < 12; ++i) {
    const double theta = (i % 2 == 0 ? 20.0 : 55.0) * kPi / 180.0, phi = 30.0 * i * kPi / 180.0;
    char name[16];
    std::snprintf(name, sizeof name, "%03d.png", i + 1);
    out.push_back({name,
                   {std::sin(theta) * std::cos(phi), -std::cos(theta), std::sin(theta) * std::sin(phi)},
                   {0.8 + 0.03 * i, 0.9 - 0.02 * i, 1.1 + 0.01 * (i % 5)}});
  }
  return out;
}

void WriteText(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out << text;
}

class PublishedLights : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(SHADEFIT_TEST_OUTPUT) / "published_lights" / info->name();
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "data");
    WriteText(dir_ / "sphere.toml", kTemplate);
  }

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

  // The data set's files: directions (each scaled by a different length: the file need not hold
  // unit vectors), intensities, file names; or one 6-column file.
  void WriteDataSet(const std::vector<Truth>& truths, bool six_columns) {
    std::ostringstream d, i, n;
    d.precision(17);
    i.precision(17);
    d << "# light directions, x right, y down, z into the scene\n";
    for (std::size_t k = 0; k < truths.size(); ++k) {
      const Truth& t = truths[k];
      const V3 f = WorldToDataSet(t.to_light);
      const double len = 0.5 + 0.25 * static_cast<double>(k);
      d << f.x * len << " " << f.y * len << " " << f.z * len;
      if (six_columns) d << " " << t.rgb[0] << " " << t.rgb[1] << " " << t.rgb[2];
      d << "\n";
      i << t.rgb[0] << "\t" << t.rgb[1] << "\t" << t.rgb[2] << "\n";
      n << t.file_name << "\n";
    }
    WriteText(dir_ / "data" / "light_directions.txt", d.str());
    if (!six_columns) WriteText(dir_ / "data" / "light_intensities.txt", i.str());
    WriteText(dir_ / "data" / "filenames.txt", n.str());
  }

  // Reads every scene back with toml++ and checks its one light against the truth.
  void ExpectScenes(const fs::path& folder, const std::vector<Truth>& truths, double irradiance) {
    for (const Truth& t : truths) {
      const fs::path scene = folder / ("sphere-" + fs::path(t.file_name).stem().string() + ".toml");
      ASSERT_TRUE(fs::exists(scene)) << scene;
      const toml::table root = toml::parse_file(scene.string());
      const toml::array* lights = root["lights"].as_array();
      ASSERT_NE(lights, nullptr) << scene;
      ASSERT_EQ(lights->size(), 1u) << scene;
      const toml::table& l = *(*lights)[0].as_table();
      EXPECT_EQ(l["type"].value_or(std::string()), "directional");
      const toml::array& d = *l["direction"].as_array();
      // `direction` is where the light travels: minus the direction towards it.
      const V3 travels{d[0].value_or(0.0), d[1].value_or(0.0), d[2].value_or(0.0)};
      const V3 to_light{-travels.x, -travels.y, -travels.z};
      EXPECT_LT(AngleDeg(to_light, t.to_light), 1e-5) << scene;
      const toml::array* e = l["irradiance"].as_array();
      ASSERT_NE(e, nullptr) << scene << ": a coloured light writes [r, g, b]";
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR((*e)[c].value_or(0.0), irradiance * t.rgb[c], 1e-7) << scene << " channel " << c;
      }
      // The template is kept as it was.
      EXPECT_EQ(root["camera"]["resolution"][0].value_or(0), 96) << scene;
      EXPECT_EQ(root["objects"][0]["radius"].value_or(0.0), 1.0) << scene;
    }
    std::ifstream in(folder / "sphere-lights.json");
    const nlohmann::json summary = nlohmann::json::parse(in);
    EXPECT_EQ(summary["lights"].size(), truths.size());
    EXPECT_EQ(summary["axes"], "x,-y,-z");
  }

  fs::path dir_;
  std::string err_;
};

// Directions, intensities and names from three files, written into an output folder that does
// not exist yet (two levels of it): every light and intensity comes back, scaled by --irradiance.
TEST_F(PublishedLights, DirectionsAndIntensitiesComeBackInTheScenes) {
  const std::vector<Truth> truths = Truths();
  WriteDataSet(truths, /*six_columns=*/false);
  ASSERT_FALSE(fs::exists(dir_ / "new"));
  ASSERT_EQ(Shadefit("refs lights --directions data/light_directions.txt --intensities "
                     "data/light_intensities.txt --names data/filenames.txt --axes x,-y,-z "
                     "--irradiance 2 --scene-template sphere.toml -o new/scenes/"),
            0)
      << err_;
  ExpectScenes(dir_ / "new" / "scenes", truths, 2.0);
}

// One 6-column file (x y z r g b) gives the same scenes; without --names the lightings are
// L0, L1, ... in file order.
TEST_F(PublishedLights, SixColumnFile) {
  std::vector<Truth> truths = Truths();
  WriteDataSet(truths, /*six_columns=*/true);
  ASSERT_EQ(Shadefit("refs lights --directions data/light_directions.txt --axes x,-y,-z "
                     "--scene-template sphere.toml -o scenes"),
            0)
      << err_;
  for (std::size_t k = 0; k < truths.size(); ++k) {
    std::ostringstream name;  // not "L" + ...: GCC 12's -Wrestrict false positive
    name << "L" << k;
    truths[k].file_name = name.str();
  }
  ExpectScenes(dir_ / "scenes", truths, 1.0);
}

// The axis mapping is applied, not assumed: a perspective camera seen from an oblique position.
// The data set's "towards the viewer" light (0, 0, -1 with z into the scene) must point from the
// object to the camera, and its "up the picture" light (0, -1, 0 with y down) along the camera's
// up, made orthogonal to the view: both computed here from the camera's position, look-at and
// up, not from shadefit's basis.
TEST_F(PublishedLights, ObliqueCameraViewAndUp) {
  WriteText(dir_ / "oblique.toml",
            "[camera]\ntype = \"perspective\"\nposition = [3.0, -4.0, 2.0]\nlook_at = [0.0, 0.5, "
            "0.0]\nup = [0.0, 0.0, 1.0]\nfov_y = 30.0\nresolution = [64, 48]\n\n[[objects]]\n"
            "type = \"sphere\"\ncenter = [0.0, 0.5, 0.0]\nradius = 1.0\n");
  WriteText(dir_ / "data" / "d.txt", "0 0 -1\n0 -3 0\n");
  WriteText(dir_ / "data" / "names.txt", "view\nup\n");
  ASSERT_EQ(Shadefit("refs lights --directions data/d.txt --names data/names.txt --axes x,-y,-z "
                     "--scene-template oblique.toml -o scenes"),
            0)
      << err_;
  const auto to_light = [&](const std::string& lighting) {
    const toml::table root = toml::parse_file((dir_ / "scenes" / ("oblique-" + lighting + ".toml")).string());
    const toml::array& d = *root["lights"][0]["direction"].as_array();
    return V3{-d[0].value_or(0.0), -d[1].value_or(0.0), -d[2].value_or(0.0)};
  };
  const V3 view = Normalized({3.0, -4.5, 2.0});  // position - look_at
  EXPECT_LT(AngleDeg(to_light("view"), view), 1e-5);
  // World up (0, 0, 1) less its component along the view.
  const V3 up = Normalized({-view.z * view.x, -view.z * view.y, 1.0 - view.z * view.z});
  EXPECT_LT(AngleDeg(to_light("up"), up), 1e-5);
}

// The mirror-ball path creates its output folder too (the docs' own `-o scenes/`): a 64 x 64
// dark ball with a clipped highlight, as in bad_input_test.
TEST_F(PublishedLights, MirrorBallCreatesTheOutputFolder) {
  shadefit::Image im(64, 64, 3, 40.0f / 255.0f);
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) {
      const bool on_ball = std::hypot(x + 0.5 - 32.0, y + 0.5 - 32.0) < 20.0;
      const bool on_spot = std::abs(x - 36) <= 1 && std::abs(y - 28) <= 1;
      for (int c = 0; c < 3; ++c) {
        if (on_ball) im.at(x, y, c) = on_spot ? 1.0f : 8.0f / 255.0f;
      }
    }
  }
  shadefit::WritePng8((dir_ / "data" / "ball-a.png").string(), im);
  WriteText(dir_ / "ball.toml",
            "[camera]\ntype = \"orthographic\"\nposition = [0.0, -10.0, 0.0]\n"
            "look_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nheight = 2.4\n"
            "resolution = [64, 64]\n\n[[objects]]\ntype = \"sphere\"\n"
            "center = [0.0, 0.0, 0.0]\nradius = 1.0\n");
  ASSERT_EQ(Shadefit("refs lights --ball data/ball-a.png --scene-template ball.toml -o scenes/"),
            0)
      << err_;
  EXPECT_TRUE(fs::exists(dir_ / "scenes" / "ball-a.toml"));
  EXPECT_TRUE(fs::exists(dir_ / "scenes" / "ball-lights.json"));
}

// Bad data-set files: one line naming the file (and line) and the field, non-zero exit, and no
// output folder left behind.
TEST_F(PublishedLights, BadFilesFailCleanly) {
  WriteDataSet(Truths(), /*six_columns=*/false);
  WriteText(dir_ / "data" / "short.txt", "1 1 1\n");
  WriteText(dir_ / "data" / "word.txt", "0 0 -1\n0 zero -1\n");
  WriteText(dir_ / "data" / "two.txt", "0 0 -1\n0 0\n");
  WriteText(dir_ / "data" / "one-name.txt", "001.png\n");
  const struct {
    std::string args, expected;
  } cases[] = {
      {"--directions data/light_directions.txt --intensities data/short.txt --axes x,-y,-z",
       "data/short.txt: intensities: 1 lights, data/light_directions.txt has 12"},
      {"--directions data/word.txt", "data/word.txt:2: directions: 'zero' is not a finite number"},
      {"--directions data/two.txt", "data/two.txt:2: directions: 2 numbers; every line has x y z"},
      {"--directions data/light_directions.txt --axes x,-y,-x",
       "axes: 'x,-y,-x' is not three signed axes"},
      // The data set's z points into the scene: read as the camera's z, every light is behind.
      {"--directions data/light_directions.txt --axes x,-y,z",
       "data/light_directions.txt: axes: with --axes x,-y,z every light points away from the "
       "camera"},
      {"--directions data/light_directions.txt --names data/one-name.txt --axes x,-y,-z",
       "data/one-name.txt: names: 1 names, data/light_directions.txt has 12 lights"},
  };
  for (const auto& c : cases) {
    EXPECT_NE(Shadefit("refs lights " + c.args + " --scene-template sphere.toml -o out/scenes"), 0)
        << c.args;
    EXPECT_NE(err_.find(c.expected), std::string::npos) << c.args << "\nstderr: " << err_;
    EXPECT_EQ(std::count(err_.begin(), err_.end(), '\n'), 1) << err_;
    EXPECT_FALSE(fs::exists(dir_ / "out" / "scenes")) << c.args;
  }
}

}  // namespace
