#pragma once
// `locard simulate CASE_DIR SCENARIO.json`: runs a scenario against the case's mesh and writes
//
//   CASE_DIR/simulations/<scenario name>/
//     scenario.json   the scenario file, byte for byte
//     events.json     {"label": "illustrative simulation, not measured data", the effective
//                      settings, the mesh's path and SHA-256, the bodies, "events" (launch,
//                      impact, no_impact, contact, rest: each with time and position) and
//                      "final" states}; no wall-clock times, so the same scenario, mesh and seed
//                      give the same bytes
//     animation.glb   physics_gltf.hpp
//
// The folder appears complete or not at all (files written into a hidden temporary folder,
// then renamed), and an existing one is replaced only with force. When CASE_DIR is a Locard
// case (case.json + manifest.json), the step is appended to log.jsonl and manifest.json is
// rewritten (forensics::CaseFolder); a bare folder holding mesh/mesh.ply is simulated too, with
// nothing logged (SimulateSummary::logged says which).

#include <locard/sim/physics_scenario.hpp>
#include <locard/sim/physics_world.hpp>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace locard::sim {

struct SimulateOptions {
  bool force = false;
  std::optional<std::uint64_t> seed;   // override the scenario's
  std::optional<double> duration;      // s
  std::optional<double> fps;
};

struct SimulateSummary {
  std::filesystem::path folder;  // CASE_DIR/simulations/<name>
  Scenario scenario;             // as run (overrides applied)
  SimulationResult result;
  double wall_seconds = 0.0;     // the physics alone
  bool logged = false;           // appended to the case's log.jsonl
};

// events.json's text for a run. `mesh_path` and `mesh_sha256` identify the mesh used.
std::string events_json(const Scenario& scenario, const SimulationResult& result,
                        const std::string& mesh_path, const std::string& mesh_sha256);

SimulateSummary simulate_case(const std::filesystem::path& case_dir,
                              const std::filesystem::path& scenario_path,
                              const SimulateOptions& options = {});

}  // namespace locard::sim
