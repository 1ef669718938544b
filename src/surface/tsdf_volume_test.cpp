#include <locard/core/error.hpp>
#include <locard/surface/tsdf_volume.hpp>

#include "surface/marching_cubes_cases.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <map>
#include <random>
#include <utility>

namespace locard {
namespace {

// Every undirected edge is used by exactly two triangles, in opposite directions: the mesh is
// closed and consistently oriented.
void expect_closed_and_oriented(const TriangleMesh& mesh) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  for (const auto& t : mesh.triangles)
    for (int j = 0; j < 3; ++j) ++directed[{t[j], t[(j + 1) % 3]}];
  std::size_t open = 0, duplicated = 0;
  for (const auto& [edge, count] : directed) {
    if (count != 1) ++duplicated;
    if (!directed.count({edge.second, edge.first})) ++open;
  }
  EXPECT_EQ(open, 0u) << "boundary edges";
  EXPECT_EQ(duplicated, 0u) << "edges used twice in the same direction";
}

TEST(MarchingCubesCases, TrianglesUseOnlyCrossedEdgesAndEveryCrossedEdge) {
  const auto& cases = detail::marching_cubes_cases();
  for (int index = 0; index < 256; ++index) {
    std::array<int, 12> uses{};
    for (int t = 0; t < cases[index].triangle_count; ++t)
      for (int e : cases[index].triangles[t]) ++uses[e];
    for (int e = 0; e < 12; ++e) {
      const int lo = detail::edge_low_corner(e);
      const int hi = lo | (1 << detail::edge_axis(e));
      const bool crossed = ((index >> lo) & 1) != ((index >> hi) & 1);
      EXPECT_EQ(crossed, uses[e] > 0) << "case " << index << " edge " << e;
    }
  }
  EXPECT_EQ(cases[0].triangle_count, 0);
  EXPECT_EQ(cases[255].triangle_count, 0);
  EXPECT_EQ(cases[1].triangle_count, 1);
}

TEST(TsdfVolume, RejectsBadOptions) {
  EXPECT_THROW(TsdfVolume({.voxel_size = 0.0}), InputError);
  EXPECT_THROW(TsdfVolume({.voxel_size = 0.01, .truncation = 0.005}), InputError);
  EXPECT_THROW(TsdfVolume({.voxel_size = 0.01, .truncation = 0.04, .max_depth_m = 0.0}),
               InputError);
}

// A sphere written straight into the voxels: the mesh is closed, oriented outwards and lies on
// the sphere; the Euler characteristic is 2.
TEST(TsdfVolume, SphereIsClosedOrientedAndAccurate) {
  const double voxel = 0.01, trunc = 0.04, radius = 0.137;
  TsdfVolume volume({.voxel_size = voxel, .truncation = trunc});
  const Eigen::Vector3d centre(0.013, -0.021, 0.5);  // blocks on both sides of zero
  for (int z = 30; z < 70; ++z)
    for (int y = -20 - 2; y < 20; ++y)
      for (int x = -20; x < 20; ++x) {
        const Eigen::Vector3i g(x, y, z);
        const double d = (volume.voxel_center(g) - centre).norm() - radius;
        const float tsdf = static_cast<float>(std::clamp(d / trunc, -1.0, 1.0));
        volume.set_voxel(g, {tsdf, 1.f, Rgb8{200, 10, 10}, 0});
      }
  const TriangleMesh mesh = volume.extract_mesh();
  ASSERT_GT(mesh.triangle_count(), 1000u);
  expect_closed_and_oriented(mesh);
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;
  for (const auto& t : mesh.triangles)
    for (int j = 0; j < 3; ++j) edges[std::minmax(t[j], t[(j + 1) % 3])] = 1;
  EXPECT_EQ(static_cast<long>(mesh.vertex_count()) - static_cast<long>(edges.size()) +
                static_cast<long>(mesh.triangle_count()),
            2);
  double worst = 0.0;
  for (const auto& v : mesh.vertices)
    worst = std::max(worst, std::abs((v.cast<double>() - centre).norm() - radius));
  EXPECT_LT(worst, 0.1 * voxel);  // linear interpolation of an exact distance field
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3f a = mesh.vertices[t[0]], b = mesh.vertices[t[1]],
                          c = mesh.vertices[t[2]];
    const Eigen::Vector3f n = (b - a).cross(c - a);
    ASSERT_GT(n.dot((a + b + c) / 3.f - centre.cast<float>()), 0.f) << "inward triangle";
  }
  ASSERT_EQ(mesh.vertex_colors.size(), mesh.vertex_count());
  EXPECT_EQ(mesh.vertex_colors[0], (Rgb8{200, 10, 10}));
}

// Random signs in a box with positive walls: every ambiguous face and cube configuration
// occurs; the result must still be closed (no cracks between neighbouring cubes or blocks).
TEST(TsdfVolume, RandomFieldGivesCrackFreeSurfaces) {
  TsdfVolume volume({.voxel_size = 0.01, .truncation = 0.04});
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> value(-1.f, 1.f);
  const int n = 20;
  for (int z = -2; z < n; ++z)
    for (int y = -2; y < n; ++y)
      for (int x = -2; x < n; ++x) {
        const bool wall = x < 0 || y < 0 || z < 0 || x >= n - 2 || y >= n - 2 || z >= n - 2;
        volume.set_voxel({x, y, z}, {wall ? 1.f : value(rng), 1.f, Rgb8{}, 0});
      }
  const TriangleMesh mesh = volume.extract_mesh();
  ASSERT_GT(mesh.triangle_count(), 1000u);
  expect_closed_and_oriented(mesh);
}

// Renders the depth of a plane z_world = 0 seen from above, plus a colour ramp.
RgbdFrame plane_frame(const Isometry3d& T_world_camera, int width, int height) {
  RgbdFrame frame;
  frame.intrinsics.width = width;
  frame.intrinsics.height = height;
  frame.intrinsics.fx = frame.intrinsics.fy = 300.0;
  frame.intrinsics.cx = width / 2.0 - 0.5;
  frame.intrinsics.cy = height / 2.0 - 0.5;
  frame.depth = DepthImage(width, height);
  frame.color = ColorImage(width, height);
  frame.depth_scale = 1000.0;
  const Eigen::Vector3d o = T_world_camera.translation();
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) {
      const Eigen::Vector3d ray_c((u - frame.intrinsics.cx) / 300.0,
                                  (v - frame.intrinsics.cy) / 300.0, 1.0);
      const Eigen::Vector3d ray_w = T_world_camera.linear() * ray_c;
      if (ray_w.z() >= -1e-6) continue;
      const double s = -o.z() / ray_w.z();  // ray parameter where z_world = 0; s = z_camera
      frame.depth.at(u, v) = static_cast<std::uint16_t>(std::lround(s * 1000.0));
      const Eigen::Vector3d p = o + s * ray_w;
      frame.color.at(u, v, 0) = p.x() > 0.0 ? 250 : 20;
      frame.color.at(u, v, 1) = 100;
      frame.color.at(u, v, 2) = 50;
    }
  return frame;
}

TEST(TsdfVolume, FusedPlaneFromSeveralPosesLiesOnThePlaneWithItsColours) {
  TsdfVolume volume({.voxel_size = 0.01, .truncation = 0.04, .max_depth_m = 3.0});
  for (int i = 0; i < 3; ++i) {
    Isometry3d T_world_camera = Isometry3d::Identity();
    // Camera looking down (-z world): flip y and z.
    T_world_camera.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix() *
                              Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d::UnitY()).toRotationMatrix();
    T_world_camera.translation() = Eigen::Vector3d(0.05 * i, -0.03 * i, 1.0 + 0.1 * i);
    volume.integrate(plane_frame(T_world_camera, 160, 120), T_world_camera);
  }
  EXPECT_EQ(volume.stats().frames, 3u);
  const TriangleMesh mesh = volume.extract_mesh();
  ASSERT_GT(mesh.triangle_count(), 1000u);
  std::size_t far_from_edge = 0;
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i) {
    const Eigen::Vector3f& p = mesh.vertices[i];
    EXPECT_LT(std::abs(p.z()), 0.002f);  // depth quantised to 1 mm
    if (std::abs(p.x()) > 0.05f && std::abs(p.x()) < 0.4f && std::abs(p.y()) < 0.3f) {
      ++far_from_edge;
      EXPECT_EQ(mesh.vertex_colors[i].r, p.x() > 0.f ? 250 : 20);
      EXPECT_EQ(mesh.vertex_colors[i].g, 100);
    }
  }
  EXPECT_GT(far_from_edge, 100u);
  // Normals point up, towards the cameras (the free side).
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3f n = (mesh.vertices[t[1]] - mesh.vertices[t[0]])
                                  .cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
    ASSERT_GT(n.z(), 0.f);
  }
}

TEST(TsdfVolume, SameMeshForAnyThreadCount) {
  auto run = [] {
    TsdfVolume volume({.voxel_size = 0.008, .truncation = 0.03});
    Isometry3d T = Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(M_PI - 0.3, Eigen::Vector3d::UnitX()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(0.0, 0.0, 0.8);
    volume.integrate(plane_frame(T, 120, 90), T);
    return volume.extract_mesh();
  };
  const TriangleMesh parallel = run();
  TriangleMesh serial;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    serial = run();
  }
  EXPECT_EQ(parallel.vertices, serial.vertices);
  EXPECT_EQ(parallel.vertex_colors, serial.vertex_colors);
  EXPECT_EQ(parallel.triangles, serial.triangles);
}

}  // namespace
}  // namespace locard
