// Successful runs of the real executable (build/studies/shadefit), each checked on the content of
// what it wrote: `render` against the analytic Lambert sphere, `metrics --json` against the
// pixel statistics recomputed here from the two images, `fit` recovering the rendered kd;
// `refs measured` of a constant MERL table written here byte by byte against the analytic
// Lambert sphere; `refs import` of a PNG written here byte by byte against the IEC 61966-2-1
// decode and the documented clipping rule; `probe fresnel` against Y(f0) and Schlick's closed
// form at a constant theta_d; `fit` of the environment-lit Cycles reference red-plastic-env
// against its sidecar's material; `--version` against the checkout's git revision.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

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
                          (dir / "stdout.txt").string() + "' 2> '" + (dir / "stderr.txt").string() +
                          "'";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// tests/data/sphere_key.toml written out: camera at (0, -6, 0) looking at the origin, +Z up,
// fov_y 22 deg, 64 x 64; unit sphere at the origin; point light of 1000 W at (4, -4, 3), i.e.
// intensity 1000 / (4 pi) W/sr (docs/scenes.md). Lambert radiance at the pixel centre's hit:
// kd / pi * max(n.l, 0) * I / d^2 (no shadow: one convex object). Returns -1 on a miss.
double LambertRadiance(int px, int py, double kd, double* discriminant = nullptr) {
  const double t = std::tan(11.0 * kPi / 180.0);
  const double sx = ((px + 0.5) / 64.0 * 2 - 1) * t, sy = (1 - (py + 0.5) / 64.0 * 2) * t;
  // forward +Y, right +X, up +Z
  double d[3] = {sx, 1.0, sy};
  const double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  for (double& c : d) c /= len;
  const double o[3] = {0, -6, 0};
  const double b = o[0] * d[0] + o[1] * d[1] + o[2] * d[2];
  const double disc = b * b - (36.0 - 1.0);
  if (discriminant) *discriminant = disc;
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
                         a + "'",
                     dir),
            0);
  ASSERT_EQ(Shadefit("render --scene '" + kScene +
                         "' --model ggx --set kd=0.6,0.5,0.4 "
                         "--set f0=0.04 --set roughness=0.3 -o '" +
                         b + "'",
                     dir),
            0);
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
                         ref + "'",
                     dir),
            0);
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

void PutLe32(std::vector<unsigned char>* out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<unsigned char>(v >> (8 * i)));
}
void PutBe32(std::vector<unsigned char>* out, std::uint32_t v) {
  for (int i = 3; i >= 0; --i) out->push_back(static_cast<unsigned char>(v >> (8 * i)));
}

void WriteBytes(const fs::path& p, const std::vector<unsigned char>& bytes) {
  std::ofstream out(p, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

// MERL .binary as published (Matusik et al. 2003; MERL's BRDFRead.cpp): three little-endian
// int32 dims 90 90 180 (theta_h, theta_d, phi_d), then three float64 blocks (R, G, B) of
// 90 * 90 * 180 cells, cell index phi_d + 180 * (theta_d + 90 * theta_h). Every cell of channel k
// holds value[k].
void WriteConstantMerl(const fs::path& p, const double value[3]) {
  constexpr std::uint32_t kCells = 90u * 90u * 180u;
  std::vector<unsigned char> bytes;
  bytes.reserve(12 + 3 * 8 * std::size_t{kCells});
  PutLe32(&bytes, 90);
  PutLe32(&bytes, 90);
  PutLe32(&bytes, 180);
  for (int k = 0; k < 3; ++k) {
    std::uint64_t bits;
    std::memcpy(&bits, &value[k], 8);
    unsigned char le[8];
    for (int i = 0; i < 8; ++i) le[i] = static_cast<unsigned char>(bits >> (8 * i));
    for (std::uint32_t c = 0; c < kCells; ++c) bytes.insert(bytes.end(), le, le + 8);
  }
  ASSERT_EQ(bytes.size(), 34992012u);  // the published file size
  WriteBytes(p, bytes);
}

TEST(CliHappyPath, RefsMeasuredConstantMerlMatchesAnalyticLambert) {
  const fs::path dir = OutputDir("refs_measured");
  const fs::path brdf = dir / "constant.binary", out = dir / "measured.exr";
  // Distinct per channel so that a swapped channel or a wrong scale shows.
  const double cell[3] = {150.0, 100.0, 50.0};
  WriteConstantMerl(brdf, cell);
  // MERL's scales (BRDFRead.cpp: RED_SCALE 1/1500, GREEN 1.15/1500, BLUE 1.66/1500): the BRDF is
  // Lambertian with f_k = cell_k * scale_k in 1/sr.
  const double f[3] = {cell[0] / 1500.0, cell[1] * 1.15 / 1500.0, cell[2] * 1.66 / 1500.0};
  ASSERT_EQ(Shadefit("refs measured --brdf '" + brdf.string() + "' --scene '" + kScene +
                         "' --threads 2 -o '" + out.string() + "'",
                     dir),
            0)
      << ReadText(dir / "stderr.txt");
  const shadefit::Image img = shadefit::ReadImage(out.string());
  ASSERT_EQ(img.width, 64);
  ASSERT_EQ(img.height, 64);
  ASSERT_EQ(img.channels, 4);
  int lit = 0, checked = 0;
  for (int y = 1; y < 64; y += 3) {
    for (int x = 1; x < 64; x += 3) {
      double disc = 0;
      // f * cos(theta) * I / d^2 = LambertRadiance with kd = pi * f.
      const double unit = LambertRadiance(x, y, kPi, &disc);
      if (std::abs(disc) < 1e-2) continue;  // within a hair of the silhouette
      if (unit < 0) {
        EXPECT_EQ(img.at(x, y, 3), 0.0f) << x << ", " << y;
        for (int c = 0; c < 3; ++c) EXPECT_EQ(img.at(x, y, c), 0.0f) << x << ", " << y;
        continue;
      }
      EXPECT_EQ(img.at(x, y, 3), 1.0f) << x << ", " << y;
      for (int c = 0; c < 3; ++c) {
        const double expected = f[c] * unit;
        EXPECT_NEAR(img.at(x, y, c), expected, 2e-4 * expected + 1e-7)
            << "pixel " << x << ", " << y << " channel " << c;
      }
      ++checked;
      lit += unit > 0.05;
    }
  }
  EXPECT_GT(checked, 100);
  EXPECT_GT(lit, 50);
  // The centre pixel: the normal is (almost) -Y, facing the camera.
  for (int c = 0; c < 3; ++c) {
    const double centre = f[c] * LambertRadiance(32, 32, kPi);
    ASSERT_GT(centre, 0.01);
    EXPECT_NEAR(img.at(32, 32, c), centre, 1e-4 * centre) << "channel " << c;
  }
  const json side = json::parse(ReadText(dir / "measured.json"));
  EXPECT_EQ(side["kind"], "measured-brdf");
  EXPECT_EQ(side["brdf"]["format"], "merl-binary");
  ASSERT_EQ(side["brdf"]["files"].size(), 1u);
  EXPECT_EQ(side["brdf"]["files"][0]["path"].get<std::string>(), brdf.lexically_normal().string());
  EXPECT_EQ(side["brdf"]["files"][0]["sha256"].get<std::string>().size(), 64u);
  EXPECT_EQ(side["scene_file"].get<std::string>(), fs::path(kScene).lexically_normal().string());
  EXPECT_EQ(side["scene_toml"].get<std::string>(), ReadText(kScene));
  EXPECT_EQ(side["resolution"], json::array({64, 64}));
}

// A PNG written byte by byte (PNG spec, ISO/IEC 15948): 8-bit RGB, no gAMA/sRGB chunks, one
// zlib stream of stored (uncompressed) deflate blocks, so no encoder of the project is involved.
std::uint32_t Crc32(const unsigned char* p, std::size_t n) {
  std::uint32_t c = 0xffffffffu;
  for (std::size_t i = 0; i < n; ++i) {
    c ^= p[i];
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xedb88320u ^ (c >> 1) : c >> 1;
  }
  return c ^ 0xffffffffu;
}

void PutChunk(std::vector<unsigned char>* png, const char type[5],
              const std::vector<unsigned char>& data) {
  PutBe32(png, static_cast<std::uint32_t>(data.size()));
  std::vector<unsigned char> body(type, type + 4);
  body.insert(body.end(), data.begin(), data.end());
  png->insert(png->end(), body.begin(), body.end());
  PutBe32(png, Crc32(body.data(), body.size()));
}

void WritePngRgb8(const fs::path& p, int w, int h, const std::vector<unsigned char>& rgb) {
  std::vector<unsigned char> raw;  // filter byte 0 (None) per row
  for (int y = 0; y < h; ++y) {
    raw.push_back(0);
    raw.insert(raw.end(), rgb.begin() + y * w * 3, rgb.begin() + (y + 1) * w * 3);
  }
  std::vector<unsigned char> z = {0x78, 0x01};
  for (std::size_t off = 0; off < raw.size() || off == 0; off += 65535) {
    const std::size_t len = std::min<std::size_t>(65535, raw.size() - off);
    z.push_back(off + len == raw.size() ? 1 : 0);  // BFINAL, BTYPE 00
    z.push_back(static_cast<unsigned char>(len));
    z.push_back(static_cast<unsigned char>(len >> 8));
    z.push_back(static_cast<unsigned char>(~len));
    z.push_back(static_cast<unsigned char>(~len >> 8));
    z.insert(z.end(), raw.begin() + off, raw.begin() + off + len);
  }
  std::uint32_t a = 1, b = 0;  // Adler-32
  for (unsigned char c : raw) {
    a = (a + c) % 65521;
    b = (b + a) % 65521;
  }
  PutBe32(&z, (b << 16) | a);
  std::vector<unsigned char> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  std::vector<unsigned char> ihdr;
  PutBe32(&ihdr, w);
  PutBe32(&ihdr, h);
  ihdr.insert(ihdr.end(), {8, 2, 0, 0, 0});  // 8 bit, truecolour, deflate, filter 0, no interlace
  PutChunk(&png, "IHDR", ihdr);
  PutChunk(&png, "IDAT", z);
  PutChunk(&png, "IEND", {});
  WriteBytes(p, png);
}

// IEC 61966-2-1 sRGB decode of an 8-bit code.
double SrgbDecode(int code) {
  const double v = code / 255.0;
  return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

TEST(CliHappyPath, RefsImportPngDecodesSrgbAndMasksClipped) {
  const fs::path dir = OutputDir("refs_import");
  const fs::path png = dir / "photo.png", out = dir / "imported.exr";
  // Codes that sweep 0..255 in every channel, so the linear segment, the power segment, 253
  // (kept) and 254, 255 (clipped at the default threshold 254) all occur, on and off the sphere.
  auto code = [](int x, int y, int c) {
    return c == 0   ? (7 * x + 3 * y) % 256
           : c == 1 ? (5 * x + 11 * y + 40) % 256
                    : (x * y + 2 * x + 17) % 256;
  };
  std::vector<unsigned char> rgb(64 * 64 * 3);
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) {
      for (int c = 0; c < 3; ++c)
        rgb[(y * 64 + x) * 3 + c] = static_cast<unsigned char>(code(x, y, c));
    }
  }
  WritePngRgb8(png, 64, 64, rgb);
  ASSERT_EQ(Shadefit("refs import '" + png.string() + "' --scene '" + kScene + "' -o '" +
                         out.string() + "'",
                     dir),
            0)
      << ReadText(dir / "stderr.txt");
  const shadefit::Image img = shadefit::ReadImage(out.string());
  ASSERT_EQ(img.width, 64);
  ASSERT_EQ(img.height, 64);
  ASSERT_EQ(img.channels, 4);
  long clipped = 0, covered = 0, valid_covered = 0, ambiguous = 0, checked_linear = 0;
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) {
      bool clip = false;
      for (int c = 0; c < 3; ++c) clip = clip || code(x, y, c) >= 254;
      double disc = 0;
      LambertRadiance(x, y, 1.0, &disc);
      const bool hit = disc > 0, sure = std::abs(disc) > 1e-2;
      ambiguous += !sure;
      covered += hit;
      clipped += clip;
      valid_covered += hit && !clip;
      if (clip) {  // documented: RGB 0 and alpha 0 where invalid
        for (int c = 0; c < 4; ++c) EXPECT_EQ(img.at(x, y, c), 0.0f) << x << ", " << y << " " << c;
        continue;
      }
      for (int c = 0; c < 3; ++c) {
        const double expected = SrgbDecode(code(x, y, c));
        EXPECT_NEAR(img.at(x, y, c), expected, 2e-6 * expected + 1e-7)
            << "pixel " << x << ", " << y << " channel " << c << " code " << code(x, y, c);
        ++checked_linear;
      }
      if (sure) {
        EXPECT_EQ(img.at(x, y, 3), hit ? 1.0f : 0.0f) << x << ", " << y;
      }
    }
  }
  ASSERT_GT(clipped, 50);
  ASSERT_GT(checked_linear, 3 * 3000);
  const json side = json::parse(ReadText(dir / "imported.json"));
  EXPECT_EQ(side["kind"], "imported");
  EXPECT_EQ(side["encoding"], "srgb");  // auto: sRGB for an 8-bit file
  EXPECT_EQ(side["source"]["path"].get<std::string>(), png.lexically_normal().string());
  EXPECT_EQ(side["scene_file"].get<std::string>(), fs::path(kScene).lexically_normal().string());
  EXPECT_EQ(side["exposure"], "unknown");
  const json& n = side["counts"];
  EXPECT_EQ(n["total"].get<long>(), 64 * 64);
  EXPECT_EQ(n["masked_out"].get<long>(), 0);
  EXPECT_EQ(n["clipped"].get<long>(), clipped);
  EXPECT_EQ(n["valid"].get<long>(), 64 * 64 - clipped);
  EXPECT_NEAR(n["covered"].get<long>(), covered, ambiguous);
  EXPECT_NEAR(n["valid_covered"].get<long>(), valid_covered, ambiguous);
}

// An orthographic view of the unit sphere from -Y under one directional light that makes the
// angle 2 theta_d with the view in the x-y plane: l, v and hence h are the same at every pixel,
// so theta_d = acos(l.h) is constant over the image.
std::string ConstantThetaDScene(double theta_d_deg) {
  const double a = 2 * theta_d_deg * kPi / 180.0;  // towards the light: (sin a, -cos a, 0)
  std::ostringstream s;
  s.precision(17);
  s << "[camera]\ntype = \"orthographic\"\nposition = [0.0, -6.0, 0.0]\n"
    << "look_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nheight = 2.4\nresolution = [96, 96]\n\n"
    << "[[objects]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n\n"
    << "[[lights]]\ntype = \"directional\"\ndirection = [" << -std::sin(a) << ", " << std::cos(a)
    << ", 0.0]\nirradiance = 3.0\n";
  return s.str();
}

TEST(CliHappyPath, ProbeFresnelGivesSchlickAtConstantThetaD) {
  const fs::path dir = OutputDir("probe_fresnel");
  const std::string model =
      "--model ggx --set kd=0.3,0.2,0.1 --set f0=0.9,0.6,0.3 --set roughness=0.3";
  std::string refs;
  for (const auto& [name, theta_d] :
       {std::pair<std::string, double>{"camera", 0.0}, {"rim", 75.0}}) {
    const fs::path scene = dir / (name + ".toml"), ref = dir / ("ggx-" + name + ".exr");
    std::ofstream(scene) << ConstantThetaDScene(theta_d);
    ASSERT_EQ(
        Shadefit("render --scene '" + scene.string() + "' " + model + " -o '" + ref.string() + "'",
                 dir),
        0)
        << ReadText(dir / "stderr.txt");
    std::ofstream(dir / ("ggx-" + name + ".json")) << json{{"scene_file", scene.string()}}.dump();
    refs += " --ref '" + ref.string() + "'";
  }
  ASSERT_EQ(
      Shadefit("probe fresnel" + refs + " " + model + " -o '" + (dir / "out").string() + "'", dir),
      0)
      << ReadText(dir / "stderr.txt");
  const json j = json::parse(ReadText(dir / "out" / "fresnel.json"));
  // Effective Fresnel = sum(specular luminance) / sum(unit-Fresnel lobe) (docs/probes.md); with
  // Schlick's F = f0 + (1 - f0)(1 - cos theta_d)^5 and the BT.709 weights summing to 1,
  // Y(F) = Y(f0) + (1 - Y(f0))(1 - cos theta_d)^5.
  const double y0 = 0.2126 * 0.9 + 0.7152 * 0.6 + 0.0722 * 0.3;
  const double y75 = y0 + (1 - y0) * std::pow(1 - std::cos(75.0 * kPi / 180.0), 5);
  const json& g = j["numbers"]["ggx"];
  ASSERT_TRUE(g["F_centre"].is_number()) << g.dump();
  ASSERT_TRUE(g["F_rim"].is_number()) << g.dump();
  EXPECT_NEAR(g["F_centre"].get<double>(), y0, 1e-4 * y0);
  EXPECT_NEAR(g["F_rim"].get<double>(), y75, 1e-4 * y75);
  EXPECT_NEAR(g["rim_to_centre"].get<double>(), y75 / y0, 2e-4 * y75 / y0);
  json curve;
  for (const json& c : j["curves"]) {
    if (c["series"] == "ggx" && c["kind"] == "F vs theta_d") curve = c;
  }
  ASSERT_EQ(curve["x"].size(), 2u) << curve.dump();
  EXPECT_NEAR(curve["x"][0].get<double>(), 0.0, 1e-3);
  EXPECT_NEAR(curve["x"][1].get<double>(), 75.0, 1e-3);
  EXPECT_TRUE(fs::exists(dir / "out" / "fresnel.png"));
}

TEST(CliHappyPath, FitEnvironmentLitCyclesReferenceRecoversRoughness) {
  const fs::path dir = OutputDir("fit_env");
  const std::string ref =
      std::string(SHADEFIT_SOURCE_DIR) + "/reference_images/cycles/red-plastic-env.exr";
  const std::string out = (dir / "fit.json").string();
  ASSERT_EQ(Shadefit("fit --ref '" + ref +
                         "' --model cycles-principled --fix specular=0.5 "
                         "--no-images -o '" +
                         out + "'",
                     dir),
            0)
      << ReadText(dir / "stderr.txt");
  const json j = json::parse(ReadText(out));
  const json truth =
      json::parse(ReadText(std::string(SHADEFIT_SOURCE_DIR) +
                           "/reference_images/cycles/red-plastic-env.json"))["material"];
  ASSERT_EQ(truth["roughness"].get<double>(), 0.3);
  EXPECT_EQ(j["derivative_path"], "gbuffer");
  const double roughness = j["values"]["roughness"].get<double>();
  EXPECT_NEAR(roughness, 0.3, 0.02 * 0.3) << j["values"].dump();
  EXPECT_EQ(j["values"]["specular"].get<double>(), 0.5);  // fixed
  for (int c = 0; c < 3; ++c) {
    const double b = truth["base_color"][c].get<double>();
    EXPECT_NEAR(j["values"]["base_color"][c].get<double>(), b, 0.05 * b) << "base_color " << c;
  }
  EXPECT_LT(j["values"]["metallic"].get<double>(), 0.02);
}

// `--version` names the revision the binary was built from: cmake/ShadefitVersion.cmake writes it
// on every build, not when CMake configured (a build after a commit used to record the revision
// before it). Expected: <project version>+<git rev-parse --short=12 HEAD>, with ".dirty" exactly
// when `git status` lists a changed tracked file. Run after building from the tree it tests.
TEST(CliHappyPath, VersionNamesTheRevisionItWasBuiltFrom) {
  const fs::path dir = OutputDir("version");
  const std::string git = std::string("git -C '") + SHADEFIT_SOURCE_DIR + "' ";
  if (std::system((git + "rev-parse --git-dir > /dev/null 2>&1").c_str()) != 0) {
    GTEST_SKIP() << SHADEFIT_SOURCE_DIR << " is not a git checkout: the version says +unknown";
  }
  ASSERT_EQ(std::system((git + "rev-parse --short=12 HEAD > '" + (dir / "head.txt").string() +
                         "'").c_str()), 0);
  ASSERT_EQ(std::system((git + "status --porcelain --untracked-files=no > '" +
                         (dir / "status.txt").string() + "'").c_str()), 0);
  std::string head = ReadText(dir / "head.txt");
  head.erase(head.find_last_not_of("\n") + 1);
  ASSERT_EQ(head.size(), 12u) << head;
  const bool dirty = !ReadText(dir / "status.txt").empty();
  ASSERT_EQ(Shadefit("--version", dir), 0) << ReadText(dir / "stderr.txt");
  std::string version = ReadText(dir / "stdout.txt");
  version.erase(version.find_last_not_of("\n") + 1);
  const std::string want = "+" + head + (dirty ? ".dirty" : "");
  ASSERT_GE(version.size(), want.size()) << version;
  EXPECT_EQ(version.substr(version.size() - want.size()), want) << version;
  EXPECT_EQ(version.substr(0, version.find('+')).find_first_not_of("0123456789."),
            std::string::npos) << version;
}

}  // namespace
