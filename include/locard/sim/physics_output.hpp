#pragma once
// What a simulation run leaves on disk, knowing nothing of cases (forensics/case_simulation.hpp
// records a run in a case):
//
//   <folder>/
//     scenario.json   the scenario file, byte for byte
//     events.json     {"label": "illustrative simulation, not measured data", the effective
//                      settings, the mesh's path and SHA-256, the bodies, "events" (launch,
//                      impact, no_impact, contact, rest: each with time and position) and
//                      "final" states}; no wall-clock times, so the same scenario, mesh and seed
//                      give the same bytes
//     animation.glb   physics_gltf.hpp
//
// The folder appears complete or not at all (files written into a hidden temporary folder
// beside it, then renamed); an existing one is replaced.

#include <locard/sim/physics_scenario.hpp>
#include <locard/sim/physics_world.hpp>

#include <filesystem>
#include <string>

namespace locard::sim {

// events.json's text for a run. `mesh_path` and `mesh_sha256` identify the mesh used.
std::string events_json(const Scenario& scenario, const SimulationResult& result,
                        const std::string& mesh_path, const std::string& mesh_sha256);

// Writes the three files of a run into `folder` (see above); `events` is events_json's text.
void write_simulation_folder(const std::filesystem::path& folder, const Scenario& scenario,
                             const SimulationResult& result, const std::string& events);

}  // namespace locard::sim
