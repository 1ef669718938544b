// Floor coverage on simulated tripod scans of the built-in bedroom (floor at z = 0, camera 1.2 m
// over it, Kinect v2 depth: 60 degree vertical field), at the simulator's exact poses. The
// oracle is the camera's geometry: a ring pitched p degrees sees the floor from h / tan(30 - p)
// out, so one ring at -10 degrees leaves a disc of 1.2 / tan(40) = 1.43 m unseen (less the
// tripod's yaw and position jitter), and a second ring at -50 shrinks it to the tripod's foot.
#include <locard/forensics/floor_coverage.hpp>

#include <locard/sim/scan_writer.hpp>
#include <locard/sim/scene.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>

namespace locard::forensics {
namespace {

namespace fs = std::filesystem;

// The sanitizer pass (CI's second, near its time budget) skips the tests that simulate a
// second scan; the coverage code runs under it in the others.
using test::kSanitized;

RgbdSequence bedroom_scan(const std::string& name, std::vector<double> pitch_deg) {
  sim::Scene scene = sim::builtin_scene("bedroom");
  scene.scanner.set_rings(24, std::move(pitch_deg));
  const fs::path folder = test::scratch_dir() / name;
  sim::write_simulated_scan(scene, folder);
  return open_rgbd_sequence(folder);
}

std::vector<std::optional<Isometry3d>> true_poses(const RgbdSequence& seq) {
  std::vector<std::optional<Isometry3d>> poses;
  for (const StampedPose& p : seq.ground_truth) poses.push_back(p.T_world_camera);
  return poses;
}

double lowest_ray_reach(double height, double pitch_deg, double vfov_deg) {
  return height / std::tan((vfov_deg / 2 - pitch_deg) * M_PI / 180.0);
}

TEST(FloorCoverage, OneRingLeavesTheDiscUnderTheTripodAndAsksForADownwardRing) {
  const RgbdSequence seq = bedroom_scan("coverage-one-ring", {-10.0});
  ASSERT_EQ(seq.traits.capture, CaptureKind::TripodTurn);
  const FloorCoverage c = compute_floor_coverage(seq, true_poses(seq), 0.0);
  const double vfov = 2.0 * std::atan2(0.5 * seq.intrinsics.height, seq.intrinsics.fy) * 180 / M_PI;
  const double expected = lowest_ray_reach(1.2, -10.0, vfov);
  EXPECT_NEAR(c.unseen_radius_m, expected, 0.15) << "analytic " << expected;
  ASSERT_TRUE(c.advised_pitch_deg.has_value());
  // The advised ring reaches the floor within the tripod's foot: h / tan(vfov/2 - p) <= 0.3 m.
  EXPECT_LE(lowest_ray_reach(1.2, *c.advised_pitch_deg, vfov), 0.3 + 1e-9);
  EXPECT_GE(*c.advised_pitch_deg, -60.0);
  ASSERT_FALSE(c.advice.empty());
  EXPECT_NE(c.advice.front().find("add a ring at pitch"), std::string::npos) << c.advice.front();
  // The room is 4 x 4 m less its furniture's footprint: most of the floor area is accounted for.
  EXPECT_NEAR(c.seen_m2 + c.hidden_m2 + c.unseen_m2, 15.0, 2.5);
  EXPECT_GT(c.unseen_m2, M_PI * 1.2 * 1.2);
  EXPECT_GT(c.hidden_m2, 0.5) << "under the bed, the table";
}

TEST(FloorCoverage, ADownwardRingCoversTheDisc) {
  if (kSanitized) GTEST_SKIP() << "two scans: release builds only";
  // (each scratch_dir() call starts a fresh folder: the first scan is used before the second)
  const RgbdSequence one = bedroom_scan("coverage-ring-a", {-10.0});
  const FloorCoverage before = compute_floor_coverage(one, true_poses(one), 0.0);
  const RgbdSequence two = bedroom_scan("coverage-ring-b", {-10.0, -50.0});
  const FloorCoverage after = compute_floor_coverage(two, true_poses(two), 0.0);
  EXPECT_LT(after.unseen_radius_m, 0.45);
  EXPECT_LT(after.unseen_m2, 0.25 * before.unseen_m2);
  EXPECT_GT(after.seen_share(), before.seen_share() + 0.2);
  for (const std::string& line : after.advice)
    EXPECT_EQ(line.find("add a ring"), std::string::npos) << line;
}

// Flagged views are left out: a scan whose downward ring is all flagged covers no more floor
// than the ring alone.
TEST(FloorCoverage, OnlyPlacedViewsCount) {
  if (kSanitized) GTEST_SKIP() << "a two-ring scan: release builds only";
  const RgbdSequence two = bedroom_scan("coverage-ring-c", {-10.0, -50.0});
  std::vector<std::optional<Isometry3d>> poses = true_poses(two);
  for (std::size_t i = 24; i < poses.size(); ++i) poses[i].reset();
  const FloorCoverage c = compute_floor_coverage(two, poses, 0.0);
  EXPECT_EQ(c.views_used, 24u);
  EXPECT_GT(c.unseen_radius_m, 1.2);
}

TEST(FloorCoverage, FloorHeightFromPoints) {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 60; ++j) {
      points.emplace_back(0.05 * i, 0.05 * j, -0.72 + 0.001 * ((i * 7 + j * 3) % 5 - 2));
      points.emplace_back(0.05 * i, 0.0, -0.72 + 0.04 * j);  // a wall
    }
  const std::optional<double> z = floor_height(points);
  ASSERT_TRUE(z.has_value());
  EXPECT_NEAR(*z, -0.72, 0.003);
}

TEST(FloorCoverage, JsonHoldsTheGridAndTheAdvice) {
  const RgbdSequence seq = bedroom_scan("coverage-json", {-10.0});
  const FloorCoverage c = compute_floor_coverage(seq, true_poses(seq), 0.0);
  const auto j = nlohmann::json::parse(floor_coverage_json(c));
  ASSERT_EQ(j["rows"].size(), static_cast<std::size_t>(c.ny));
  EXPECT_EQ(j["rows"][0].get<std::string>().size(), static_cast<std::size_t>(c.nx));
  std::size_t unseen = 0;
  for (const auto& row : j["rows"])
    for (char ch : row.get<std::string>()) unseen += ch == 'u';
  EXPECT_NEAR(static_cast<double>(unseen) * c.cell_m * c.cell_m, j["area_m2"]["unseen"].get<double>(), 1e-9);
  EXPECT_EQ(j["advice"].size(), c.advice.size());
  EXPECT_NEAR(j["tripod"]["unseen_radius_m"].get<double>(), c.unseen_radius_m, 1e-12);
}

}  // namespace
}  // namespace locard::forensics
