#pragma once
// The animated glTF 2.0 binary (GLB) of a simulation, for the viewer's timeline.
//
//   scene 0: one root node "simulation (illustrative)" whose rotation turns Locard's z-up world
//            into glTF's y-up ((x, y, z) -> (x, z, -y), as mesh.glb is written), so the
//            animation overlays the case's mesh.glb; under it one node per body:
//              objects (box / sphere / the imported mesh), ragdoll parts ("victim/head", ...),
//              avatars (capsules), projectiles (small red spheres) and each projectile's
//              trail ("<name> trail", a LINE_STRIP of its flown path).
//   animation 0 "simulation": translation + rotation channels (LINEAR) per body, sampled at
//            the scenario's fps; projectiles are keyed at every physics step of their flight
//            (a bullet crosses a room between two frames), and a STEP scale channel hides a
//            projectile and its trail (scale 0) until it is fired.
//   asset.extras / scene extras / every node's extras: {"label": "illustrative simulation, not
//            measured data", ...}; node extras also carry "kind" and "body".
// Geometry has POSITION and indices only (viewers compute flat normals, as glTF requires).

#include <locard/sim/physics_scenario.hpp>
#include <locard/sim/physics_world.hpp>

#include <cstdint>
#include <filesystem>
#include <vector>

namespace locard::sim {

std::vector<std::uint8_t> simulation_glb(const Scenario& scenario, const SimulationResult& result);
// Atomic write of simulation_glb().
void write_simulation_glb(const std::filesystem::path& path, const Scenario& scenario,
                          const SimulationResult& result);

}  // namespace locard::sim
