#pragma once
// Ray casting against a triangle mesh through Embree's BVH. Thread-safe for queries: one
// Raycaster is shared by every worker rendering rows and views in parallel.

#include <locard/core/triangle_mesh.hpp>

#include <Eigen/Core>

#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

namespace locard {

struct RayHit {
  static constexpr std::uint32_t kNoTriangle = std::numeric_limits<std::uint32_t>::max();

  // Distance along the ray in units of the direction's length: with a direction whose camera
  // z component is 1, `t` is the z-depth itself.
  float t = std::numeric_limits<float>::infinity();
  std::uint32_t triangle = kNoTriangle;
  // Barycentric coordinates: hit = (1 - u - v) * v0 + u * v1 + v * v2.
  float u = 0.0f;
  float v = 0.0f;

  bool hit() const { return triangle != kNoTriangle; }
};

class Raycaster {
 public:
  // Builds the BVH. Throws locard::Error if Embree fails (e.g. degenerate input).
  explicit Raycaster(const TriangleMesh& mesh);
  ~Raycaster();
  Raycaster(Raycaster&&) noexcept;
  Raycaster& operator=(Raycaster&&) noexcept;
  Raycaster(const Raycaster&) = delete;
  Raycaster& operator=(const Raycaster&) = delete;

  // Nearest hit with t in [t_near, t_far]; `direction` need not be unit length.
  RayHit intersect(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction,
                   float t_near = 0.0f,
                   float t_far = std::numeric_limits<float>::infinity()) const;

  // Nearest hits of n rays from one origin, e.g. a row of pixels: Embree traces such coherent
  // bundles as packets, several times faster than one ray at a time.
  void intersect_coherent(const Eigen::Vector3f& origin, const Eigen::Vector3f* directions,
                          std::size_t n, RayHit* hits) const;

  std::size_t triangle_count() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace locard
