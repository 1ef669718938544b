#pragma once
// Shared by the physics tests: the simulated bedroom's mesh and scenario text helpers.

#include <locard/core/triangle_mesh.hpp>
#include <locard/sim/physics_scenario.hpp>
#include <locard/sim/scene.hpp>
#include <locard/sim/scene_mesh.hpp>

#include <string>
#include <string_view>

namespace locard::sim::test {

// The bedroom's ground-truth mesh (what scan-sim writes as scene.ply): room 3.84 x 4.00 x 2.60,
// z up, floor at z = 0, walls at x = +-1.92 and y = +-2.
inline const TriangleMesh& bedroom_mesh() {
  static const TriangleMesh mesh = build_scene_mesh(builtin_scene("bedroom")).mesh;
  return mesh;
}

inline Scenario scenario_from(std::string_view text) {
  return parse_scenario(text, "test-scenario.json");
}

}  // namespace locard::sim::test
