#include "shadefit/render/ray_caster.h"

#include <embree3/rtcore.h>
#include <fmt/format.h>

#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <vector>

#include "shadefit/base/error.h"
#include "shadefit/render/scene.h"

namespace shadefit {
namespace {

// One Embree device for the process: made on first use, never released (a device per scene
// would cost its thread pool each time).
RTCDevice Device() {
  static std::once_flag once;
  static RTCDevice device = nullptr;
  std::call_once(once, [] {
    // Embree's own threads are not used: rtcCommitScene builds on the calling thread (the study
    // runner's workers already fill the cores).
    device = rtcNewDevice("threads=1,set_affinity=0");
  });
  if (!device) throw Error("Embree", "device", "rtcNewDevice failed");
  return device;
}

RTCRayHit MakeRay(const Ray& ray, double t_min, double t_max) {
  RTCRayHit rh;
  rh.ray.org_x = static_cast<float>(ray.origin.x);
  rh.ray.org_y = static_cast<float>(ray.origin.y);
  rh.ray.org_z = static_cast<float>(ray.origin.z);
  rh.ray.dir_x = static_cast<float>(ray.direction.x);
  rh.ray.dir_y = static_cast<float>(ray.direction.y);
  rh.ray.dir_z = static_cast<float>(ray.direction.z);
  // Embree's interval is closed; ours is open: the next float up excludes t_min itself.
  rh.ray.tnear = std::nextafter(static_cast<float>(std::max(t_min, 0.0)),
                                std::numeric_limits<float>::infinity());
  rh.ray.tfar = t_max >= 3.0e38 ? std::numeric_limits<float>::infinity()
                                : static_cast<float>(t_max);
  rh.ray.time = 0.0f;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  return rh;
}

}  // namespace

struct RayCaster::Impl {
  RTCScene scene = nullptr;
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
  }
};

RayCaster::RayCaster(std::vector<Part> parts) : impl_(std::make_unique<Impl>()), parts_(std::move(parts)) {
  RTCDevice device = Device();
  impl_->scene = rtcNewScene(device);
  // Robust: rays through an edge or a vertex shared by two triangles never slip between them.
  rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    const TriangleMesh& mesh = *parts_[i].mesh;
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    // Shared buffers: Embree reads the mesh's own arrays (kept alive by parts_). Its vertex
    // buffers must be readable 16 bytes past the last vertex, so the positions are copied with
    // padding.
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
        geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), mesh.VertexCount()));
    auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
        mesh.TriangleCount()));
    if (!v || !idx) {
      rtcReleaseGeometry(geom);
      throw Error(mesh.path, "mesh", "Embree could not allocate its buffers (out of memory?)");
    }
    std::copy(mesh.positions.begin(), mesh.positions.end(), v);
    std::copy(mesh.indices.begin(), mesh.indices.end(), idx);
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(impl_->scene, geom, static_cast<unsigned>(i));
    rtcReleaseGeometry(geom);
  }
  rtcCommitScene(impl_->scene);
  if (rtcGetDeviceError(device) != RTC_ERROR_NONE) {
    throw Error("Embree", "scene", "building the ray-casting structure failed (out of memory?)");
  }
}

RayCaster::~RayCaster() = default;

bool RayCaster::Nearest(const Ray& ray, double t_min, double t_max, TriangleHit* hit) const {
  RTCRayHit rh = MakeRay(ray, t_min, t_max);
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  rtcIntersect1(impl_->scene, &context, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
  if (hit) {
    hit->t = rh.ray.tfar;
    hit->part = static_cast<int>(rh.hit.geomID);
    hit->triangle = rh.hit.primID;
    hit->u = rh.hit.u;
    hit->v = rh.hit.v;
  }
  return true;
}

bool RayCaster::Occluded(const Ray& ray, double t_min, double t_max) const {
  RTCRayHit rh = MakeRay(ray, t_min, t_max);
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  rtcOccluded1(impl_->scene, &context, &rh.ray);
  return rh.ray.tfar < 0.0f;  // Embree sets tfar to -inf on a hit.
}

std::shared_ptr<const RayCaster> SharedRayCaster(std::vector<RayCaster::Part> parts) {
  static std::mutex mutex;
  // Held weakly: a ray caster lives as long as its scenes. While it lives, its parts keep their
  // meshes alive, so a mesh's address cannot be another mesh's: identity is a sound key.
  static std::vector<std::weak_ptr<const RayCaster>> built;
  const auto same = [&parts](const RayCaster& r) {
    if (r.parts().size() != parts.size()) return false;
    for (std::size_t i = 0; i < parts.size(); ++i) {
      if (r.parts()[i].object != parts[i].object || r.parts()[i].mesh != parts[i].mesh) {
        return false;
      }
    }
    return true;
  };
  std::lock_guard<std::mutex> lock(mutex);
  std::erase_if(built, [](const std::weak_ptr<const RayCaster>& w) { return w.expired(); });
  for (const std::weak_ptr<const RayCaster>& w : built) {
    if (std::shared_ptr<const RayCaster> r = w.lock(); r && same(*r)) return r;
  }
  // Built under the lock: two workers loading scenes of one mesh wait for one build.
  auto made = std::make_shared<const RayCaster>(std::move(parts));
  built.push_back(made);
  return made;
}

}  // namespace shadefit
