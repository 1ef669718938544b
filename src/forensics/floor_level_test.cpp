// The floor a case is levelled by (floor_level.hpp), on synthetic rooms with a known floor: a
// tilted frame is found within 0.5 degrees from a rough up guess, despite walls, a table and
// noise; without a floor there is no level, rather than a wall taken for one.
#include <locard/forensics/floor_level.hpp>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace locard::forensics {
namespace {

using Eigen::Vector3d;

constexpr double kDeg = M_PI / 180.0;

// A 4 x 3 m room (floor z = 0, walls to 2.5 m, a 1 x 0.6 m table top at 0.75 m), 2 cm
// sampling, 5 mm noise, seen in a frame turned by `R` and shifted.
std::vector<Vector3d> room(const Eigen::Matrix3d& R, bool with_floor) {
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.005);
  std::vector<Vector3d> out;
  auto add = [&](const Vector3d& p) {
    out.push_back(R * (p + Vector3d(noise(rng), noise(rng), noise(rng))) + Vector3d(0.3, -1.0, 2.0));
  };
  for (double x = -2; x <= 2; x += 0.02)
    for (double y = -1.5; y <= 1.5; y += 0.02) {
      if (with_floor) add({x, y, 0.0});
      if (x > 0.5 && x < 1.5 && y > -0.3 && y < 0.3) add({x, y, 0.75});
    }
  for (double t = -2; t <= 2; t += 0.02)
    for (double z = 0; z <= 2.5; z += 0.02) {
      add({t, -1.5, z});
      add({t, 1.5, z});
      if (std::abs(t) <= 1.5) add({2.0, t, z});
    }
  return out;
}

TEST(FloorLevel, FindsATiltedFloorFromARoughUpGuess) {
  const Eigen::Matrix3d R =
      (Eigen::AngleAxisd(35 * kDeg, Vector3d(1, 0.3, 0).normalized())).toRotationMatrix();
  const Vector3d true_up = R * Vector3d::UnitZ();
  // The cameras' up off by 15 degrees.
  const Vector3d guess = Eigen::AngleAxisd(15 * kDeg, Vector3d::UnitY()) * true_up;
  const auto f = find_floor_level(room(R, true), guess);
  ASSERT_TRUE(f.has_value());
  EXPECT_LT(std::acos(std::clamp(f->normal.dot(true_up), -1.0, 1.0)) / kDeg, 0.5);
  EXPECT_NEAR(f->tilt_deg, 35.0, 0.5);
  EXPECT_LT((f->R_level * f->normal - Vector3d::UnitZ()).norm(), 1e-9);
  EXPECT_NEAR(f->rms_m, 0.005, 0.002);
  // The floor's height along its normal: the frame's shift projected on it.
  EXPECT_NEAR(f->height_m, true_up.dot(Vector3d(0.3, -1.0, 2.0)), 0.005);
}

TEST(FloorLevel, NoFloorNoLevel) {
  const Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  // Walls and a table only: a tilted plane through the walls' feet holds more points than the
  // table top, but has wall below it.
  EXPECT_FALSE(find_floor_level(room(R, false), Vector3d::UnitZ()).has_value());
  EXPECT_FALSE(find_floor_level({}, Vector3d::UnitZ()).has_value());
  EXPECT_FALSE(find_floor_level(room(R, true), Vector3d::Zero()).has_value());
}

}  // namespace
}  // namespace locard::forensics
