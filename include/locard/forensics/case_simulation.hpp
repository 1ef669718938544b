#pragma once
// `locard simulate CASE_DIR SCENARIO.json`: runs a scenario against the case's mesh and writes
// CASE_DIR/simulations/<scenario name>/ (sim/physics_output.hpp: scenario.json, events.json,
// animation.glb). An existing run of that name is replaced only with force. When CASE_DIR is a
// Locard case (case.json + manifest.json), the case is held and verified first, and the step is
// appended to log.jsonl and manifest.json rewritten (CaseFolder); a bare folder holding
// mesh/mesh.ply is simulated too, with nothing logged (SimulateSummary::logged says which).
// The simulator knows nothing of cases: this is where a run becomes part of one.

#include <locard/sim/physics_scenario.hpp>
#include <locard/sim/physics_world.hpp>

#include <cstdint>
#include <filesystem>
#include <optional>

namespace locard::forensics {

struct SimulateOptions {
  bool force = false;
  std::optional<std::uint64_t> seed;   // override the scenario's
  std::optional<double> duration;      // s
  std::optional<double> fps;
};

struct SimulateSummary {
  std::filesystem::path folder;  // CASE_DIR/simulations/<name>
  sim::Scenario scenario;        // as run (overrides applied)
  sim::SimulationResult result;
  double wall_seconds = 0.0;     // the physics alone
  bool logged = false;           // appended to the case's log.jsonl
};

SimulateSummary simulate_case(const std::filesystem::path& case_dir,
                              const std::filesystem::path& scenario_path,
                              const SimulateOptions& options = {});

}  // namespace locard::forensics
