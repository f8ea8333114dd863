#include "hazmap/sim/raycaster.hpp"

#include <embree3/rtcore.h>

#include <chrono>
#include <string>

#include "hazmap/core/error.hpp"

namespace hazmap::sim {

namespace {

void embreeError(void* user, RTCError code, const char* message) {
  auto* last = static_cast<std::string*>(user);
  *last = "embree error " + std::to_string(static_cast<int>(code)) + ": " + (message ? message : "");
}

}  // namespace

struct RayCaster::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::string last_error;
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

RayCaster::RayCaster(const TriangleMesh& mesh) : impl_(std::make_unique<Impl>()) {
  if (mesh.triangles.empty() || mesh.vertices.empty())
    fail("ray caster", "scene mesh is empty (no triangles)");
  const auto start = std::chrono::steady_clock::now();
  impl_->device = rtcNewDevice(nullptr);
  if (!impl_->device) fail("ray caster", "cannot create an Embree device");
  rtcSetDeviceErrorFunction(impl_->device, embreeError, &impl_->last_error);

  RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), mesh.vertices.size()));
  auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), mesh.triangles.size()));
  if (!vertices || !indices) {
    rtcReleaseGeometry(geom);
    fail("ray caster", "cannot allocate Embree buffers (" + impl_->last_error + ")");
  }
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
    for (int k = 0; k < 3; ++k) vertices[3 * i + k] = mesh.vertices[i][k];
  const auto nv = static_cast<int>(mesh.vertices.size());
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    const Eigen::Vector3i& t = mesh.triangles[i];
    if (t.minCoeff() < 0 || t.maxCoeff() >= nv) {
      rtcReleaseGeometry(geom);
      fail("ray caster", "triangle " + std::to_string(i) + " has a vertex index out of range");
    }
    for (int k = 0; k < 3; ++k) indices[3 * i + k] = static_cast<unsigned>(t[k]);
  }
  rtcCommitGeometry(geom);
  impl_->scene = rtcNewScene(impl_->device);
  // Robust mode: rays through shared triangle edges (e.g. the floor's diagonal) never leak.
  rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);
  rtcAttachGeometry(impl_->scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(impl_->scene);
  if (!impl_->last_error.empty()) fail("ray caster", impl_->last_error);
  build_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

RayCaster::~RayCaster() = default;

void RayCaster::cast(const Eigen::Vector3f& origin, std::span<const Eigen::Vector3f> directions,
                     float t_near, float t_far, std::vector<RayHit>& hits) const {
  hits.assign(directions.size(), RayHit{});
  constexpr std::size_t kBatch = 256;
  RTCRayHit batch[kBatch];
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  // Rays of one scan share an origin and sweep the directions in order: coherent.
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  for (std::size_t begin = 0; begin < directions.size(); begin += kBatch) {
    const std::size_t n = std::min(kBatch, directions.size() - begin);
    for (std::size_t k = 0; k < n; ++k) {
      RTCRayHit& rh = batch[k];
      const Eigen::Vector3f& d = directions[begin + k];
      rh.ray.org_x = origin.x();
      rh.ray.org_y = origin.y();
      rh.ray.org_z = origin.z();
      rh.ray.dir_x = d.x();
      rh.ray.dir_y = d.y();
      rh.ray.dir_z = d.z();
      rh.ray.tnear = t_near;
      rh.ray.tfar = t_far;
      rh.ray.time = 0.0f;
      rh.ray.mask = 0xFFFFFFFFu;
      rh.ray.id = static_cast<unsigned>(k);
      rh.ray.flags = 0;
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
      rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    }
    rtcIntersect1M(impl_->scene, &context, batch, static_cast<unsigned>(n), sizeof(RTCRayHit));
    for (std::size_t k = 0; k < n; ++k) {
      const RTCRayHit& rh = batch[k];
      if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
      RayHit& out = hits[begin + k];
      out.distance = rh.ray.tfar;
      out.triangle = rh.hit.primID;
      const Eigen::Vector3f n(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
      const float len = n.norm();
      out.normal = len > 0.0f ? Eigen::Vector3f(n / len) : Eigen::Vector3f::UnitZ();
    }
  }
}

RayHit RayCaster::cast(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction,
                       float t_near, float t_far) const {
  std::vector<RayHit> hits;
  cast(origin, std::span<const Eigen::Vector3f>(&direction, 1), t_near, t_far, hits);
  return hits[0];
}

}  // namespace hazmap::sim
