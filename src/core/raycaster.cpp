#include <locard/core/raycaster.hpp>

#include <locard/core/error.hpp>

#include <embree3/rtcore.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <string>

namespace locard {
namespace {

std::string embree_error_name(RTCError code) {
  switch (code) {
    case RTC_ERROR_NONE: return "no error";
    case RTC_ERROR_INVALID_ARGUMENT: return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION: return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY: return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU: return "unsupported CPU";
    case RTC_ERROR_CANCELLED: return "cancelled";
    default: return "unknown error";
  }
}

void check(RTCDevice device, const char* what) {
  const RTCError code = rtcGetDeviceError(device);
  if (code != RTC_ERROR_NONE)
    throw Error(std::string("Embree: ") + what + " failed: " + embree_error_name(code));
}

}  // namespace

struct Raycaster::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::size_t triangles = 0;

  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

Raycaster::Raycaster(const TriangleMesh& mesh) : impl_(std::make_unique<Impl>()) {
  impl_->device = rtcNewDevice(nullptr);
  if (!impl_->device)
    throw Error("Embree: could not create a device: " +
                embree_error_name(rtcGetDeviceError(nullptr)));
  impl_->scene = rtcNewScene(impl_->device);
  // Robust mode: watertight edges, so no ray slips between the two triangles of a wall.
  rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);

  const std::size_t n_vertices = mesh.vertices.size();
  for (const auto& tri : mesh.triangles)
    for (std::uint32_t index : tri)
      if (index >= n_vertices)
        throw Error("Raycaster: triangle index " + std::to_string(index) + " out of range (" +
                    std::to_string(n_vertices) + " vertices)");

  if (!mesh.triangles.empty()) {
    RTCGeometry geometry = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    // Buffers allocated by Embree carry the padding its SIMD loads need.
    auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
        geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), n_vertices));
    auto* indices = static_cast<std::uint32_t*>(
        rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                3 * sizeof(std::uint32_t), mesh.triangles.size()));
    check(impl_->device, "allocating geometry buffers");
    for (std::size_t i = 0; i < n_vertices; ++i)
      std::memcpy(vertices + 3 * i, mesh.vertices[i].data(), 3 * sizeof(float));
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
      std::memcpy(indices + 3 * i, mesh.triangles[i].data(), 3 * sizeof(std::uint32_t));
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(impl_->scene, geometry);
    rtcReleaseGeometry(geometry);
  }
  rtcCommitScene(impl_->scene);
  check(impl_->device, "building the BVH");
  impl_->triangles = mesh.triangles.size();
}

Raycaster::~Raycaster() = default;
Raycaster::Raycaster(Raycaster&&) noexcept = default;
Raycaster& Raycaster::operator=(Raycaster&&) noexcept = default;

std::size_t Raycaster::triangle_count() const { return impl_->triangles; }

void Raycaster::intersect_coherent(const Eigen::Vector3f& origin,
                                   const Eigen::Vector3f* directions, std::size_t n,
                                   RayHit* hits) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  constexpr std::size_t kPacket = 16;
  for (std::size_t first = 0; first < n; first += kPacket) {
    const std::size_t count = std::min(kPacket, n - first);
    alignas(64) RTCRayHit16 packet;
    alignas(64) int valid[kPacket];
    for (std::size_t k = 0; k < kPacket; ++k) {
      const bool active = k < count;
      valid[k] = active ? -1 : 0;
      const Eigen::Vector3f& d = directions[first + (active ? k : 0)];
      packet.ray.org_x[k] = origin.x();
      packet.ray.org_y[k] = origin.y();
      packet.ray.org_z[k] = origin.z();
      packet.ray.dir_x[k] = d.x();
      packet.ray.dir_y[k] = d.y();
      packet.ray.dir_z[k] = d.z();
      packet.ray.tnear[k] = 0.0f;
      packet.ray.tfar[k] = std::numeric_limits<float>::infinity();
      packet.ray.time[k] = 0.0f;
      packet.ray.mask[k] = 0xFFFFFFFFu;
      packet.ray.id[k] = static_cast<unsigned>(k);
      packet.ray.flags[k] = 0;
      packet.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
      packet.hit.primID[k] = RTC_INVALID_GEOMETRY_ID;
      packet.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
    }
    rtcIntersect16(valid, impl_->scene, &context, &packet);
    for (std::size_t k = 0; k < count; ++k) {
      RayHit& hit = hits[first + k];
      hit = RayHit{};
      if (packet.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) continue;
      hit.t = packet.ray.tfar[k];
      hit.triangle = packet.hit.primID[k];
      hit.u = packet.hit.u[k];
      hit.v = packet.hit.v[k];
    }
  }
}

RayHit Raycaster::intersect(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction,
                            float t_near, float t_far) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit query;
  query.ray.org_x = origin.x();
  query.ray.org_y = origin.y();
  query.ray.org_z = origin.z();
  query.ray.dir_x = direction.x();
  query.ray.dir_y = direction.y();
  query.ray.dir_z = direction.z();
  query.ray.tnear = t_near;
  query.ray.tfar = t_far;
  query.ray.time = 0.0f;
  query.ray.mask = 0xFFFFFFFFu;
  query.ray.id = 0;
  query.ray.flags = 0;
  query.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  query.hit.primID = RTC_INVALID_GEOMETRY_ID;
  query.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &context, &query);

  RayHit hit;
  if (query.hit.geomID == RTC_INVALID_GEOMETRY_ID) return hit;
  hit.t = query.ray.tfar;
  hit.triangle = query.hit.primID;
  hit.u = query.hit.u;
  hit.v = query.hit.v;
  return hit;
}

}  // namespace locard
