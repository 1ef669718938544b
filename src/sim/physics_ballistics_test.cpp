// Projectiles in free space against closed forms: the drag-free parabola (through the whole
// simulator, not just the integrator) and quadratic drag without gravity.
#include <locard/sim/physics_ballistics.hpp>
#include <locard/sim/physics_world.hpp>

#include "physics_test_util.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace locard::sim {
namespace {

using Eigen::Vector3d;

// Position of a track at a step time (tracks hold every physics step of a projectile's flight).
Vector3d track_at(const BodyTrack& track, double t) {
  for (std::size_t i = 0; i < track.times.size(); ++i)
    if (std::abs(track.times[i] - t) < 1e-9) return track.positions[i];
  ADD_FAILURE() << "no sample at t = " << t;
  return Vector3d::Zero();
}

TEST(PhysicsBallistics, FreeSpaceShotFollowsTheClosedFormParabola) {
  // No mesh, no drag: x(t) = x0 + v0 t + g t^2 / 2 for 3 s of flight at 240 steps/s.
  const Scenario s = test::scenario_from(R"({
    "name": "free", "duration": 3.0, "time_step": 0.004166666666666667,
    "projectiles": [{"name": "shot", "muzzle": [0, 0, 1.5], "direction": [3, 1, 2],
                     "speed": 120, "drag_coefficient": 0}]})");
  const SimulationResult r = simulate(s, TriangleMesh{});
  ASSERT_EQ(r.tracks.size(), 1u);
  const BallisticState start{{0, 0, 1.5}, Vector3d(3, 1, 2).normalized() * 120.0};
  double worst = 0.0;
  for (int step : {1, 24, 120, 240, 480, 719}) {
    const double t = step * s.time_step;
    const Vector3d expected = ballistic_closed_form(start, s.gravity, t).position;
    worst = std::max(worst, (track_at(r.tracks[0], t) - expected).norm());
  }
  EXPECT_LT(worst, 1e-9) << "largest deviation from the parabola, m";
  RecordProperty("ballistic_error_m", std::to_string(worst));
  // No surface: the shot ends in flight, reported as such.
  ASSERT_FALSE(r.events.empty());
  EXPECT_EQ(r.events.front().type, "launch");
  EXPECT_EQ(r.events.back().type, "no_impact");
  const Vector3d end = ballistic_closed_form(start, s.gravity, 3.0).position;
  EXPECT_LT((r.events.back().position - end).norm(), 1e-9);
}

TEST(PhysicsBallistics, DelayedShotStartsAtItsFireTime) {
  const Scenario s = test::scenario_from(R"({
    "name": "late", "duration": 1.0,
    "projectiles": [{"name": "shot", "muzzle": [0, 0, 1], "direction": [1, 0, 0],
                     "speed": 100, "drag_coefficient": 0, "fire_time": 0.3}]})");
  const SimulationResult r = simulate(s, TriangleMesh{});
  const BallisticState start{{0, 0, 1}, {100, 0, 0}};
  const BodyTrack& track = r.tracks[0];
  for (std::size_t i = 0; i < track.times.size(); ++i) {
    if (track.times[i] < 0.3) continue;
    const Vector3d expected = ballistic_closed_form(start, s.gravity, track.times[i] - 0.3).position;
    EXPECT_LT((track.positions[i] - expected).norm(), 1e-9) << "t = " << track.times[i];
  }
  EXPECT_DOUBLE_EQ(r.events.front().time, 0.3);
}

TEST(PhysicsBallistics, QuadraticDragMatchesTheClosedFormWithoutGravity) {
  // dv/dt = -c |v| v along a line: v(t) = v0 / (1 + c v0 t), s(t) = ln(1 + c v0 t) / c.
  BallisticModel model;
  model.gravity = Vector3d::Zero();
  model.drag_per_metre = drag_per_metre(1.225, 0.3, 0.009, 0.008);
  const double c = model.drag_per_metre;
  EXPECT_NEAR(c, 1.225 * 0.3 * (std::numbers::pi * 0.009 * 0.009 / 4) / (2 * 0.008), 1e-15);
  const double v0 = 360.0;
  BallisticState s{{0, 0, 0}, {v0, 0, 0}};
  const double dt = 1.0 / 240.0;
  double worst = 0.0;
  for (int n = 1; n <= 480; ++n) {
    s = ballistic_step(s, model, dt);
    const double t = n * dt;
    worst = std::max(worst, std::abs(s.position.x() - std::log1p(c * v0 * t) / c));
    EXPECT_NEAR(s.velocity.x(), v0 / (1 + c * v0 * t), 1e-7);
  }
  EXPECT_LT(worst, 1e-7) << "m over 2 s of flight";
}

TEST(PhysicsBallistics, FallWithDragApproachesTerminalVelocity) {
  // Terminal speed where drag balances gravity: c v^2 = g.
  BallisticModel model;
  model.drag_per_metre = drag_per_metre(1.225, 0.47, 0.05, 0.05);  // a 5 cm ball of 50 g
  BallisticState s;
  for (int n = 0; n < 240 * 30; ++n) s = ballistic_step(s, model, 1.0 / 240.0);
  EXPECT_NEAR(-s.velocity.z(), std::sqrt(9.81 / model.drag_per_metre), 1e-6);
}

TEST(PhysicsBallistics, DragShortensAShotAcrossTheBedroom) {
  // Same aim, with and without drag: the drag shot is slower at the wall and arrives later.
  auto shot = [](double cd) {
    const std::string text = R"({"name": "drag", "duration": 0.2, "projectiles": [{"name": "shot",
        "muzzle": [-1.5, 0.3, 1.4], "direction": [1, 0, 0], "speed": 340, "drag_coefficient": )" +
                             std::to_string(cd) + "}]}";
    return simulate(test::scenario_from(text), test::bedroom_mesh());
  };
  const SimulationResult plain = shot(0.0), drag = shot(0.3);
  ASSERT_EQ(plain.events.back().type, "impact");
  ASSERT_EQ(drag.events.back().type, "impact");
  EXPECT_LT(drag.events.back().speed, plain.events.back().speed - 1.0);
  EXPECT_GT(drag.events.back().time, plain.events.back().time);
  EXPECT_NEAR(drag.events.back().position.x(), 1.92, 1e-6);
}

}  // namespace
}  // namespace locard::sim
