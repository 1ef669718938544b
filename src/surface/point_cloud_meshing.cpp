#include <locard/core/error.hpp>
#include <locard/surface/mesh_cleanup.hpp>
#include <locard/surface/point_cloud_meshing.hpp>

#include <CGAL/Advancing_front_surface_reconstruction.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <Eigen/Geometry>

#include <array>
#include <utility>
#include <iterator>
#include <vector>

namespace locard {

TriangleMesh advancing_front_mesh(const PointCloud& cloud, const AdvancingFrontOptions& options) {
  using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
  std::vector<Kernel::Point_3> points;
  std::vector<std::uint32_t> source;  // input index of each point
  points.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f& p = cloud.positions[i];
    if (!p.allFinite()) continue;
    points.emplace_back(p.x(), p.y(), p.z());
    source.push_back(static_cast<std::uint32_t>(i));
  }
  if (points.size() < 3)
    throw InputError("advancing_front_mesh: at least 3 finite points are needed, got " +
                     std::to_string(points.size()));
  std::vector<std::array<std::size_t, 3>> facets;
  CGAL::advancing_front_surface_reconstruction(points.begin(), points.end(),
                                               std::back_inserter(facets),
                                               options.radius_ratio_bound, options.beta);
  TriangleMesh mesh;
  mesh.vertices.reserve(points.size());
  for (std::uint32_t i : source) mesh.vertices.push_back(cloud.positions[i]);
  if (cloud.has_colors())
    for (std::uint32_t i : source) mesh.vertex_colors.push_back(cloud.colors[i]);
  mesh.triangles.reserve(facets.size());
  for (const auto& f : facets)
    mesh.triangles.push_back({static_cast<std::uint32_t>(f[0]), static_cast<std::uint32_t>(f[1]),
                              static_cast<std::uint32_t>(f[2])});
  // Facet orientation from the Delaunay walk is arbitrary: agree with the points' normals.
  if (cloud.has_normals())
    for (auto& t : mesh.triangles) {
      const Eigen::Vector3f face = (mesh.vertices[t[1]] - mesh.vertices[t[0]])
                                       .cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
      const Eigen::Vector3f n = cloud.normals[source[t[0]]] + cloud.normals[source[t[1]]] +
                                cloud.normals[source[t[2]]];
      if (face.dot(n) < 0.f) std::swap(t[1], t[2]);
    }
  remove_unused_vertices(mesh);
  return mesh;
}

}  // namespace locard
