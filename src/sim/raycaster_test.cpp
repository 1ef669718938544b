// Ray casting: exact z-depth on planes at known distances (every pixel, off-centre included),
// and Embree's hits against a brute-force oracle on the bedroom mesh.
#include <locard/core/raycaster.hpp>
#include <locard/sim/scan_protocol.hpp>
#include <locard/sim/scene_mesh.hpp>
#include <locard/sim/view_renderer.hpp>

#include "sim/sensor_test_util.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

namespace locard::sim {
namespace {

using test::plane_mesh;

// Möller-Trumbore in double: the oracle for Embree.
double brute_force_t(const TriangleMesh& mesh, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& tri : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[tri[0]].cast<double>();
    const Eigen::Vector3d e1 = mesh.vertices[tri[1]].cast<double>() - a;
    const Eigen::Vector3d e2 = mesh.vertices[tri[2]].cast<double>() - a;
    const Eigen::Vector3d p = d.cross(e2);
    const double det = e1.dot(p);
    if (std::abs(det) < 1e-15) continue;
    const Eigen::Vector3d s = o - a;
    const double u = s.dot(p) / det;
    if (u < 0.0 || u > 1.0) continue;
    const Eigen::Vector3d q = s.cross(e1);
    const double v = d.dot(q) / det;
    if (v < 0.0 || u + v > 1.0) continue;
    const double t = e2.dot(q) / det;
    if (t > 0.0) best = std::min(best, t);
  }
  return best;
}

TEST(Raycaster, FrontoParallelPlaneGivesExactDepthAtEveryPixel) {
  // Camera at the origin looking along +z (identity pose), plane z = 2 m.
  const ViewRenderer renderer(plane_mesh({0, 0, 2.0}, {0, 0, -1}, 20.0));
  const KinectV2Model model = KinectV2Model::exact();
  const IdealDepth ideal = renderer.ideal_depth(model, Isometry3d::Identity(), 1, 0);
  const SensorFrame frame = renderer.render(model, Isometry3d::Identity(), 1, 0);
  ASSERT_EQ(frame.depth.width(), 512);
  ASSERT_EQ(frame.depth.height(), 424);
  for (int v = 0; v < 424; ++v) {
    for (int u = 0; u < 512; ++u) {
      // z-depth, not ray length: the corner rays are ~40% longer than 2 m.
      ASSERT_NEAR(ideal.z[static_cast<std::size_t>(v) * 512 + u], 2.0, 1e-6) << u << "," << v;
      ASSERT_EQ(frame.depth.at(u, v), 2000) << u << "," << v;
    }
  }
}

TEST(Raycaster, TiltedPlaneSeenFromTripodPoseMatchesAnalyticDepth) {
  // Tripod camera at 1.2 m looking along +x, pitched 10 degrees down; the plane through
  // (2.5, 0, 1.2) is tilted 40 degrees about the vertical and 15 about y.
  const Isometry3d T_world_camera =
      tripod_pose({0.0, 0.0, 1.2}, 0.0, -10.0 * std::numbers::pi / 180.0);
  const Eigen::Vector3d p0(2.5, 0.0, 1.2);
  const Eigen::Vector3d n =
      (Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(0.26, Eigen::Vector3d::UnitY()) *
       Eigen::Vector3d(-1, 0, 0)).normalized();
  const ViewRenderer renderer(plane_mesh(p0, n, 30.0));
  const KinectV2Model model = KinectV2Model::exact();
  const IdealDepth ideal = renderer.ideal_depth(model, T_world_camera, 1, 0);
  const SensorFrame frame = renderer.render(model, T_world_camera, 1, 0);
  const CameraIntrinsics& K = model.intrinsics;
  int compared = 0;
  for (int v = 0; v < K.height; ++v) {
    for (int u = 0; u < K.width; ++u) {
      const Eigen::Vector3d d = pixel_ray(K, T_world_camera, u, v);
      const double z = n.dot(p0 - T_world_camera.translation()) / n.dot(d);
      const double measured = ideal.z[static_cast<std::size_t>(v) * K.width + u];
      ASSERT_NEAR(measured, z, 2e-6 * z) << u << "," << v;
      if (z < model.min_range_m || z > model.max_range_m) {
        ASSERT_EQ(frame.depth.at(u, v), 0);
        continue;
      }
      // Millimetre raw units: the rounding step is the only error.
      ASSERT_LE(std::abs(frame.depth.at(u, v) - z * 1000.0), 0.5 + 1e-3) << u << "," << v;
      ++compared;
    }
  }
  EXPECT_GT(compared, 512 * 424 / 2);
}

TEST(Raycaster, WallSeenFromRotatedCameraHasConstantZDepth) {
  // Camera turned to yaw 90 degrees faces the wall y = 1.5: every pixel reads 1.5 m.
  const Isometry3d T = tripod_pose({0.0, 0.0, 1.0}, 0.5 * std::numbers::pi, 0.0);
  const ViewRenderer renderer(plane_mesh({0, 1.5, 1.0}, {0, -1, 0}, 20.0));
  const SensorFrame frame = renderer.render(KinectV2Model::exact(), T, 3, 0);
  for (std::uint16_t d : frame.depth.data()) ASSERT_EQ(d, 1500);
}

TEST(Raycaster, MissReturnsNoHitAndDirectionScaleSetsT) {
  const ViewRenderer renderer(plane_mesh({0, 0, 2.0}, {0, 0, -1}, 2.0));
  const Raycaster& rc = renderer.raycaster();
  EXPECT_FALSE(rc.intersect({0, 0, 0}, {0, 0, -1}).hit());
  EXPECT_FALSE(rc.intersect({5, 0, 0}, {0, 0, 1}).hit());  // beside the square
  const RayHit unit = rc.intersect({0, 0, 0}, {0, 0, 1});
  const RayHit half = rc.intersect({0, 0, 0}, {0, 0, 0.5f});
  ASSERT_TRUE(unit.hit());
  EXPECT_FLOAT_EQ(unit.t, 2.0f);
  EXPECT_FLOAT_EQ(half.t, 4.0f);  // t counts direction lengths
  EXPECT_FALSE(rc.intersect({0, 0, 0}, {0, 0, 1}, 0.0f, 1.9f).hit());  // t_far respected
}

TEST(Raycaster, AgreesWithBruteForceOnBedroomMesh) {
  const SceneMesh mesh = build_scene_mesh(builtin_scene("bedroom"));
  const Raycaster rc(mesh.mesh);
  EXPECT_EQ(rc.triangle_count(), mesh.mesh.triangle_count());
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> pos(-1.5, 1.5), height(0.2, 2.4), dir(-1.0, 1.0);
  int hits = 0;
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d o(pos(rng), pos(rng), height(rng));
    Eigen::Vector3d d(dir(rng), dir(rng), dir(rng));
    if (d.norm() < 1e-3) continue;
    d.normalize();
    const double expected = brute_force_t(mesh.mesh, o, d);
    const RayHit hit = rc.intersect(o.cast<float>(), d.cast<float>());
    // Every ray from inside the closed room hits something; starting inside a piece of
    // furniture is allowed (it sees that piece's inner faces).
    ASSERT_TRUE(std::isfinite(expected));
    ASSERT_TRUE(hit.hit());
    ASSERT_NEAR(hit.t, expected, 1e-4) << "ray " << i;
    ++hits;
  }
  EXPECT_GT(hits, 1900);
}

}  // namespace
}  // namespace locard::sim
