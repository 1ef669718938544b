#include <locard/core/error.hpp>
#include <locard/preprocess/depth_to_points.hpp>
#include <locard/preprocess/normals.hpp>
#include <locard/preprocess/voxel_grid.hpp>
#include <locard/sim/scan_simulator.hpp>
#include <locard/sim/scene.hpp>
#include <locard/surface/point_cloud_meshing.hpp>
#include <locard/surface/segmentation.hpp>

#include <gtest/gtest.h>

#include <functional>
#include <map>
#include <set>

namespace locard {
namespace {

// The simulated bedroom seen from its tripod (noisy Kinect v2), merged at the exact poses and
// averaged on a 2 cm grid, with normals and curvature.
PointCloud bedroom_cloud() {
  sim::Scene scene = sim::builtin_scene("bedroom");
  scene.scanner.set_rings(16, {-10.0});  // one ring, as the bedroom had before its downward ring
  const sim::ScanSimulator simulator(scene);
  PointCloud merged;
  DepthToPointsOptions options;
  options.min_depth_m = 0.5;
  options.max_depth_m = 4.5;
  for (std::size_t i = 0; i < simulator.view_count(); ++i) {
    merged.append(depth_to_points(simulator.render_frame(i), options,
                                  simulator.trajectory()[i].T_world_camera));
  }
  PointCloud cloud = voxel_down_sample(merged, 0.02f).cloud;
  NormalOptions normals;
  normals.radius = 0.06f;
  normals.max_neighbors = 40;
  normals.viewpoint = Eigen::Vector3f(0.f, 0.f, 1.2f);
  normals.compute_curvature = true;
  estimate_normals(cloud, normals);
  return cloud;
}

// The label most points of a selection carry, and the share of the selection it covers.
std::pair<std::int32_t, double> dominant(const PointCloud& cloud, const Segmentation& s,
                                         const std::function<bool(const Eigen::Vector3f&)>& in) {
  std::map<std::int32_t, std::size_t> count;
  std::size_t total = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (in(cloud.positions[i])) {
      ++count[s.labels[i]];
      ++total;
    }
  if (total == 0) return {-2, 0.0};
  auto best = std::max_element(count.begin(), count.end(),
                               [](auto& a, auto& b) { return a.second < b.second; });
  return {best->first, static_cast<double>(best->second) / static_cast<double>(total)};
}

TEST(RegionGrowing, FloorWallsAndFurnitureFacesOfTheBedroomAreSeparateSegments) {
  const PointCloud cloud = bedroom_cloud();
  RegionGrowingOptions options;
  options.radius = 0.05f;
  options.max_angle_deg = 10.0;
  options.max_curvature = 0.03;
  options.min_points = 30;
  const Segmentation s = region_growing(cloud, options);
  ASSERT_EQ(s.labels.size(), cloud.size());
  ASSERT_GE(s.sizes.size(), 6u);

  using P = const Eigen::Vector3f&;
  const std::map<std::string, std::function<bool(P)>> parts = {
      // The sensor looks 10 degrees down from 1.2 m: the floor shows from about 1.4 m out.
      {"floor", [](P p) { return std::abs(p.z()) < 0.02f && p.x() > -0.6f && p.x() < 0.3f &&
                                 p.y() > -1.9f && p.y() < -1.5f; }},
      {"wall +x", [](P p) { return p.x() > 1.89f && std::abs(p.y()) < 0.4f && p.z() > 0.8f &&
                                   p.z() < 2.2f; }},
      {"wall -y", [](P p) { return p.y() < -1.97f && p.x() > -0.6f && p.x() < 0.3f &&
                                   p.z() > 1.0f && p.z() < 2.2f; }},
      {"wall -x", [](P p) { return p.x() < -1.89f && p.y() > -0.6f && p.y() < 0.5f &&
                                   p.z() > 0.8f && p.z() < 2.2f; }},
      {"bed top", [](P p) { return std::abs(p.z() - 0.5f) < 0.02f && p.x() > 1.05f &&
                                   p.x() < 1.85f && p.y() > -1.3f && p.y() < 0.0f; }},
      {"cupboard door", [](P p) { return std::abs(p.y() - 1.38f) < 0.02f && p.x() > 0.3f &&
                                         p.x() < 0.85f && p.z() > 0.4f && p.z() < 1.6f; }},
  };
  std::set<std::int32_t> labels;
  for (const auto& [name, in] : parts) {
    const auto [label, share] = dominant(cloud, s, in);
    EXPECT_GE(label, 0) << name;
    EXPECT_GT(share, 0.8) << name << " is split or unlabelled";
    labels.insert(label);
  }
  EXPECT_EQ(labels.size(), parts.size()) << "two parts merged into one segment";

  PointCloud labelled = cloud;
  attach_segment_labels(labelled, s);
  ASSERT_NE(labelled.find_scalar("segment"), nullptr);
  EXPECT_EQ(labelled.find_scalar("segment")->values.size(), cloud.size());
}

TEST(RegionGrowing, NeedsNormalsAndCurvature) {
  PointCloud cloud;
  cloud.positions = {{0, 0, 0}, {1, 0, 0}};
  EXPECT_THROW(region_growing(cloud), InputError);
  cloud.normals = {{0, 0, 1}, {0, 0, 1}};
  EXPECT_THROW(region_growing(cloud), InputError);
}

TEST(AdvancingFront, SphereSamplesGiveAClosedSurfaceOnTheSphereWithColours) {
  PointCloud cloud;
  const int n = 40;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < 2 * n; ++j) {
      // Fibonacci-like even sampling on a unit sphere of radius 0.3.
      const double k = i * 2 * n + j + 0.5, total = 2.0 * n * n;
      const double z = 1.0 - 2.0 * k / total, r = std::sqrt(1.0 - z * z);
      const double phi = k * M_PI * (3.0 - std::sqrt(5.0));
      const Eigen::Vector3f p(static_cast<float>(r * std::cos(phi)),
                              static_cast<float>(r * std::sin(phi)), static_cast<float>(z));
      cloud.positions.push_back(0.3f * p);
      cloud.normals.push_back(p);
      cloud.colors.push_back({static_cast<std::uint8_t>(z > 0 ? 255 : 0), 10, 10});
    }
  const TriangleMesh mesh = advancing_front_mesh(cloud);
  EXPECT_GT(mesh.vertex_count(), cloud.size() * 95 / 100);
  EXPECT_NEAR(static_cast<double>(mesh.triangle_count()), 2.0 * mesh.vertex_count() - 4.0,
              0.02 * mesh.vertex_count());  // closed genus-0 surface: F = 2V - 4
  ASSERT_EQ(mesh.vertex_colors.size(), mesh.vertex_count());
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    EXPECT_NEAR(mesh.vertices[v].norm(), 0.3f, 1e-5f);
    EXPECT_EQ(mesh.vertex_colors[v].r, mesh.vertices[v].z() > 0 ? 255 : 0);
  }
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3f a = mesh.vertices[t[0]], b = mesh.vertices[t[1]], c = mesh.vertices[t[2]];
    ASSERT_GT((b - a).cross(c - a).dot(a + b + c), 0.f) << "facet not oriented along normals";
  }
}

}  // namespace
}  // namespace locard
