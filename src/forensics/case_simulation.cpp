// Recording a simulation run in a case (see case_simulation.hpp).
#include <locard/forensics/case_simulation.hpp>

#include <locard/core/error.hpp>
#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/integrity.hpp>
#include <locard/io/ply.hpp>
#include <locard/sim/physics_output.hpp>

#include <nlohmann/json.hpp>

#include <chrono>
#include <optional>
#include <vector>

namespace locard::forensics {

namespace fs = std::filesystem;
using nlohmann::json;

SimulateSummary simulate_case(const fs::path& case_dir, const fs::path& scenario_path,
                              const SimulateOptions& options) {
  if (!fs::is_directory(case_dir)) throw_input_error(case_dir, "no such case folder");
  SimulateSummary summary;
  sim::Scenario& s = summary.scenario;
  s = sim::read_scenario(scenario_path, case_dir);
  if (options.seed) s.seed = *options.seed;
  if (options.duration) {
    if (!(*options.duration > 0.0 && *options.duration <= 600.0))
      throw InputError("--duration: expected seconds in (0, 600]");
    s.duration = *options.duration;
  }
  if (options.fps) {
    if (!(*options.fps >= 1.0 && *options.fps <= 1000.0)) throw InputError("--fps: expected 1 to 1000");
    s.fps = *options.fps;
  }
  const fs::path mesh_path = case_dir / s.mesh;
  if (!fs::is_regular_file(mesh_path))
    throw_input_error(mesh_path, "the case has no mesh to simulate against (run `locard "
                                 "reconstruct` first, or name one with the scenario's \"mesh\")");
  const TriangleMesh mesh = read_ply_mesh(mesh_path);
  if (mesh.triangles.empty()) throw_input_error(mesh_path, "the mesh has no triangles");

  const fs::path simulations = case_dir / "simulations";
  summary.folder = simulations / s.name;
  if (fs::exists(summary.folder) && !options.force)
    throw_input_error(summary.folder, "a simulation of this name exists; pass --force to replace it");

  // A Locard case is held and verified before the simulation runs: a simulation is not
  // added to a case that does not verify (CaseNotIntact). A plain folder holding a mesh is
  // written without a log.
  std::optional<CaseFolder> folder;
  if (fs::is_regular_file(case_dir / "manifest.json"))
    folder.emplace(CaseFolder::open(case_dir, CaseAccess::Change));
  const fs::path rel = fs::path("simulations") / s.name;
  const std::vector<fs::path> outputs = {rel / "scenario.json", rel / "events.json",
                                         rel / "animation.glb"};
  std::optional<CaseChange> change;
  if (folder) change.emplace(*folder, outputs);

  // Everything is checked and run before the case is touched.
  const auto start = std::chrono::steady_clock::now();
  summary.result = sim::simulate(s, mesh);
  summary.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  const std::string events = sim::events_json(s, summary.result, s.mesh.generic_string(),
                                              sha256_file(mesh_path));
  sim::write_simulation_folder(summary.folder, s, summary.result, events);

  if (folder) {
    LogStep step;
    step.step = "simulate";
    const json parameters = {{"scenario", s.name},
                             {"label", std::string(sim::kIllustrativeLabel)},
                             {"seed", s.seed},
                             {"duration_s", s.duration},
                             {"time_step_s", s.time_step},
                             {"fps", s.fps},
                             {"force", options.force}};
    step.parameters_json = parameters.dump();
    step.duration_s = summary.wall_seconds;
    step.inputs = {fs::absolute(scenario_path), s.mesh};
    step.outputs = outputs;
    change->commit(step);
    summary.logged = true;
  }
  return summary;
}

}  // namespace locard::forensics
