// The tripod scan: pose conventions, yaw spacing and seeded jitter, and the ground-truth poses
// re-projecting known scene points to the right pixel (with the right depth) in every view
// that sees them.
#include <locard/sim/scan_protocol.hpp>

#include <locard/sim/scan_simulator.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>

namespace locard::sim {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

double wrap_deg(double a) {
  while (a > 180.0) a -= 360.0;
  while (a <= -180.0) a += 360.0;
  return a;
}

double yaw_of(const Isometry3d& T) {
  const Eigen::Vector3d f = T.linear().col(2);
  return std::atan2(f.y(), f.x()) / kDeg;
}

TEST(ScanProtocol, TripodPoseAxes) {
  for (double yaw : {0.0, 30.0, 90.0, 200.0, -45.0}) {
    for (double pitch : {-30.0, -10.0, 0.0, 25.0}) {
      const Isometry3d T = tripod_pose({0.5, -0.2, 1.3}, yaw * kDeg, pitch * kDeg);
      const Eigen::Matrix3d R = T.linear();
      EXPECT_TRUE((R.transpose() * R).isIdentity(1e-12));
      EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
      const Eigen::Vector3d forward(std::cos(yaw * kDeg) * std::cos(pitch * kDeg),
                                    std::sin(yaw * kDeg) * std::cos(pitch * kDeg), std::sin(pitch * kDeg));
      EXPECT_TRUE(R.col(2).isApprox(forward, 1e-12));
      EXPECT_NEAR(R.col(0).z(), 0.0, 1e-12);   // level horizon: x (right) is horizontal
      EXPECT_LE(R.col(1).z(), 1e-12);          // y points down
      EXPECT_TRUE(T.translation().isApprox(Eigen::Vector3d(0.5, -0.2, 1.3)));
    }
  }
  // Looking along +x, the camera's right is world -y and its down is world -z.
  const Isometry3d T0 = tripod_pose(Eigen::Vector3d::Zero(), 0.0, 0.0);
  EXPECT_TRUE(T0.linear().col(0).isApprox(Eigen::Vector3d(0, -1, 0)));
  EXPECT_TRUE(T0.linear().col(1).isApprox(Eigen::Vector3d(0, 0, -1)));
  // A point 2 m ahead and 1 m up projects above the image centre (smaller v).
  const Eigen::Vector3d q = T0.inverse() * Eigen::Vector3d(2, 0, 1);
  EXPECT_NEAR(q.z(), 2.0, 1e-12);
  EXPECT_NEAR(q.y(), -1.0, 1e-12);
}

TEST(ScanProtocol, ViewsEvenlySpacedPerPitchRowWithSeededJitter) {
  ScannerSpec spec;
  spec.views = 50;
  spec.pitch_deg = {-10.0, 15.0};
  spec.yaw_jitter_deg = 0.0;
  spec.position_jitter_m = 0.0;
  const Trajectory exact = tripod_scan_trajectory(spec);
  ASSERT_EQ(exact.size(), 100u);
  for (std::size_t i = 0; i < exact.size(); ++i) {
    EXPECT_EQ(exact[i].frame_index, static_cast<std::int64_t>(i));
    EXPECT_NEAR(exact[i].timestamp, i / 30.0, 0.5e-6);
    const double expected_yaw = 360.0 * (i % 50) / 50.0;
    EXPECT_NEAR(wrap_deg(yaw_of(exact[i].T_world_camera) - expected_yaw), 0.0, 1e-9);
    const double pitch = std::asin(exact[i].T_world_camera.linear()(2, 2)) / kDeg;
    EXPECT_NEAR(pitch, i < 50 ? -10.0 : 15.0, 1e-9);
    EXPECT_TRUE(exact[i].T_world_camera.translation().isApprox(spec.position));
  }

  spec.yaw_jitter_deg = 1.0;
  spec.position_jitter_m = 0.005;
  spec.views = 2000;  // many draws: jitter statistics
  spec.pitch_deg = {0.0};
  const Trajectory jittered = tripod_scan_trajectory(spec);
  double yaw2 = 0.0, pos2 = 0.0;
  for (std::size_t i = 0; i < jittered.size(); ++i) {
    const double d = wrap_deg(yaw_of(jittered[i].T_world_camera) - 360.0 * i / 2000.0);
    yaw2 += d * d;
    pos2 += (jittered[i].T_world_camera.translation() - spec.position).squaredNorm() / 3.0;
  }
  EXPECT_NEAR(std::sqrt(yaw2 / 2000), 1.0, 0.1);
  EXPECT_NEAR(std::sqrt(pos2 / 2000), 0.005, 0.0005);

  // Same seed, same poses bit for bit; another seed, other poses.
  const Trajectory again = tripod_scan_trajectory(spec);
  for (std::size_t i = 0; i < again.size(); ++i)
    ASSERT_TRUE(again[i].T_world_camera.matrix() == jittered[i].T_world_camera.matrix());
  spec.seed = 2;
  EXPECT_FALSE(tripod_scan_trajectory(spec)[0].T_world_camera.matrix() ==
               jittered[0].T_world_camera.matrix());
}

// A ring of its own size: 12 views at -50 degrees after 30 level ones, each ring evenly spaced.
TEST(ScanProtocol, RingsOfTheirOwnSizes) {
  ScannerSpec spec;
  spec.ring_views = {30, 12};
  spec.pitch_deg = {0.0, -50.0};
  spec.yaw_jitter_deg = 0.0;
  spec.position_jitter_m = 0.0;
  const Trajectory t = tripod_scan_trajectory(spec);
  ASSERT_EQ(t.size(), 42u);
  for (std::size_t i = 0; i < t.size(); ++i) {
    const bool down = i >= 30;
    const double expected_yaw = down ? 360.0 * (i - 30) / 12.0 : 360.0 * i / 30.0;
    EXPECT_NEAR(wrap_deg(yaw_of(t[i].T_world_camera) - expected_yaw), 0.0, 1e-9) << i;
    const double pitch = std::asin(t[i].T_world_camera.linear()(2, 2)) / kDeg;
    EXPECT_NEAR(pitch, down ? -50.0 : 0.0, 1e-9) << i;
  }
}

// Points on known planes of the bedroom: the plane is what the pixel's ray must hit.
struct KnownPoint {
  const char* name;
  Eigen::Vector3d p;
  Eigen::Vector3d plane_normal;
};

TEST(ScanProtocol, GroundTruthPosesReprojectKnownPointsInEveryViewThatSeesThem) {
  Scene scene = builtin_scene("bedroom");
  scene.scanner.noise = false;
  const ScanSimulator sim(scene);
  const CameraIntrinsics& K = sim.model().intrinsics;
  const std::vector<KnownPoint> points = {
      {"bed top, 3 cm from its corner", {0.98, 0.09, 0.50}, {0, 0, 1}},
      {"electric socket face", {0.0, -1.99, 0.39}, {0, 1, 0}},
      {"window", {1.89, 1.0, 1.5}, {-1, 0, 0}},
      {"cupboard door", {0.6, 1.38, 1.2}, {0, -1, 0}},
      {"entrance door", {-1.89, 1.0, 1.6}, {1, 0, 0}},
  };
  std::map<std::size_t, SensorFrame> rendered;
  for (const KnownPoint& known : points) {
    int visible = 0;
    for (std::size_t view = 0; view < sim.view_count(); ++view) {
      const Isometry3d& T_world_camera = sim.trajectory()[view].T_world_camera;
      const Eigen::Vector3d q = T_world_camera.inverse() * known.p;
      if (q.z() < 0.5 || q.z() > 4.5) continue;
      const double u = K.fx * q.x() / q.z() + K.cx;
      const double v = K.fy * q.y() / q.z() + K.cy;
      const int ui = static_cast<int>(std::lround(u)), vi = static_cast<int>(std::lround(v));
      if (ui < 0 || vi < 0 || ui >= K.width || vi >= K.height) continue;
      // Unoccluded: the ray from the camera reaches the point itself.
      const Eigen::Vector3d o = T_world_camera.translation();
      const RayHit hit = sim.renderer().raycaster().intersect(o.cast<float>(), (known.p - o).cast<float>());
      if (!hit.hit() || std::abs(hit.t - 1.0) * (known.p - o).norm() > 1e-3) continue;
      ++visible;
      auto it = rendered.find(view);
      if (it == rendered.end()) it = rendered.emplace(view, sim.render(view)).first;
      const DepthImage& depth = it->second.depth;
      // The pixel centre's ray meets the point's plane at this z-depth.
      const Eigen::Vector3d d = pixel_ray(K, T_world_camera, ui, vi);
      const double z = known.plane_normal.dot(known.p - o) / known.plane_normal.dot(d);
      ASSERT_NEAR(depth.at(ui, vi), 1000.0 * z, 0.5 + 1e-3) << known.name << " view " << view;
      // And back-projecting that pixel with the pose lands next to the point: half a pixel
      // of rounding, stretched by the slant of the surface.
      const Eigen::Vector3d back = T_world_camera * Eigen::Vector3d((ui - K.cx) / K.fx * depth.at(ui, vi) / 1000.0,
                                                                    (vi - K.cy) / K.fy * depth.at(ui, vi) / 1000.0,
                                                                    depth.at(ui, vi) / 1000.0);
      EXPECT_LT((back - known.p).norm(), 3.0 * q.z() / K.fx + 1e-3) << known.name << " view " << view;
    }
    // A 50-view turn with 70 degrees of field of view sees every point in several views.
    EXPECT_GE(visible, 5) << known.name;
  }
}

}  // namespace
}  // namespace locard::sim
