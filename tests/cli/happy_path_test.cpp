// Successful runs of the real executable (build/studies/shadefit), each checked on the content of
// what it wrote: `render` against the analytic Lambert sphere, `metrics --json` against the
// pixel statistics recomputed here from the two images, `fit` recovering the rendered kd.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "shadefit/render/image.h"

namespace {
namespace fs = std::filesystem;
using json = nlohmann::json;

constexpr double kPi = 3.14159265358979323846;
const std::string kScene = std::string(SHADEFIT_SOURCE_DIR) + "/tests/data/sphere_key.toml";

fs::path OutputDir(const std::string& name) {
  const fs::path dir = fs::path(SHADEFIT_TEST_OUTPUT) / "cli_happy" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string ReadText(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Runs `shadefit <args>`, stdout to <dir>/stdout.txt and stderr to <dir>/stderr.txt.
int Shadefit(const std::string& args, const fs::path& dir) {
  const std::string cmd = std::string("'") + SHADEFIT_EXE + "' " + args + " > '" +
                          (dir / "stdout.txt").string() + "' 2> '" +
                          (dir / "stderr.txt").string() + "'";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// tests/data/sphere_key.toml written out: camera at (0, -6, 0) looking at the origin, +Z up,
// fov_y 22 deg, 64 x 64; unit sphere at the origin; point light of 1000 W at (4, -4, 3), i.e.
// intensity 1000 / (4 pi) W/sr (docs/scenes.md). Lambert radiance at the pixel centre's hit:
// kd / pi * max(n.l, 0) * I / d^2 (no shadow: one convex object). Returns -1 on a miss.
double LambertRadiance(int px, int py, double kd) {
  const double t = std::tan(11.0 * kPi / 180.0);
  const double sx = ((px + 0.5) / 64.0 * 2 - 1) * t, sy = (1 - (py + 0.5) / 64.0 * 2) * t;
  // forward +Y, right +X, up +Z
  double d[3] = {sx, 1.0, sy};
  const double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  for (double& c : d) c /= len;
  const double o[3] = {0, -6, 0};
  const double b = o[0] * d[0] + o[1] * d[1] + o[2] * d[2];
  const double disc = b * b - (36.0 - 1.0);
  if (disc <= 0) return -1;
  const double s = -b - std::sqrt(disc);
  const double n[3] = {o[0] + s * d[0], o[1] + s * d[1], o[2] + s * d[2]};
  double l[3] = {4 - n[0], -4 - n[1], 3 - n[2]};
  const double d2 = l[0] * l[0] + l[1] * l[1] + l[2] * l[2];
  const double nol = (n[0] * l[0] + n[1] * l[1] + n[2] * l[2]) / std::sqrt(d2);
  return kd / kPi * std::max(nol, 0.0) * (1000.0 / (4 * kPi)) / d2;
}

TEST(CliHappyPath, RenderLambertMatchesAnalytic) {
  const fs::path dir = OutputDir("render");
  const fs::path out = dir / "lambert.exr";
  ASSERT_EQ(Shadefit("render --scene '" + kScene + "' --model lambert --set kd=0.5,0.4,0.3 -o '" +
                         out.string() + "'",
                     dir),
            0)
      << ReadText(dir / "stderr.txt");
  const shadefit::Image img = shadefit::ReadImage(out.string());
  ASSERT_EQ(img.width, 64);
  ASSERT_EQ(img.height, 64);
  int lit = 0;
  for (int y = 2; y < 64; y += 5) {
    for (int x = 2; x < 64; x += 5) {
      const double kds[3] = {0.5, 0.4, 0.3};
      const double expected = LambertRadiance(x, y, 1.0);
      if (expected < 0) {
        EXPECT_EQ(img.at(x, y, 3), 0.0f) << x << ", " << y;
        continue;
      }
      if (img.at(x, y, 3) < 1.0f) continue;  // silhouette: point-sampled, but skip edge pixels
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(img.at(x, y, c), kds[c] * expected, 1e-4 * kds[c] * expected + 1e-7)
            << "pixel " << x << ", " << y << " channel " << c;
      }
      lit += expected > 0.05;
    }
  }
  // The centre pixel, as the README states it (exact to 1e-4).
  const double centre = LambertRadiance(32, 32, 0.5);
  EXPECT_NEAR(img.at(32, 32, 0), centre, 1e-4 * centre);
  EXPECT_GT(lit, 30);
}

TEST(CliHappyPath, MetricsJsonMatchesRecomputedStatistics) {
  const fs::path dir = OutputDir("metrics");
  const std::string a = (dir / "a.exr").string(), b = (dir / "b.exr").string();
  ASSERT_EQ(Shadefit("render --scene '" + kScene + "' --model lambert --set kd=0.5,0.5,0.5 -o '" +
                         a + "'", dir), 0);
  ASSERT_EQ(Shadefit("render --scene '" + kScene + "' --model ggx --set kd=0.6,0.5,0.4 "
                         "--set f0=0.04 --set roughness=0.3 -o '" + b + "'", dir), 0);
  ASSERT_EQ(Shadefit("metrics '" + a + "' '" + b + "' --json", dir), 0)
      << ReadText(dir / "stderr.txt");
  const json j = json::parse(ReadText(dir / "stdout.txt"));
  // docs/metrics.md: means over every channel of every pixel (no mask); relative RMSE per
  // element with eps = 0.01; log RMSE on ln(1 + max(x, 0)).
  const shadefit::Image r = shadefit::ReadImage(a), t = shadefit::ReadImage(b);
  double sq = 0, abs_sum = 0, rel_sq = 0, log_sq = 0;
  long n = 0;
  for (std::size_t p = 0; p < r.PixelCount(); ++p) {
    for (int c = 0; c < 3; ++c) {
      const double rv = r.data[p * r.channels + c], tv = t.data[p * t.channels + c];
      sq += (tv - rv) * (tv - rv);
      abs_sum += std::abs(tv - rv);
      rel_sq += std::pow((tv - rv) / (std::abs(rv) + 0.01), 2);
      log_sq += std::pow(std::log(1 + std::max(tv, 0.0)) - std::log(1 + std::max(rv, 0.0)), 2);
      ++n;
    }
  }
  EXPECT_EQ(j["valid_pixels"].get<long>(), 64 * 64);
  const json& lin = j["linear"];
  const double rmse = std::sqrt(sq / n);
  ASSERT_GT(rmse, 1e-3);
  EXPECT_NEAR(lin["rmse"].get<double>(), rmse, 1e-9 * rmse);
  EXPECT_NEAR(lin["mae"].get<double>(), abs_sum / n, 1e-9 * abs_sum / n);
  EXPECT_NEAR(lin["relative_rmse"].get<double>(), std::sqrt(rel_sq / n), 1e-9);
  EXPECT_NEAR(lin["log_rmse"].get<double>(), std::sqrt(log_sq / n), 1e-9);
}

TEST(CliHappyPath, FitRecoversRenderedLambert) {
  const fs::path dir = OutputDir("fit");
  const std::string ref = (dir / "ref.exr").string();
  ASSERT_EQ(Shadefit("render --scene '" + kScene + "' --model lambert --set kd=0.7,0.4,0.2 -o '" +
                         ref + "'", dir), 0);
  std::ofstream(dir / "ref.json") << json{{"scene_file", kScene}}.dump();
  const std::string out = (dir / "fit.json").string();
  ASSERT_EQ(Shadefit("fit --ref '" + ref + "' --model lambert -o '" + out + "'", dir), 0)
      << ReadText(dir / "stderr.txt");
  const json j = json::parse(ReadText(out));
  EXPECT_TRUE(j["converged"].get<bool>());
  const double truth[3] = {0.7, 0.4, 0.2};
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(j["values"]["kd"][c].get<double>(), truth[c], 1e-4) << "kd channel " << c;
  }
  // The fitted image is the reference again (same renderer, same parameters).
  const shadefit::Image fit = shadefit::ReadImage((dir / "fit.ref.fit.exr").string());
  const shadefit::Image reference = shadefit::ReadImage(ref);
  ASSERT_EQ(fit.PixelCount(), reference.PixelCount());
  for (std::size_t p = 0; p < fit.PixelCount(); ++p) {
    for (int c = 0; c < 3; ++c) {
      ASSERT_NEAR(fit.data[p * fit.channels + c], reference.data[p * reference.channels + c],
                  1e-4 * reference.data[p * reference.channels + c] + 1e-7)
          << "pixel " << p;
    }
  }
}

}  // namespace
