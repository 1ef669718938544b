#pragma once
// Indexed triangle mesh with optional per-vertex colours and normals.

#include <locard/core/point_cloud.hpp>

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <vector>

namespace locard {

struct TriangleMesh {
  std::vector<Eigen::Vector3f> vertices;
  std::vector<Eigen::Vector3f> vertex_normals;  // empty or one per vertex
  std::vector<Rgb8> vertex_colors;              // empty or one per vertex
  std::vector<std::array<std::uint32_t, 3>> triangles;  // counter-clockwise seen from outside

  std::size_t vertex_count() const { return vertices.size(); }
  std::size_t triangle_count() const { return triangles.size(); }
};

}  // namespace locard
