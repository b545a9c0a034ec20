// CPU ray casting of a scene's triangles (its meshes and the depth surfaces of its normal-map
// objects) with Embree: the CPU side's view of the same triangles the GL renderer rasterises.
// Scene::ray_caster holds one, built when the scene is read; Intersect() (scene.h) asks it.
#pragma once

#include <memory>
#include <vector>

#include "shadefit/render/mesh.h"

namespace shadefit {

struct Ray;

class RayCaster {
 public:
  struct Part {
    int object = -1;  // Index into Scene::objects.
    std::shared_ptr<const TriangleMesh> mesh;
  };
  // Throws shadefit::Error when Embree cannot build the structure (out of memory).
  explicit RayCaster(std::vector<Part> parts);
  ~RayCaster();
  RayCaster(const RayCaster&) = delete;
  RayCaster& operator=(const RayCaster&) = delete;

  struct TriangleHit {
    double t = 0;
    int part = -1;          // Index into parts().
    unsigned triangle = 0;  // Index into the part's mesh triangles.
    double u = 0, v = 0;    // Barycentrics: p = (1 - u - v) p0 + u p1 + v p2.
  };
  // Nearest hit with t in (t_min, t_max). Thread-safe.
  bool Nearest(const Ray& ray, double t_min, double t_max, TriangleHit* hit) const;
  // Any hit with t in (t_min, t_max). Thread-safe.
  bool Occluded(const Ray& ray, double t_min, double t_max) const;

  const std::vector<Part>& parts() const { return parts_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::vector<Part> parts_;
};

// The ray caster of `parts`: the one already built for the same meshes (the same objects, by
// identity: meshes are shared per file and transform, normal-map surfaces per content of their
// files) while any scene still holds it, else a new one. A photometric-stereo set's 96 scenes
// differ in their light only; each used to build its own Embree structure over the same depth
// mesh. Thread-safe.
std::shared_ptr<const RayCaster> SharedRayCaster(std::vector<RayCaster::Part> parts);

}  // namespace shadefit
