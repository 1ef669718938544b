#pragma once
// Shared by the sensor-model tests: a flat target to render depth against.

#include <locard/core/triangle_mesh.hpp>
#include <locard/sim/scene_mesh.hpp>

#include <Eigen/Geometry>

#include <array>

namespace locard::sim::test {

// A 80 m square through `center` with unit normal `n` (facing the camera at the origin).
inline SceneMesh plane_through(const Eigen::Vector3d& center, const Eigen::Vector3d& n) {
  const Eigen::Vector3d e1 = Eigen::Vector3d::UnitX() * 40.0;
  const Eigen::Vector3d e2 = n.cross(e1);
  const std::array<Eigen::Vector3d, 4> corners{center - e1 - e2, center + e1 - e2,
                                               center + e1 + e2, center - e1 + e2};
  TriangleMesh quad;
  for (const Eigen::Vector3d& p : corners) {
    quad.vertices.push_back(p.cast<float>());
    quad.vertex_colors.push_back({200, 200, 200});
  }
  quad.triangles = {{0, 1, 2}, {0, 2, 3}};
  SceneMesh mesh;
  mesh.add_part(quad, {}, "plane");
  return mesh;
}

}  // namespace locard::sim::test
