// Scenario files: every bad input names the file and the key; the three ways of aiming a
// projectile (muzzle + direction, two points, a case's trajectory analysis).
#include <locard/core/error.hpp>
#include <locard/sim/physics_scenario.hpp>

#include "test_support.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

namespace locard::sim {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

std::string error_of(const std::string& text) {
  try {
    parse_scenario(text, "bad.json");
  } catch (const InputError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(PhysicsScenario, BadInputNamesTheKey) {
  const std::pair<const char*, const char*> cases[] = {
      {R"({"name": "x", "objets": []})", "unknown key 'objets'"},
      {R"({"name": "x", "objects": [{"name": "box", "shape": "box", "size": [1, 1, 1],
          "position": [0, 0, 1], "mas": 2}]})", "objects[0] \"box\": unknown key 'mas'"},
      {R"({"objects": []})", "missing required key 'name'"},
      {R"({"name": "x", "projectiles": [{"name": "p", "muzzle": [0, 0, 1], "direction": [1, 0, 0]}]})",
       "projectiles[0] \"p\": missing required key 'speed'"},
      {R"({"name": "x", "objects": [{"name": "b", "shape": "sphere", "radius": 0.1,
          "position": [0, 0, 1], "mass": NaN}]})", "key 'mass': expected a finite number"},
      {R"({"name": "x", "objects": [{"name": "b", "shape": "sphere", "radius": 0.1,
          "position": [0, 0, -Infinity]}]})", "key 'position': expected a finite number"},
      {R"({"name": "x", "objects": [{"name": "b", "shape": "sphere", "radius": 0.1,
          "position": [0, 0, 1e999]}]})", "key 'position': the number 1e999 is not a finite double"},
      {R"({"name": "x", "objects": [{"name": "b", "shape": "cone", "position": [0, 0, 1]}]})",
       "unknown shape 'cone'"},
      {R"({"name": "x", "projectiles": [{"name": "p", "muzzle": [0, 0, 1], "from_points": [[0, 0, 1], [1, 0, 1]],
          "speed": 3}]})", "give exactly one of 'muzzle'"},
      {R"({"name": "x", "projectiles": [{"name": "p", "muzzle": [0, 0, 1], "direction": [0, 0, 0],
          "speed": 3}]})", "projectiles[0] \"p\".direction: must not be the zero vector"},
      {R"({"name": "x", "people": [{"name": "w", "kind": "avatar", "path": [{"time": 1, "position": [0, 0, 0]},
          {"time": 1, "position": [1, 0, 0]}]}]})", "path[1].time: times must increase"},
      {R"({"name": "x", "people": [{"name": "w", "kind": "zombie"}]})", "unknown kind 'zombie'"},
      {R"({"name": "x", "duration": -1, "objects": []})", "scenario.duration"},
      {R"({"name": "x"})", "nothing to simulate"},
      {R"({"name": "../up", "objects": []})", "scenario.name"},
      {R"({"name": "x", "objects": [{"name": "a", "shape": "sphere", "radius": 0.1, "position": [0, 0, 1]},
          {"name": "a", "shape": "sphere", "radius": 0.1, "position": [1, 0, 1]}]})", "\"a\" is used twice"},
      {"{\"name\": \"x\",\n \"objects\": [,]}", "bad.json:2: not valid JSON"},
  };
  for (const auto& [text, expected] : cases)
    EXPECT_THAT(error_of(text), AllOf(HasSubstr("bad.json"), HasSubstr(expected))) << text;
  // Issue 14: a 300-character name failed the file system after the output folder was made.
  const std::string long_name = R"({"name": ")" + std::string(300, 'n') + R"(", "objects": []})";
  EXPECT_THAT(error_of(long_name), AllOf(HasSubstr("scenario.name"), HasSubstr("at most 100 bytes")));
}

TEST(PhysicsScenario, DefaultsAndAiming) {
  const Scenario s = parse_scenario(R"({
    "name": "ok",
    "projectiles": [{"name": "a", "muzzle": [0, 0, 1], "direction": [0, 3, 4], "speed": 300},
                    {"name": "b", "from_points": [[1, 1, 1], [1, 1, 3]], "speed": 200}],
    "objects": [{"name": "box", "shape": "box", "size": [0.1, 0.2, 0.3], "position": [0, 0, 1],
                 "rotation_deg": [0, 0, 90]}],
    "people": [{"name": "v", "kind": "ragdoll", "position": [0, 0, 0]}]})", "ok.json");
  EXPECT_EQ(s.seed, 1u);
  EXPECT_DOUBLE_EQ(s.duration, 5.0);
  EXPECT_DOUBLE_EQ(s.fps, 30.0);
  EXPECT_EQ(s.mesh, "mesh/mesh.ply");
  EXPECT_NEAR((s.projectiles[0].direction - Eigen::Vector3d(0, 0.6, 0.8)).norm(), 0.0, 1e-15);
  EXPECT_DOUBLE_EQ(s.projectiles[0].drag_coefficient, 0.3);
  EXPECT_EQ(s.projectiles[1].muzzle, Eigen::Vector3d(1, 1, 1));
  EXPECT_EQ(s.projectiles[1].direction, Eigen::Vector3d(0, 0, 1));
  EXPECT_TRUE(s.projectiles[1].starts_on_surface);
  EXPECT_EQ(s.objects[0].shape, ObjectShape::Box);
  EXPECT_EQ(s.people[0].kind, PersonKind::Ragdoll);
  EXPECT_DOUBLE_EQ(s.people[0].height, 1.75);
}

TEST(PhysicsScenario, ProjectileFromACaseTrajectoryAnalysis) {
  const auto dir = locard::test::scratch_dir();
  std::filesystem::create_directories(dir / "trajectories");
  // As issue 7's `locard trajectory` writes it: {"analyses": [{name, points, direction, ...}]}.
  std::ofstream(dir / "trajectories" / "analyses.json") << R"({"analyses": [
    {"name": "T1", "points": [[0, 0, 1], [1, 0, 1]], "direction": [1, 0, 0]},
    {"name": "rod", "points": [{"position": [0, 0, 1]}, {"position": [0, 1, 1.1]}, {"position": [0, 2, 1.2]}],
     "direction": [0, 0.995037, 0.0995037]}]})";
  std::ofstream(dir / "s.json") << R"({"name": "s", "projectiles": [
    {"name": "p", "trajectory": "rod", "speed": 300}]})";
  const Scenario s = read_scenario(dir / "s.json", dir);
  EXPECT_EQ(s.projectiles[0].source, "trajectory:rod");
  EXPECT_EQ(s.projectiles[0].muzzle, Eigen::Vector3d(0, 0, 1));
  EXPECT_NEAR((s.projectiles[0].direction - Eigen::Vector3d(0, 1, 0.1).normalized()).norm(), 0, 1e-6);
  std::ofstream(dir / "t.json") << R"({"name": "t", "projectiles": [
    {"name": "p", "trajectory": "T9", "speed": 300}]})";
  try {
    read_scenario(dir / "t.json", dir);
    ADD_FAILURE() << "unknown analysis accepted";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("t.json"), HasSubstr("no analysis named 'T9'"),
                                HasSubstr("T1, rod")));
  }
}

}  // namespace
}  // namespace locard::sim
