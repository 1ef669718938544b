#include <locard/core/error.hpp>
#include <locard/surface/mesh_cleanup.hpp>
#include <locard/surface/point_cloud_meshing.hpp>

#include <locard/core/kdtree.hpp>
#include <locard/preprocess/normals.hpp>

#include <CGAL/Advancing_front_surface_reconstruction.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/poisson_surface_reconstruction.h>
#include <CGAL/property_map.h>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <string>

#include <array>
#include <iterator>
#include <limits>
#include <utility>
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

namespace {

double mean_neighbour_spacing(const KdTree& tree, int k) {
  const NeighborLists lists = tree.knn_batch(tree.points(), k + 1);  // the point itself first
  double sum = 0.0;
  std::size_t n = 0;
  for (const Neighbor& nb : lists.neighbors)
    if (nb.squared_distance > 0.f) {
      sum += std::sqrt(static_cast<double>(nb.squared_distance));
      ++n;
    }
  return n ? sum / static_cast<double>(n) : 0.0;
}

// CGAL's Poisson solver dereferences a null cell (SIGSEGV) when the points span no volume:
// its Delaunay refinement of an exactly flat or straight set has no tetrahedra to solve on. The
// spread of the points along their principal axes tells: thinner than kFlatRatio of the
// widest spread is a plane (or a line, when two axes are).
constexpr double kFlatRatio = 1e-4;

void check_spans_a_volume(const std::vector<Eigen::Vector3f>& positions) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3f& p : positions) mean += p.cast<double>();
  mean /= static_cast<double>(positions.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3f& p : positions) {
    const Eigen::Vector3d d = p.cast<double>() - mean;
    covariance += d * d.transpose();
  }
  covariance /= static_cast<double>(positions.size());
  const Eigen::Vector3d spread =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance).eigenvalues().cwiseMax(0.0).cwiseSqrt();
  const double widest = spread(2);
  if (!(widest > 0.0))
    throw InputError("poisson_mesh: every point is at the same place; a surface needs points "
                     "that span a volume");
  if (spread(1) < kFlatRatio * widest)
    throw InputError(fmt::format("poisson_mesh: the points lie on a line (spread {:.3g} m across, "
                                 "{:.3g} m along); a Poisson surface needs points that span a "
                                 "volume", spread(1), widest));
  if (spread(0) < kFlatRatio * widest)
    throw InputError(fmt::format("poisson_mesh: the points lie on a plane (spread {:.3g} m off "
                                 "it, {:.3g} m along it); a Poisson surface needs points that "
                                 "span a volume - use the Delaunay method for a flat patch",
                                 spread(0), widest));
}

}  // namespace

TriangleMesh poisson_mesh(const PointCloud& cloud, const PoissonOptions& options) {
  using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
  using PointNormal = std::pair<Kernel::Point_3, Kernel::Vector_3>;
  if (!cloud.has_normals()) throw InputError("poisson_mesh: the cloud has no normals");
  std::vector<PointNormal> points;
  std::vector<Eigen::Vector3f> positions;
  std::vector<Rgb8> colors;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f& p = cloud.positions[i];
    const Eigen::Vector3f& n = cloud.normals[i];
    if (!p.allFinite() || !n.allFinite()) continue;
    points.emplace_back(Kernel::Point_3(p.x(), p.y(), p.z()), Kernel::Vector_3(n.x(), n.y(), n.z()));
    positions.push_back(p);
    if (cloud.has_colors()) colors.push_back(cloud.colors[i]);
  }
  if (points.size() < 10)
    throw InputError("poisson_mesh: at least 10 finite points are needed, got " +
                     std::to_string(points.size()));
  check_spans_a_volume(positions);
  const KdTree tree(positions);
  const double spacing = options.spacing > 0.0 ? options.spacing : mean_neighbour_spacing(tree, 6);
  const double trim = options.trim_distance > 0.0 ? options.trim_distance : 2.0 * spacing;

  CGAL::Surface_mesh<Kernel::Point_3> surface;
  if (!CGAL::poisson_surface_reconstruction_delaunay(
          points.begin(), points.end(), CGAL::First_of_pair_property_map<PointNormal>(),
          CGAL::Second_of_pair_property_map<PointNormal>(), surface, spacing, options.sm_angle,
          options.sm_radius, options.sm_distance))
    throw Error("poisson_mesh: CGAL's Poisson solver failed");

  TriangleMesh mesh;
  std::vector<std::uint32_t> index(surface.number_of_vertices(), 0);
  for (auto v : surface.vertices()) {
    const auto& p = surface.point(v);
    index[v.idx()] = static_cast<std::uint32_t>(mesh.vertices.size());
    mesh.vertices.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()),
                               static_cast<float>(p.z()));
  }
  const std::vector<Neighbor> nearest = tree.nearest_batch(mesh.vertices);
  std::vector<std::uint8_t> supported(mesh.vertices.size());
  for (std::size_t i = 0; i < nearest.size(); ++i)
    supported[i] = std::sqrt(static_cast<double>(nearest[i].squared_distance)) <= trim;
  if (!colors.empty())
    for (const Neighbor& nb : nearest) mesh.vertex_colors.push_back(colors[nb.index]);
  for (auto f : surface.faces()) {
    std::array<std::uint32_t, 3> t{};
    int k = 0;
    for (auto v : CGAL::vertices_around_face(surface.halfedge(f), surface)) {
      if (k == 3) break;
      t[static_cast<std::size_t>(k++)] = index[v.idx()];
    }
    if (k == 3 && supported[t[0]] && supported[t[1]] && supported[t[2]])
      mesh.triangles.push_back(t);
  }
  remove_unused_vertices(mesh);
  return mesh;
}

CloudMeshingResult mesh_point_cloud(const PointCloud& merged, const CloudMeshingOptions& options) {
  CloudMeshingResult result;
  FilterResult filtered = remove_statistical_outliers(merged, options.outliers);
  result.outliers = filtered.report;
  result.cloud = std::move(filtered.cloud);
  if (result.cloud.size() < 10)
    throw InputError("mesh_point_cloud: fewer than 10 points left after outlier removal");
  NormalOptions normals;
  normals.radius = options.normal_radius;
  normals.max_neighbors = options.normal_max_neighbors;
  normals.viewpoint = options.viewpoint;
  normals.compute_curvature = true;
  estimate_normals(result.cloud, normals);
  result.segmentation = region_growing(result.cloud, options.segmentation);
  attach_segment_labels(result.cloud, result.segmentation);

  if (options.method == CloudSurfaceMethod::Delaunay) {
    result.mesh = advancing_front_mesh(result.cloud, options.advancing_front);
  } else {
    Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
    Eigen::Vector3f hi = -lo;
    for (const Eigen::Vector3f& p : result.cloud.positions) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    const bool inside = (options.viewpoint.array() > lo.array()).all() &&
                        (options.viewpoint.array() < hi.array()).all();
    PointCloud oriented = result.cloud;
    if (inside)
      for (Eigen::Vector3f& n : oriented.normals) n = -n;
    result.mesh = poisson_mesh(oriented, options.poisson);
    if (inside)
      for (auto& t : result.mesh.triangles) std::swap(t[1], t[2]);
  }
  const KdTree tree(result.cloud.positions);
  for (const Neighbor& nb : tree.nearest_batch(result.mesh.vertices))
    result.vertex_segments.push_back(result.segmentation.labels[nb.index]);
  return result;
}

}  // namespace locard
