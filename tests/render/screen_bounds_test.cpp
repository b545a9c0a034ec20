// The renderer shades only the pixels inside ObjectPixelBounds (scene.h) on a transparent
// background and reads back only those. These tests hold that to the full-screen ray cast:
// the bounds miss no pixel any sample hits, and the bounded frame equals the full one bit for
// bit, silhouette pixels included.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <string>
#include <vector>

#include "shadefit/render/gl_context.h"
#include "shadefit/render/models.h"
#include "shadefit/render/renderer.h"
#include "shadefit/render/scene.h"
#include "test_util.h"

namespace shadefit {
namespace {

std::string CameraToml(bool ortho, int w, int h, int supersample) {
  return std::string("[camera]\n") + (ortho ? "type = \"orthographic\"\nheight = 2.4\n" : "") +
         "position = [0.3, -6.0, 0.2]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\n"
         "fov_y = 22.0\nresolution = [" + std::to_string(w) + ", " + std::to_string(h) + "]\n"
         "supersample = " + std::to_string(supersample) + "\n";
}

std::string SphereToml(double x, double y, double z, double r) {
  return "[[objects]]\ntype = \"sphere\"\ncenter = [" + std::to_string(x) + ", " +
         std::to_string(y) + ", " + std::to_string(z) + "]\nradius = " + std::to_string(r) + "\n";
}

const char* kKeyLight =
    "[[lights]]\ntype = \"point\"\nposition = [4.0, -4.0, 3.0]\npower = 1000.0\n";

// Whether any of pixel (x, y)'s n x n samples hits an object, by the C++ ray cast (double).
bool AnySampleHits(const Scene& scene, int x, int y, int n) {
  const Camera& cam = scene.camera;
  for (int k = 0; k < n * n; ++k) {
    Hit h;
    if (Intersect(scene, CameraRay(cam, x + (k % n + 0.5) / n, y + (k / n + 0.5) / n), 0.0, 1e30,
                  &h)) {
      return true;
    }
  }
  return false;
}

// Pixels any of whose n x n samples hits an object.
struct HitBox {
  int x0, y0, x1, y1;
  bool empty() const { return x0 >= x1; }
};
HitBox HitPixels(const Scene& scene, int n) {
  const Camera& cam = scene.camera;
  HitBox b{cam.width, cam.height_px, 0, 0};
  for (int y = 0; y < cam.height_px; ++y) {
    for (int x = 0; x < cam.width; ++x) {
      if (!AnySampleHits(scene, x, y, n)) continue;
      b.x0 = std::min(b.x0, x), b.x1 = std::max(b.x1, x + 1);
      b.y0 = std::min(b.y0, y), b.y1 = std::max(b.y1, y + 1);
    }
  }
  return b;
}

// Spheres all over the frame, partly outside it, tiny and large, both cameras, 1 and 3 samples:
// every pixel a sample hits lies inside the bounds (conservative), and the bounds reach at most
// one pixel beyond the pixels the silhouette enters (tight; those found with 6 x 6 samples) when
// the frame does not cut the silhouette.
TEST(ObjectPixelBounds, ContainTheHitPixelsAndAtMostOnePixelMore) {
  int scenes = 0, with_hits = 0, touching = 0, tight = 0;
  for (const bool ortho : {false, true}) {
    for (const int ss : {1, 3}) {
      for (const double r : {0.02, 0.31, 1.13}) {
        for (double x = -1.9; x <= 1.9; x += 0.47) {
          for (double z = -1.4; z <= 1.4; z += 0.53) {
            const Scene scene = ParseScene(
                CameraToml(ortho, 41, 29, ss) + SphereToml(x, 0.7 * z, z, r) + kKeyLight,
                "bounds.toml");
            const PixelRect rect = ObjectPixelBounds(scene);
            const HitBox hits = HitPixels(scene, ss);
            const HitBox area = HitPixels(scene, 6);
            ++scenes;
            const std::string what = "sphere (" + std::to_string(x) + ", " + std::to_string(z) +
                                     ") r " + std::to_string(r) + (ortho ? " ortho" : "") +
                                     " ss " + std::to_string(ss);
            // Tight where the silhouette lies inside the frame; a sphere the frame cuts has
            // bounds of its whole projection, which may reach beyond the visible part's.
            const bool inside = area.x0 > 0 && area.y0 > 0 && area.x1 < 41 && area.y1 < 29;
            if (area.empty()) {
              // At most a sliver: a silhouette between samples, or one just beyond the edge.
              EXPECT_TRUE(rect.width() * rect.height() <= 4 || rect.width() <= 1 ||
                          rect.height() <= 1)
                  << what;
            } else if (inside) {
              ++tight;
              EXPECT_GE(rect.x0, area.x0 - 1) << what;
              EXPECT_GE(rect.y0, area.y0 - 1) << what;
              EXPECT_LE(rect.x1, area.x1 + 1) << what;
              EXPECT_LE(rect.y1, area.y1 + 1) << what;
            }
            if (hits.empty()) continue;
            ++with_hits;
            EXPECT_LE(rect.x0, hits.x0) << what;
            EXPECT_LE(rect.y0, hits.y0) << what;
            EXPECT_GE(rect.x1, hits.x1) << what;
            EXPECT_GE(rect.y1, hits.y1) << what;
            touching += rect.x0 == hits.x0 || rect.x1 == hits.x1;
          }
        }
      }
    }
  }
  EXPECT_GT(scenes, 600);
  EXPECT_GT(tight, 150);
  // Many bounds are met by a hit pixel on a side: shrinking them by one pixel would lose it.
  EXPECT_GT(touching, with_hits / 3);
  std::printf("[ bounds ] %d scenes, %d with hits, %d tight-checked, %d met on a side\n", scenes,
              with_hits, tight, touching);
}

// Whether the point lies inside the convex polygon (either orientation), strictly.
bool InsideConvex(const PixelPolygon& poly, double x, double y) {
  int positive = 0, negative = 0;
  for (std::size_t k = 0; k < poly.size(); ++k) {
    const PixelPoint& a = poly[k];
    const PixelPoint& b = poly[(k + 1) % poly.size()];
    const double side = (b.x - a.x) * (y - a.y) - (b.y - a.y) * (x - a.x);
    positive += side > 0;
    negative += side < 0;
  }
  return positive == static_cast<int>(poly.size()) || negative == static_cast<int>(poly.size());
}

// Pixels with a sample that hits (n x n samples), and pixels whose centre a polygon holds: the
// pixels GL rasterises.
struct PixelCounts {
  int hit = 0, shaded = 0, hit_not_shaded = 0;
};
PixelCounts CountPixels(const Scene& scene, const std::vector<PixelPolygon>& polygons, int n) {
  const Camera& cam = scene.camera;
  PixelCounts c;
  for (int y = 0; y < cam.height_px; ++y) {
    for (int x = 0; x < cam.width; ++x) {
      const bool hit = AnySampleHits(scene, x, y, n);
      bool shaded = false;
      for (const PixelPolygon& poly : polygons)
        shaded = shaded || InsideConvex(poly, x + 0.5, y + 0.5);
      c.hit += hit;
      c.shaded += shaded;
      c.hit_not_shaded += hit && !shaded;
    }
  }
  return c;
}

// The polygons a bounded frame rasterises hold every pixel a sample hits (spheres all over the
// frame as above, and tilted tiles), and shade little more than the silhouette: at most a ring
// of about two pixels beyond the pixels it enters (found with 6 x 6 samples).
TEST(ObjectPixelPolygons, HoldTheHitPixelsAndLittleMore) {
  int scenes = 0, with_hits = 0, large = 0;
  long shaded_large = 0, rect_large = 0;
  std::vector<std::string> objects;
  for (const double r : {0.02, 0.31, 1.13}) {
    for (double x = -1.9; x <= 1.9; x += 0.47) {
      for (double z = -1.4; z <= 1.4; z += 0.53) objects.push_back(SphereToml(x, 0.7 * z, z, r));
    }
  }
  for (int k = 0; k < 12; ++k) {
    const double a = 0.5 * k;
    objects.push_back("[[objects]]\ntype = \"plane\"\npoint = [" +
                      std::to_string(0.3 * std::cos(a)) + ", 0.4, " +
                      std::to_string(0.2 * k - 1.1) + "]\nnormal = [" +
                      std::to_string(std::sin(a)) + ", -1.0, " + std::to_string(std::cos(3 * a)) +
                      "]\nhalf_size = [" + std::to_string(0.2 + 0.1 * k) + ", 0.35]\n");
  }
  for (const bool ortho : {false, true}) {
    for (const int ss : {1, 3}) {
      for (const std::string& object : objects) {
        const Scene scene =
            ParseScene(CameraToml(ortho, 41, 29, ss) + object + kKeyLight, "polygons.toml");
        bool whole_frame = true;
        const std::vector<PixelPolygon> polygons = ObjectPixelPolygons(scene, &whole_frame);
        ASSERT_FALSE(whole_frame) << object;
        const PixelCounts at_samples = CountPixels(scene, polygons, ss);
        const PixelCounts area = CountPixels(scene, polygons, 6);
        ++scenes;
        with_hits += at_samples.hit > 0;
        EXPECT_EQ(at_samples.hit_not_shaded, 0)
            << object << (ortho ? " ortho" : "") << " ss " << ss;
        // A ring two pixels wide about the silhouette: its perimeter is about 2 sqrt(pi A).
        const double ring = 2.0 * 2.0 * std::sqrt(std::numbers::pi * area.hit) + 8.0;
        EXPECT_LE(area.shaded, area.hit + ring) << object << (ortho ? " ortho" : "");
        if (area.hit > 150) {
          ++large;
          shaded_large += area.shaded;
          const PixelRect rect = ObjectPixelBounds(scene);
          rect_large += static_cast<long>(rect.width()) * rect.height();
        }
      }
    }
  }
  EXPECT_GT(scenes, 600);
  EXPECT_GT(with_hits, 300);
  EXPECT_GT(large, 40);
  // Large silhouettes (mostly discs) shade well under the rectangle's pixels (pi / 4 for a disc
  // whose rectangle the frame does not cut).
  EXPECT_LT(static_cast<double>(shaded_large), 0.9 * static_cast<double>(rect_large));
  std::printf("[ polygons ] %d scenes, %d with hits, %d large: %ld shaded of %ld in rectangles\n",
              scenes, with_hits, large, shaded_large, rect_large);
}

TEST(ObjectPixelBounds, WholeFrameOrNothingWhenTheyCannotBeBounded) {
  const std::string cam = CameraToml(false, 32, 24, 1);
  // The camera inside a sphere, an unbounded plane: every pixel.
  for (const std::string& objects :
       {SphereToml(0.3, -6.0, 0.2, 2.0),
        std::string("[[objects]]\ntype = \"plane\"\npoint = [0.0, 0.0, -1.0]\n"
                    "normal = [0.0, 0.0, 1.0]\n")}) {
    const PixelRect r = ObjectPixelBounds(ParseScene(cam + objects + kKeyLight, "whole.toml"));
    EXPECT_EQ(r.x0, 0);
    EXPECT_EQ(r.y0, 0);
    EXPECT_EQ(r.x1, 32);
    EXPECT_EQ(r.y1, 24);
  }
  // A sphere behind the camera: no pixel.
  const PixelRect r =
      ObjectPixelBounds(ParseScene(cam + SphereToml(0.0, -9.0, 0.0, 1.0) + kKeyLight, "b.toml"));
  EXPECT_TRUE(r.empty());
}

Renderer& FullScreenRenderer() {
  static Renderer* renderer = [] {
    RendererOptions options;
    options.bound_objects = false;
    return new Renderer(*new GlContext(), options);
  }();
  return *renderer;
}

// The bounded frame against the full-screen ray cast, every pixel, bit for bit.
TEST(BoundedRender, EqualsTheFullScreenRayCastBitForBit) {
  struct Case {
    std::string name, toml;
  };
  const std::string plane =
      "[[objects]]\ntype = \"plane\"\npoint = [0.0, 0.6, -1.0]\nnormal = [0.0, 0.0, 1.0]\n"
      "half_size = [0.9, 0.7]\n";
  std::vector<Case> cases = {
      {"key", CameraToml(false, 96, 72, 1) + SphereToml(0, 0, 0, 1) + kKeyLight},
      {"key ss4", CameraToml(false, 96, 72, 4) + SphereToml(0, 0, 0, 1) + kKeyLight},
      {"off-centre ss3",
       CameraToml(false, 80, 64, 3) + SphereToml(1.2, 0.5, -0.8, 0.45) + kKeyLight},
      {"partly outside", CameraToml(false, 64, 64, 2) + SphereToml(-1.6, 0, 1.1, 0.6) + kKeyLight},
      {"two spheres", CameraToml(false, 72, 56, 2) + SphereToml(-0.5, 0, 0, 0.5) +
                          SphereToml(0.7, -0.8, 0.3, 0.3) + kKeyLight},
      {"sphere and tile",
       CameraToml(false, 72, 56, 2) + SphereToml(0, 0, 0, 0.5) + plane + kKeyLight},
      {"ortho ss4", CameraToml(true, 60, 44, 4) + SphereToml(0.2, 0, 0.1, 0.8) + kKeyLight},
      {"uniform light", CameraToml(false, 48, 40, 2) + SphereToml(0, 0, 0, 1) +
                            "[[lights]]\ntype = \"uniform\"\nradiance = [0.8, 0.9, 1.0]\n"
                            "samples = 8\n"},
  };
  for (int k = 0; k < 8; ++k) {
    cases.push_back({"placement " + std::to_string(k),
                     CameraToml(false, 52, 44, 3 + k % 2) +
                         SphereToml(-0.9 + 0.37 * k, 0.1 * k, 0.23 * k - 0.7, 0.29 + 0.043 * k) +
                         kKeyLight});
  }
  for (const char* model_name : {"lambert", "ggx"}) {
    const ModelInfo& model = FindModel(model_name);
    const std::vector<double> params = DefaultParams(model);
    for (const Case& c : cases) {
      const Scene scene = ParseScene(c.toml, c.name + ".toml");
      const Image bounded = testing::SharedRenderer().Render(scene, model.id, params);
      // The same frame again skips the clear (renderer.cpp): still the same pixels. After a
      // full-frame draw (an opaque background writes every pixel), the next must clear again.
      const Image again = testing::SharedRenderer().Render(scene, model.id, params);
      Scene opaque = scene;
      opaque.background.transparent = false;
      opaque.background.color = {0.25, 0.5, 0.75};
      testing::SharedRenderer().Render(opaque, model.id, params);
      const Image after_opaque = testing::SharedRenderer().Render(scene, model.id, params);
      const Image full = FullScreenRenderer().Render(scene, model.id, params);
      ASSERT_EQ(bounded.data.size(), full.data.size());
      ASSERT_EQ(again.data.size(), full.data.size());
      ASSERT_EQ(after_opaque.data.size(), full.data.size());
      int differ = 0, differ_again = 0, differ_after_opaque = 0, covered = 0;
      for (std::size_t i = 0; i < full.data.size(); ++i) {
        differ += std::memcmp(&bounded.data[i], &full.data[i], sizeof(float)) != 0;
        differ_again += std::memcmp(&again.data[i], &full.data[i], sizeof(float)) != 0;
        differ_after_opaque +=
            std::memcmp(&after_opaque.data[i], &full.data[i], sizeof(float)) != 0;
        covered += i % 4 == 3 && full.data[i] > 0;
      }
      EXPECT_EQ(differ, 0) << model_name << ", " << c.name;
      EXPECT_EQ(differ_again, 0) << model_name << ", " << c.name << ", again";
      EXPECT_EQ(differ_after_opaque, 0)
          << model_name << ", " << c.name << ", after an opaque frame";
      EXPECT_GT(covered, 20) << c.name;
    }
  }
}

}  // namespace
}  // namespace shadefit
