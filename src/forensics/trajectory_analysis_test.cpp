// Bullet trajectories on the simulated bedroom's exact mesh: a line through two known points
// meets the walls at the analytic points, with the analytic angles.
#include <locard/forensics/trajectory_analysis.hpp>

#include <locard/core/error.hpp>
#include <locard/sim/scene.hpp>
#include <locard/sim/scene_mesh.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <unistd.h>

namespace locard::forensics {
namespace {

using Eigen::Vector3d;

const TriangleMesh& bedroom() {
  static const TriangleMesh mesh = sim::build_scene_mesh(sim::builtin_scene("bedroom")).mesh;
  return mesh;
}

TEST(TrajectoryAnalysis, TwoPointsHitTheKnownWallsAtTheAnalyticPoints) {
  TrajectoryInput in;
  in.name = "shot 1";
  in.points = {Vector3d(0.0, 0.0, 1.2), Vector3d(0.4, 0.05, 1.25)};
  in.point_sigma_m = 0.002;
  const TrajectoryAnalysis a = analyse_trajectory(bedroom(), in);
  const double deg = 180.0 / M_PI;
  EXPECT_NEAR(a.horizontal_angle_deg, std::atan2(0.05, 0.4) * deg, 1e-9);
  EXPECT_NEAR(a.vertical_angle_deg, std::asin(0.05 / std::sqrt(0.4 * 0.4 + 2 * 0.05 * 0.05)) * deg, 1e-9);
  // The east wall x = 1.92: s = 1.92 / 0.4 along (0.4, 0.05, 0.05) from the first point.
  ASSERT_TRUE(a.forward.hit);
  EXPECT_NEAR(a.forward.point.x(), 1.92, 1e-5);
  EXPECT_NEAR(a.forward.point.y(), 0.24, 1e-5);
  EXPECT_NEAR(a.forward.point.z(), 1.44, 1e-5);
  EXPECT_NEAR(a.forward.normal.x(), -1.0, 1e-6);  // facing the incoming line
  EXPECT_NEAR(a.forward.distance_m, (Vector3d(1.92, 0.24, 1.44) - in.points[1]).norm(), 1e-5);
  EXPECT_NEAR(a.forward.incidence_deg, std::acos(0.4 / std::sqrt(0.165)) * deg, 1e-4);
  // The west wall x = -1.92, behind the first point.
  ASSERT_TRUE(a.backward.hit);
  EXPECT_NEAR(a.backward.point.x(), -1.92, 1e-5);
  EXPECT_NEAR(a.backward.point.y(), -0.24, 1e-5);
  EXPECT_NEAR(a.backward.point.z(), 0.96, 1e-5);
  // Error cone: sqrt(2) sigma / L, doubled; the radius grows with the distance.
  const double L = (in.points[1] - in.points[0]).norm();
  EXPECT_NEAR(a.cone_half_angle_deg, 2.0 * std::sqrt(2.0) * 0.002 / L * deg, 1e-9);
  EXPECT_NEAR(a.forward.cone_radius_m,
              a.forward.distance_m * std::tan(a.cone_half_angle_deg / deg) + 2 * 0.002, 1e-9);
}

TEST(TrajectoryAnalysis, RodFitRecoversTheLineAndSkipsTheHolesThemselves) {
  // Entry and exit holes on the cupboard door's front face (y = 1.38) would be met again at
  // once; min_gap keeps the line going. Points along a rod, slightly scattered.
  TrajectoryInput in;
  in.name = "rod";
  const Vector3d start(-0.5, -0.5, 1.0), dir = Vector3d(0.3, 1.0, -0.1).normalized();
  for (int i = 0; i < 5; ++i) {
    const double jitter = (i % 2 ? 1 : -1) * 0.001;
    in.points.push_back(start + 0.2 * i * dir + Vector3d(jitter, 0, -jitter));
  }
  in.point_sigma_m = 0.001;
  const TrajectoryAnalysis a = analyse_trajectory(bedroom(), in);
  EXPECT_GT(a.direction.dot(dir), std::cos(0.5 * M_PI / 180.0));
  EXPECT_GT(a.fit_rms_m, 0.0);
  EXPECT_LT(a.fit_rms_m, 0.002);
  EXPECT_TRUE(a.forward.hit);
  EXPECT_TRUE(a.backward.hit);
  EXPECT_GT(a.forward.distance_m, in.min_gap_m);
}

TEST(TrajectoryAnalysis, BadInput) {
  TrajectoryInput in;
  in.points = {Vector3d(0, 0, 1)};
  in.point_sigma_m = 0.001;
  EXPECT_THROW(analyse_trajectory(bedroom(), in), InputError);
  in.points = {Vector3d(0, 0, 1), Vector3d(0, 0, 1)};
  EXPECT_THROW(analyse_trajectory(bedroom(), in), InputError);
  in.points = {Vector3d(0, 0, 1), Vector3d(0, 0, NAN)};
  EXPECT_THROW(analyse_trajectory(bedroom(), in), InputError);
  in.points = {Vector3d(0, 0, 1), Vector3d(1, 0, 1)};
  in.point_sigma_m = 0.0;  // no model to derive it from
  EXPECT_THROW(analyse_trajectory(nullptr, in), InputError);
}

TEST(TrajectoryAnalysis, JsonRoundTrip) {
  TrajectoryInput in;
  in.name = "shot";
  in.points = {Vector3d(0.0, 0.0, 1.2), Vector3d(0.4, 0.05, 1.25)};
  in.point_sigma_m = 0.002;
  const TrajectoryAnalysis a = analyse_trajectory(bedroom(), in);
  const std::filesystem::path p = std::filesystem::temp_directory_path() /
                                  ("locard-traj-" + std::to_string(::getpid()) + ".json");
  { std::ofstream(p) << trajectory_analyses_json({a}); }
  const auto back = read_trajectory_analyses(p);
  std::filesystem::remove(p);
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(back[0].name, "shot");
  EXPECT_NEAR((back[0].forward.point - a.forward.point).norm(), 0.0, 1e-9);
  EXPECT_NEAR(back[0].vertical_angle_deg, a.vertical_angle_deg, 1e-12);
}

}  // namespace
}  // namespace locard::forensics
