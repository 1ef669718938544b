#pragma once
// Shared by the sensor-model tests: a flat target to render depth against.

#include <locard/core/triangle_mesh.hpp>
#include <locard/sim/scene_mesh.hpp>

#include <Eigen/Geometry>

#include <array>
#include <cmath>

namespace locard::sim::test {

// A square of side `size` centred on `center`, facing along `normal`.
inline SceneMesh plane_mesh(const Eigen::Vector3d& center, const Eigen::Vector3d& normal,
                            double size, Rgb8 color = {200, 200, 200}) {
  const Eigen::Vector3d n = normal.normalized();
  const Eigen::Vector3d helper =
      std::abs(n.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d e1 = n.cross(helper).normalized() * (0.5 * size);
  const Eigen::Vector3d e2 = n.cross(e1);
  const std::array<Eigen::Vector3d, 4> corners{center - e1 - e2, center + e1 - e2,
                                               center + e1 + e2, center - e1 + e2};
  TriangleMesh quad;
  for (const Eigen::Vector3d& c : corners) {
    quad.vertices.push_back(c.cast<float>());
    quad.vertex_normals.push_back(n.cast<float>());
    quad.vertex_colors.push_back(color);
  }
  quad.triangles = {{0, 1, 2}, {0, 2, 3}};
  SceneMesh mesh;
  mesh.add_part(quad, {}, "plane");
  return mesh;
}

// An 80 m square through `center` with unit normal `n` (facing the camera at the origin):
// wider than any view.
inline SceneMesh plane_through(const Eigen::Vector3d& center, const Eigen::Vector3d& n) {
  return plane_mesh(center, n, 80.0);
}

}  // namespace locard::sim::test
