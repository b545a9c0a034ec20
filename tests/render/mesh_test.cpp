// Surface objects (meshes, normal maps) and their shadows: the GL raster against independent
// answers (the analytic sphere, CPU ray casting, hand-computed normals and shadow regions).
#include <gtest/gtest.h>
#include <matio.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "shadefit/base/error.h"
#include "shadefit/render/gbuffer.h"
#include "shadefit/render/pixel_surface.h"
#include "shadefit/render/ray_caster.h"
#include "shadefit/render/shadows.h"
#include "test_util.h"

namespace shadefit {
namespace {

namespace fs = std::filesystem;
constexpr double kPiD = 3.14159265358979323846;

std::string Dir() { return testing::TestOutputDir("mesh_test"); }

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

// A UV sphere OBJ (radius r at c), counter-clockwise from outside, with outward normals.
std::string SphereObj(const std::string& name, double r, Vec3d c, int rings, int segments,
                      bool normals = true) {
  std::ostringstream s;
  s.precision(10);
  for (int i = 0; i <= rings; ++i) {
    const double th = kPiD * i / rings;
    for (int j = 0; j < segments; ++j) {
      const double ph = 2 * kPiD * j / segments;
      const Vec3d n{std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)};
      s << "v " << c.x + r * n.x << " " << c.y + r * n.y << " " << c.z + r * n.z << "\n";
      if (normals) s << "vn " << n.x << " " << n.y << " " << n.z << "\n";
    }
  }
  auto id = [&](int i, int j) { return i * segments + (j % segments) + 1; };
  for (int i = 0; i < rings; ++i) {
    for (int j = 0; j < segments; ++j) {
      const int a = id(i, j), b = id(i + 1, j), cc = id(i + 1, j + 1), d = id(i, j + 1);
      // Counter-clockwise seen from outside: theta grows downward, phi grows eastward.
      if (normals) {
        s << "f " << a << "//" << a << " " << b << "//" << b << " " << cc << "//" << cc << "\n";
        s << "f " << a << "//" << a << " " << cc << "//" << cc << " " << d << "//" << d << "\n";
      } else {
        s << "f " << a << " " << b << " " << cc << "\nf " << a << " " << cc << " " << d << "\n";
      }
    }
  }
  const std::string path = Dir() + "/" + name;
  WriteText(path, s.str());
  return path;
}

// A square in the plane z = z0, half size h, facing +Z, with uvs (u along +X, v along +Y).
std::string QuadObj(const std::string& name, double h, double z0) {
  std::ostringstream s;
  s << "v " << -h << " " << -h << " " << z0 << "\nv " << h << " " << -h << " " << z0 << "\n"
    << "v " << h << " " << h << " " << z0 << "\nv " << -h << " " << h << " " << z0 << "\n"
    << "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
  const std::string path = Dir() + "/" + name;
  WriteText(path, s.str());
  return path;
}

std::string Camera(int w, int h) {
  return "[camera]\nposition = [0.0, -6.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\n"
         "fov_y = 22.0\nresolution = [" + std::to_string(w) + ", " + std::to_string(h) + "]\n";
}

Vec3d At3(const Image& img, int x, int y) {
  return {img.at(x, y, 0), img.at(x, y, 1), img.at(x, y, 2)};
}

TEST(Mesh, SphereMeshMatchesTheAnalyticSphere) {
  const std::string obj = SphereObj("sphere.obj", 1.0, {0, 0, 0}, 256, 512);
  const std::string lights = "[[lights]]\ntype = \"point\"\nposition = [3.0, -4.0, 4.0]\nintensity = 40.0\n";
  const Scene mesh = ParseScene(Camera(96, 96) + "[[objects]]\ntype = \"mesh\"\nfile = \"" + obj +
                                    "\"\n" + lights, "mesh.toml");
  const Scene analytic = ParseScene(testing::SphereSceneToml(96, 96, lights), "sphere.toml");
  const GBuffer gm = testing::SharedRenderer().RenderGBuffer(mesh);
  const GBuffer ga = testing::SharedRenderer().RenderGBuffer(analytic);
  const Image im = testing::SharedRenderer().Render(mesh, ModelId::kLambert, {0.5, 0.5, 0.5});
  const Image ia = testing::SharedRenderer().Render(analytic, ModelId::kLambert, {0.5, 0.5, 0.5});
  int both = 0, differ = 0;
  double worst_angle = 0, worst_radiance = 0;
  for (int y = 0; y < 96; ++y) {
    for (int x = 0; x < 96; ++x) {
      if (gm.Hit(x, y) != ga.Hit(x, y)) ++differ;
      if (!gm.Hit(x, y) || !ga.Hit(x, y)) continue;
      const Vec3d nm = At3(gm.normal, x, y), na = At3(ga.normal, x, y);
      if (Dot(na, At3(ga.view, x, y)) < 0.2) continue;  // Facets show at grazing view.
      ++both;
      worst_angle = std::max(worst_angle, std::acos(std::min(1.0, Dot(nm, na))) * 180 / kPiD);
      EXPECT_LT(Length(At3(gm.position, x, y) - At3(ga.position, x, y)), 2e-3) << x << "," << y;
      const double ref = ia.at(x, y, 1);
      if (ref > 0.05 * 40 / 41.0 * 0.5 / kPiD) {
        worst_radiance = std::max(worst_radiance, std::abs(im.at(x, y, 1) - ref) / ref);
      }
    }
  }
  EXPECT_GT(both, 4000);
  EXPECT_LT(differ, 40);  // Silhouette pixels only (a polygon is inside the sphere).
  EXPECT_LT(worst_angle, 0.5);
  EXPECT_LT(worst_radiance, 0.01);
}

TEST(Mesh, GlRasterAgreesWithCpuRayCasting) {
  // A concave object: a sphere with a smaller one pushed into it, both from files.
  const std::string a = SphereObj("big.obj", 1.0, {0, 0, 0}, 48, 96, false);
  const std::string b = SphereObj("small.obj", 0.5, {0.6, -0.7, 0.3}, 32, 64);
  const Scene scene = ParseScene(Camera(80, 64) + "[[objects]]\ntype = \"mesh\"\nfile = \"" + a +
                                     "\"\nrotate = [10.0, 20.0, 30.0]\n[[objects]]\ntype = \"mesh\"\n"
                                     "file = \"" + b + "\"\nscale = [1.0, 1.2, 0.8]\n",
                                 "two.toml");
  const GBuffer g = testing::SharedRenderer().RenderGBuffer(scene);
  int hits = 0, mismatched = 0;
  for (int y = 0; y < g.height; ++y) {
    for (int x = 0; x < g.width; ++x) {
      Hit hit;
      const bool cpu = Intersect(scene, CameraRay(scene.camera, x + 0.5, y + 0.5), 0, 1e30, &hit);
      if (cpu != g.Hit(x, y)) {
        ++mismatched;  // A ray through an edge may round either way.
        continue;
      }
      if (!cpu) continue;
      ++hits;
      const Vec3d p = At3(g.position, x, y);
      if (Length(p - hit.position) > 1e-3) {
        ++mismatched;  // Depth-buffer rounding where the two spheres meet.
        continue;
      }
      EXPECT_EQ(static_cast<int>(g.position.at(x, y, 3)) - 1, hit.object);
      EXPECT_GT(Dot(At3(g.normal, x, y), hit.normal), 0.9999) << x << "," << y;
    }
  }
  EXPECT_GT(hits, 2000);
  EXPECT_LT(mismatched, 10);
}

// A sphere above a ground square, a point light straight above: the shadow on the ground is the
// disc under the sphere, widened by the light's distance (similar triangles), computed here.
TEST(Mesh, CastShadowsFallWhereGeometrySaysAndTheTwinAgrees) {
  const std::string ground = QuadObj("ground.obj", 3.0, -1.0);
  const std::string ball = SphereObj("ball.obj", 0.5, {0, 0, 0.2}, 64, 128);
  const Vec3d light{0, 0, 3};
  const std::string text =
      "[camera]\nposition = [0.0, -7.0, 5.0]\nlook_at = [0.0, 0.0, -0.5]\nup = [0.0, 0.0, 1.0]\n"
      "fov_y = 30.0\nresolution = [96, 80]\n[[objects]]\ntype = \"mesh\"\nfile = \"" + ground +
      "\"\n[[objects]]\ntype = \"mesh\"\nfile = \"" + ball +
      "\"\n[[lights]]\ntype = \"point\"\nposition = [0.0, 0.0, 3.0]\nintensity = 20.0\n";
  const Scene scene = ParseScene(text, "shadow.toml");
  const GBuffer g = testing::SharedRenderer().RenderGBuffer(scene);
  const Image gl = testing::SharedRenderer().Render(scene, ModelId::kLambert, {0.8, 0.8, 0.8});
  const Image twin = ShadeGBuffer(scene, g, ModelId::kLambert, {0.8, 0.8, 0.8});
  // On the ground (z = -1), the ray to the light passes the sphere's centre (0, 0, 0.2) at
  // distance d; shadowed when d < 0.5 (a polygon: a little less), lit when clearly beyond.
  int shadowed = 0, lit = 0;
  for (int y = 0; y < g.height; ++y) {
    for (int x = 0; x < g.width; ++x) {
      if (!g.Hit(x, y) || static_cast<int>(g.position.at(x, y, 3)) != 1) continue;
      const Vec3d p = At3(g.position, x, y);
      const Vec3d l = Normalize(light - p);
      const Vec3d c{0, 0, 0.2};
      const double along = Dot(c - p, l);
      const double d = Length(c - p - l * along);
      const double value = gl.at(x, y, 0);
      if (d < 0.47) {
        ++shadowed;
        EXPECT_EQ(value, 0.0f) << "ground pixel " << x << "," << y << " should be in shadow";
      } else if (d > 0.53) {
        ++lit;
        EXPECT_GT(value, 0.0f) << "ground pixel " << x << "," << y << " should be lit";
      }
    }
  }
  EXPECT_GT(shadowed, 50);
  EXPECT_GT(lit, 1000);
  // The twin (PrepareShading's shadow test) and the GL path (the visibility texture) agree.
  double worst = 0;
  for (int y = 0; y < g.height; ++y) {
    for (int x = 0; x < g.width; ++x) {
      if (!g.Hit(x, y)) continue;
      const double ref = std::max<double>(twin.at(x, y, 0), 1e-3);
      worst = std::max(worst, std::abs(gl.at(x, y, 0) - twin.at(x, y, 0)) / ref);
    }
  }
  EXPECT_LT(worst, 1e-3);
  // The shadow edge is marked, and only near the edge.
  const Image edges = ShadowEdgeMask(scene);
  int marked = 0;
  for (int y = 0; y < g.height; ++y) {
    for (int x = 0; x < g.width; ++x) {
      if (!(edges.at(x, y, 0) > 0.5f)) continue;
      ++marked;
      if (static_cast<int>(g.position.at(x, y, 3)) != 1) continue;
      const Vec3d p = At3(g.position, x, y);
      const Vec3d l = Normalize(light - p);
      const Vec3d c{0, 0, 0.2};
      const double d = Length(c - p - l * Dot(c - p, l));
      EXPECT_NEAR(d, 0.5, 0.25) << x << "," << y;  // A pixel and its neighbours.
    }
  }
  EXPECT_GT(marked, 10);
}

// Environment light on meshes is occluded per quadrature direction (the CPU-cast visibility
// bits, render/src/surface_samples.h): a ball of triangles over a ground quad under uniform light
// renders as the analytic sphere over the analytic plane, whose shader casts its own occlusion
// rays against the exact shapes, for the same quadrature (Lambert: the light's and the cosine
// directions; GGX: its lobe's too). Without the bits the ground under the ball sees the whole
// sky (twice as bright there).
// Scenes of the same meshes differ in their lights only (a photometric-stereo set: one scene per
// light): they share one ray caster instead of building the same Embree structure each; other
// meshes get their own, and the shared one still answers for either scene.
TEST(Mesh, ScenesOfTheSameMeshesShareOneRayCaster) {
  const std::string ground = QuadObj("share_ground.obj", 3.0, -1.0);
  const std::string ball = SphereObj("share_ball.obj", 0.5, {0, 0, 0.2}, 16, 32);
  const auto scene_text = [&](bool with_ball, const std::string& light) {
    std::string t = Camera(32, 32) + "[[objects]]\ntype = \"mesh\"\nfile = \"" + ground + "\"\n";
    if (with_ball) t += "[[objects]]\ntype = \"mesh\"\nfile = \"" + ball + "\"\n";
    return t + "[[lights]]\ntype = \"point\"\nposition = " + light + "\nintensity = 20.0\n";
  };
  const Scene a = ParseScene(scene_text(true, "[0.0, 0.0, 3.0]"), "a.toml");
  const Scene b = ParseScene(scene_text(true, "[2.0, -1.0, 3.0]"), "b.toml");
  const Scene ground_only = ParseScene(scene_text(false, "[0.0, 0.0, 3.0]"), "c.toml");
  ASSERT_TRUE(a.ray_caster && b.ray_caster && ground_only.ray_caster);
  EXPECT_EQ(a.ray_caster, b.ray_caster);
  EXPECT_NE(a.ray_caster, ground_only.ray_caster);
  // Straight up from the ground under the ball: the ball is in the way; beside it, nothing is.
  const Ray up_under{{0, 0, -0.99}, {0, 0, 1}}, up_beside{{2, 2, -0.99}, {0, 0, 1}};
  EXPECT_TRUE(b.ray_caster->Occluded(up_under, 1e-6, 1e30));
  EXPECT_FALSE(b.ray_caster->Occluded(up_beside, 1e-6, 1e30));
  EXPECT_FALSE(ground_only.ray_caster->Occluded(up_under, 1e-6, 1e30));
}

TEST(Mesh, EnvironmentLightIsOccludedPerQuadratureDirection) {
  const std::string ground = QuadObj("env_ground.obj", 2.0, -1.0);
  const std::string ball = SphereObj("env_ball.obj", 0.5, {0, 0, -0.45}, 96, 192);
  const std::string camera =
      "[camera]\nposition = [0.0, -7.0, 5.0]\nlook_at = [0.0, 0.0, -0.8]\nup = [0.0, 0.0, 1.0]\n"
      "fov_y = 22.0\nresolution = [80, 64]\n";
  const std::string light = "[[lights]]\ntype = \"uniform\"\nradiance = [1.0, 1.0, 1.0]\n"
                            "samples = 64\n";
  const Scene mesh = ParseScene(camera + "[[objects]]\ntype = \"mesh\"\nfile = \"" + ground +
                                    "\"\n[[objects]]\ntype = \"mesh\"\nfile = \"" + ball +
                                    "\"\n" + light,
                                "env_mesh.toml");
  const Scene analytic = ParseScene(
      camera +
          "[[objects]]\ntype = \"plane\"\npoint = [0.0, 0.0, -1.0]\nnormal = [0.0, 0.0, 1.0]\n"
          "half_size = [2.0, 2.0]\n[[objects]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, -0.45]\n"
          "radius = 0.5\n" + light,
      "env_analytic.toml");
  const GBuffer g = testing::SharedRenderer().RenderGBuffer(analytic);
  struct Case {
    ModelId model;
    std::vector<double> params;
  };
  for (const Case& c : {Case{ModelId::kLambert, {0.8, 0.8, 0.8}},
                        Case{ModelId::kGgx, {0.5, 0.5, 0.5, 0.04, 0.04, 0.04, 0.3}}}) {
    const Image im = testing::SharedRenderer().Render(mesh, c.model, c.params);
    const Image ia = testing::SharedRenderer().Render(analytic, c.model, c.params);
    // Ground pixels near the ball (shadowed from a part of the sky), away from the contact
    // point's facets and the ball's silhouette.
    int near = 0;
    double sum_m = 0, sum_a = 0, open_sky = 0;
    int open = 0;
    for (int y = 1; y + 1 < g.height; ++y) {
      for (int x = 1; x + 1 < g.width; ++x) {
        bool ground_block = true;
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            ground_block = ground_block && g.Hit(x + dx, y + dy) &&
                           static_cast<int>(g.position.at(x + dx, y + dy, 3)) == 1;
          }
        }
        if (!ground_block) continue;
        const Vec3d p = At3(g.position, x, y);
        const double r = std::hypot(p.x, p.y);
        if (r > 1.5) {
          open_sky += ia.at(x, y, 1);
          ++open;
        }
        if (r < 0.25 || r > 0.9) continue;
        ++near;
        sum_m += im.at(x, y, 1);
        sum_a += ia.at(x, y, 1);
        EXPECT_NEAR(im.at(x, y, 1), ia.at(x, y, 1), 0.06 * ia.at(x, y, 1) + 1e-3)
            << GetModel(c.model).name << " ground pixel " << x << "," << y;
      }
    }
    ASSERT_GT(near, 100) << GetModel(c.model).name;
    ASSERT_GT(open, 100) << GetModel(c.model).name;
    // The ball takes a clear part of the sky near it (the test would not see a missing bit
    // otherwise), and the mesh's mean agrees with the analytic one.
    EXPECT_LT(sum_a / near, 0.8 * open_sky / open) << GetModel(c.model).name;
    EXPECT_NEAR(sum_m / sum_a, 1.0, 0.01) << GetModel(c.model).name;
  }
}

// SelfOcclusion against geometry: from a point on a ground plane, a sphere of radius r whose
// centre lies D away, at angle theta from the normal and wholly above the horizon, hides
// sin^2(asin(r / D)) cos(theta) = (r / D)^2 cos(theta) of the cosine-weighted hemisphere (its
// projected solid angle over pi). Here on a ground quad under a ball of triangles.
TEST(Mesh, SelfOcclusionIsTheHiddenShareOfTheCosineWeightedHemisphere) {
  const std::string ground = QuadObj("occ_ground.obj", 2.0, -1.0);
  const std::string ball = SphereObj("occ_ball.obj", 0.5, {0, 0, -0.45}, 96, 192);
  const Scene scene = ParseScene(
      "[camera]\nposition = [0.0, -7.0, 5.0]\nlook_at = [0.0, 0.0, -0.8]\nup = [0.0, 0.0, 1.0]\n"
      "fov_y = 22.0\nresolution = [80, 64]\n[[objects]]\ntype = \"mesh\"\nfile = \"" + ground +
          "\"\n[[objects]]\ntype = \"mesh\"\nfile = \"" + ball +
          "\"\n[[lights]]\ntype = \"point\"\nposition = [0.0, 0.0, 3.0]\nintensity = 20.0\n",
      "occ.toml");
  const Image share = SelfOcclusion(scene);
  const GBuffer g = testing::SharedRenderer().RenderGBuffer(scene);
  ASSERT_EQ(share.width, g.width);
  int checked = 0;
  double worst = 0;
  for (int y = 0; y < g.height; ++y) {
    for (int x = 0; x < g.width; ++x) {
      if (!g.Hit(x, y) || static_cast<int>(g.position.at(x, y, 3)) != 1) continue;
      const Vec3d p = At3(g.position, x, y);
      const Vec3d to_centre = Vec3d{0, 0, -0.45} - p;
      const double d = Length(to_centre), cos_theta = to_centre.z / d;
      const double expected = (0.5 / d) * (0.5 / d) * cos_theta;
      worst = std::max(worst, std::abs(share.at(x, y, 0) - expected));
      ++checked;
    }
  }
  EXPECT_GT(checked, 1000);
  // 256 directions a pixel: a share is a multiple of 1/256 with a stratification error of a few.
  EXPECT_LT(worst, 0.03);
  // Analytic objects: no surface object, no share.
  const Image empty = SelfOcclusion(ParseScene(testing::SphereSceneToml(8, 8, ""), "sphere.toml"));
  EXPECT_TRUE(empty.empty());
}

TEST(Mesh, NormalMapTiltsTheNormalAsItsTexelSays) {
  // A constant normal map: tangent-space (0.6, 0, 0.8) along +u, i.e. world (+X) on a +Z quad.
  Image map(4, 4, 3);
  for (int i = 0; i < 16; ++i) {
    map.data[3 * i] = 0.5f * (0.6f + 1.0f);
    map.data[3 * i + 1] = 0.5f * (0.0f + 1.0f);
    map.data[3 * i + 2] = 0.5f * (0.8f + 1.0f);
  }
  const std::string map_path = Dir() + "/tilt.exr";
  WriteExr(map_path, map);
  Image map_y = map;  // (0, 0.6, 0.8): along +v, world +Y.
  for (int i = 0; i < 16; ++i) std::swap(map_y.data[3 * i], map_y.data[3 * i + 1]);
  const std::string map_y_path = Dir() + "/tilt_y.exr";
  WriteExr(map_y_path, map_y);
  const std::string quad = QuadObj("quad.obj", 1.0, 0.0);
  auto scene_with = [&](const std::string& m, bool flip) {
    return ParseScene(
        "[camera]\ntype = \"orthographic\"\nposition = [0.0, 0.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\n"
        "up = [0.0, 1.0, 0.0]\nheight = 1.0\nresolution = [16, 16]\n[[objects]]\ntype = \"mesh\"\n"
        "file = \"" + quad + "\"\nnormal_map = \"" + m + "\"\n" +
            (flip ? "normal_map_flip_green = true\n" : ""),
        "tilt.toml");
  };
  struct Case {
    std::string map;
    bool flip;
    Vec3d expect;
  };
  for (const Case& c : {Case{map_path, false, {0.6, 0, 0.8}}, Case{map_y_path, false, {0, 0.6, 0.8}},
                        Case{map_y_path, true, {0, -0.6, 0.8}}}) {
    const Scene scene = scene_with(c.map, c.flip);
    const GBuffer g = testing::SharedRenderer().RenderGBuffer(scene);
    ASSERT_TRUE(g.Hit(8, 8));
    const Vec3d n = At3(g.normal, 8, 8);
    EXPECT_NEAR(n.x, c.expect.x, 1e-4) << c.map;
    EXPECT_NEAR(n.y, c.expect.y, 1e-4) << c.map;
    EXPECT_NEAR(n.z, c.expect.z, 1e-4) << c.map;
    Hit hit;
    ASSERT_TRUE(Intersect(scene, CameraRay(scene.camera, 8.5, 8.5), 0, 1e30, &hit));
    EXPECT_NEAR(Dot(hit.normal, c.expect), 1.0, 1e-6);
  }
}

// A hemisphere's normals as a photometric-stereo data set would give them: camera frame, y up.
NormalImage HemisphereNormals(int size, double radius_px) {
  NormalImage img;
  img.width = img.height = size;
  img.normal.assign(3 * size * size, 0.0f);
  img.mask.assign(size * size, 0);
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const double u = (x + 0.5 - size / 2.0) / radius_px, v = -(y + 0.5 - size / 2.0) / radius_px;
      const double r2 = u * u + v * v;
      if (r2 >= 0.97 * 0.97) continue;
      const std::size_t i = static_cast<std::size_t>(y) * size + x;
      img.mask[i] = 1;
      img.normal[3 * i] = static_cast<float>(u);
      img.normal[3 * i + 1] = static_cast<float>(v);
      img.normal[3 * i + 2] = static_cast<float>(std::sqrt(1 - r2));
    }
  }
  return img;
}

TEST(NormalMapObject, IntegratedDepthIsTheHemisphere) {
  const int size = 64;
  const double radius_px = 28;
  const NormalImage img = HemisphereNormals(size, radius_px);
  const double pixel = 1.0 / radius_px;  // Unit radius.
  const std::vector<double> depth = IntegrateNormals(img, pixel, 10.0);
  // Height above the mean: sqrt(1 - r^2) minus its mean over the mask, both computed here.
  double mean = 0;
  int n = 0;
  for (int i = 0; i < size * size; ++i) {
    if (!img.mask[i]) continue;
    mean += img.normal[3 * i + 2];
    ++n;
  }
  mean /= n;
  double worst = 0;
  for (int i = 0; i < size * size; ++i) {
    if (!img.mask[i] || img.normal[3 * i + 2] < 0.5) continue;  // Away from the clamped rim.
    worst = std::max(worst, std::abs((10.0 - depth[i]) - (img.normal[3 * i + 2] - mean)));
  }
  EXPECT_LT(worst, 0.05);
}

void WriteNpy(const std::string& path, const NormalImage& img, bool doubles) {
  std::ofstream out(path, std::ios::binary);
  std::string header = "{'descr': '<f" + std::string(doubles ? "8" : "4") +
                       "', 'fortran_order': False, 'shape': (" + std::to_string(img.height) + ", " +
                       std::to_string(img.width) + ", 3), }";
  while ((10 + header.size() + 1) % 64 != 0) header += ' ';
  header += '\n';
  out.write("\x93NUMPY\x01\x00", 8);
  const std::uint16_t len = static_cast<std::uint16_t>(header.size());
  out.write(reinterpret_cast<const char*>(&len), 2);
  out << header;
  for (std::size_t i = 0; i < img.normal.size(); ++i) {
    const double v = img.mask[i / 3] ? img.normal[i] : 0.0;
    if (doubles) {
      out.write(reinterpret_cast<const char*>(&v), 8);
    } else {
      const float f = static_cast<float>(v);
      out.write(reinterpret_cast<const char*>(&f), 4);
    }
  }
}

void WriteMat(const std::string& path, const NormalImage& img, bool compressed, bool flip_y) {
  std::vector<double> data(img.normal.size());
  for (int y = 0; y < img.height; ++y) {
    for (int x = 0; x < img.width; ++x) {
      for (int c = 0; c < 3; ++c) {
        const std::size_t i = static_cast<std::size_t>(y) * img.width + x;
        double v = img.mask[i] ? img.normal[3 * i + c] : 0.0;
        if (flip_y && c == 1) v = -v;
        data[y + static_cast<std::size_t>(img.height) * (x + static_cast<std::size_t>(img.width) * c)] = v;
      }
    }
  }
  mat_t* mat = Mat_CreateVer(path.c_str(), nullptr, MAT_FT_MAT5);
  ASSERT_NE(mat, nullptr);
  std::size_t dims[3] = {static_cast<std::size_t>(img.height), static_cast<std::size_t>(img.width), 3};
  matvar_t* var = Mat_VarCreate("Normal_gt", MAT_C_DOUBLE, MAT_T_DOUBLE, 3, dims, data.data(), 0);
  Mat_VarWrite(mat, var, compressed ? MAT_COMPRESSION_ZLIB : MAT_COMPRESSION_NONE);
  Mat_VarFree(var);
  Mat_Close(mat);
}

TEST(NormalMapObject, EveryFormatReadsTheSameNormals) {
  const NormalImage img = HemisphereNormals(24, 10);
  Image mask(24, 24, 1);
  for (int i = 0; i < 24 * 24; ++i) mask.data[i] = img.mask[i];
  const std::string mask_path = Dir() + "/mask.exr";
  WriteExr(mask_path, mask);
  WriteNpy(Dir() + "/n4.npy", img, false);
  WriteNpy(Dir() + "/n8.npy", img, true);
  WriteMat(Dir() + "/n.mat", img, false, false);
  WriteMat(Dir() + "/nz.mat", img, true, false);
  WriteMat(Dir() + "/ndown.mat", img, true, true);
  {
    std::ofstream txt(Dir() + "/n.txt");
    txt.precision(9);
    for (std::size_t i = 0; i < img.mask.size(); ++i) {
      txt << (img.mask[i] ? img.normal[3 * i] : 0) << " " << (img.mask[i] ? img.normal[3 * i + 1] : 0)
          << " " << (img.mask[i] ? img.normal[3 * i + 2] : 0) << "\n";
    }
  }
  Image exr(24, 24, 3);
  for (std::size_t i = 0; i < exr.data.size(); ++i) exr.data[i] = img.mask[i / 3] ? img.normal[i] : 0;
  WriteExr(Dir() + "/n.exr", exr);
  struct Case {
    std::string file;
    bool y_down;
  };
  for (const Case& c : {Case{"n4.npy", false}, Case{"n8.npy", false}, Case{"n.mat", false},
                        Case{"nz.mat", false}, Case{"ndown.mat", true}, Case{"n.txt", false},
                        Case{"n.exr", false}}) {
    const NormalImage got = ReadNormalImage(Dir() + "/" + c.file, mask_path, "", c.y_down);
    ASSERT_EQ(got.width, 24) << c.file;
    ASSERT_EQ(got.mask, img.mask) << c.file;
    for (std::size_t i = 0; i < img.normal.size(); ++i) {
      if (!img.mask[i / 3]) continue;
      ASSERT_NEAR(got.normal[i], img.normal[i], 2e-5) << c.file << " value " << i;
    }
  }
  // The flipped file read without y_axis = "down" is caught by no check on its own (a y-flip
  // keeps z), but its values differ: the test above needs y_down to pass.
  const NormalImage wrong = ReadNormalImage(Dir() + "/ndown.mat", mask_path, "", false);
  double diff = 0;
  for (std::size_t i = 0; i < img.normal.size(); ++i) diff += std::abs(wrong.normal[i] - img.normal[i]);
  EXPECT_GT(diff, 1.0);
}

TEST(NormalMapObject, LambertRendersNDotLWithItsCastShadows) {
  const NormalImage img = HemisphereNormals(48, 20);
  WriteNpy(Dir() + "/hemi.npy", img, false);
  // No camera: orthographic along the normals' z axis (world -Z). A directional light from the
  // camera's upper right, in the normals' frame (x right, y up, z toward the camera).
  const Vec3d l = Normalize(Vec3d{0.5, 0.4, 0.77});
  std::ostringstream text;
  text << "[[objects]]\ntype = \"normal_map\"\nnormals = \"" << Dir() << "/hemi.npy\"\n"
       << "[[lights]]\ntype = \"directional\"\ndirection = [" << -l.x << ", " << -l.y << ", "
       << -l.z << "]\nirradiance = 3.0\n";
  const Scene scene = ParseScene(text.str(), "hemi.toml");
  EXPECT_EQ(scene.camera.width, 48);
  const Image out = testing::SharedRenderer().Render(scene, ModelId::kLambert, {0.5, 0.5, 0.5});
  int checked = 0;
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 48; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * 48 + x;
      if (!img.mask[i]) {
        EXPECT_EQ(out.at(x, y, 3), 0.0f);
        continue;
      }
      const Vec3d n{img.normal[3 * i], img.normal[3 * i + 1], img.normal[3 * i + 2]};
      const double expect = std::max(0.0, Dot(n, l)) * 3.0 * 0.5 / kPiD;
      // A convex cap casts no shadow on itself; only the terminator's facets may differ.
      if (Dot(n, l) < 0.1) continue;
      ++checked;
      EXPECT_NEAR(out.at(x, y, 0), expect, 1e-4 + 1e-4 * expect) << x << "," << y;
    }
  }
  EXPECT_GT(checked, 800);
}

TEST(MeshErrors, OneLineNamingTheFileAndTheProblem) {
  auto message = [](const std::string& object_toml) {
    try {
      ParseScene(Camera(8, 8) + object_toml, "bad.toml");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string missing = message("[[objects]]\ntype = \"mesh\"\nfile = \"/nonexistent/x.obj\"\n");
  EXPECT_NE(missing.find("bad.toml"), std::string::npos) << missing;
  EXPECT_NE(missing.find("objects[0].file"), std::string::npos) << missing;
  EXPECT_NE(missing.find("not found"), std::string::npos) << missing;
  WriteText(Dir() + "/nofaces.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
  const std::string nofaces = message("[[objects]]\ntype = \"mesh\"\nfile = \"" + Dir() + "/nofaces.obj\"\n");
  EXPECT_NE(nofaces.find("nofaces.obj"), std::string::npos) << nofaces;
  EXPECT_TRUE(nofaces.find("no faces") != std::string::npos ||
              nofaces.find("cannot read") != std::string::npos) << nofaces;
  WriteText(Dir() + "/garbage.xyz3", "\x01\x02 not a mesh at all \x7f");
  const std::string garbage = message("[[objects]]\ntype = \"mesh\"\nfile = \"" + Dir() + "/garbage.xyz3\"\n");
  EXPECT_NE(garbage.find("garbage.xyz3: mesh: cannot read it as a mesh"), std::string::npos) << garbage;
  for (const std::string& m : {missing, nofaces, garbage}) EXPECT_EQ(m.find('\n'), std::string::npos);
  const std::string mixed = message("[[objects]]\ntype = \"sphere\"\n[[objects]]\ntype = \"mesh\"\nfile = \"" +
                                    SphereObj("m.obj", 1, {0, 0, 0}, 4, 8) + "\"\n");
  EXPECT_NE(mixed.find("objects[1].type"), std::string::npos) << mixed;

  TriangleMesh nan_mesh;
  nan_mesh.positions = {0, 0, 0, 1, 0, 0, 0, std::nanf(""), 0};
  nan_mesh.indices = {0, 1, 2};
  try {
    ValidateMesh("nan.ply", &nan_mesh);
    ADD_FAILURE() << "a NaN vertex was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("nan.ply: mesh: vertex 2"), std::string::npos) << e.what();
  }
  TriangleMesh range;
  range.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  range.indices = {0, 1, 7};
  try {
    ValidateMesh("range.ply", &range);
    ADD_FAILURE() << "an index out of range was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("out of range"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace shadefit
