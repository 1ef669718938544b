// Writing a simulation into a case folder (see physics_output.hpp).
#include <locard/sim/physics_output.hpp>

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/integrity.hpp>
#include <locard/io/ply.hpp>
#include <locard/sim/physics_gltf.hpp>

#include <LinearMath/btScalar.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <optional>
#include <system_error>
#include <unistd.h>

namespace locard::sim {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

// Six decimals: micrometres and microseconds, far below what the model can claim, and short.
double r6(double x) { return std::round(x * 1e6) / 1e6; }
json vec(const Eigen::Vector3d& v) { return {r6(v.x()), r6(v.y()), r6(v.z())}; }
json quat(const Eigen::Quaterniond& q) {  // [w, x, y, z], w >= 0
  const double s = q.w() < 0 ? -1.0 : 1.0;
  return {r6(s * q.w()), r6(s * q.x()), r6(s * q.y()), r6(s * q.z())};
}

json event_json(const SimEvent& e) {
  json j = {{"time", r6(e.time)}, {"type", e.type}, {"body", e.body}};
  if (!e.part.empty()) j["part"] = e.part;
  if (!e.other.empty()) j["other"] = e.other;
  if (!e.other_part.empty()) j["other_part"] = e.other_part;
  j["position"] = vec(e.position);
  if (e.has_normal) j["normal"] = vec(e.normal);
  if (e.has_velocity) j["velocity"] = vec(e.velocity);
  if (e.speed >= 0) j["speed"] = r6(e.speed);
  if (e.incidence_deg >= 0) j["incidence_deg"] = r6(e.incidence_deg);
  if (e.energy_j >= 0) j["energy_j"] = r6(e.energy_j);
  if (e.distance_m >= 0) j["distance"] = r6(e.distance_m);
  if (e.triangle >= 0) j["triangle"] = e.triangle;
  if (e.has_rotation) j["rotation_wxyz"] = quat(e.rotation);
  return j;
}

void write_text(const fs::path& path, const std::string& text) {
  AtomicFile file(path);
  file.stream() << text;
  file.commit();
}

}  // namespace

std::string events_json(const Scenario& s, const SimulationResult& result,
                        const std::string& mesh_path, const std::string& mesh_sha256) {
  json j;
  j["label"] = std::string(kIllustrativeLabel);
  j["scenario"] = s.name;
  if (!s.description.empty()) j["description"] = s.description;
  j["software"] = std::string("locard ") + LOCARD_VERSION + ", Bullet " +
                  std::to_string(btGetVersion()) + " (double precision)";
  j["settings"] = {{"seed", s.seed},
                   {"duration_s", s.duration},
                   {"time_step_s", s.time_step},
                   {"fps", s.fps},
                   {"gravity", vec(s.gravity)},
                   {"air_density", s.air_density},
                   {"steps", result.steps}};
  j["mesh"] = {{"path", mesh_path}, {"sha256", mesh_sha256}, {"triangles", result.mesh_triangles}};
  // Where the scan has holes, bodies rest on an inferred plane, not on measured surface.
  if (result.floor_inferred)
    j["inferred_support"] = {{"kind", "floor plane"},
                             {"height_m", result.floor_height_m},
                             {"note", "inferred from the mesh's lowest level surface; it holds "
                                      "bodies where the scan saw no floor"}};
  j["warnings"] = result.warnings;
  j["frame"] = "case world frame (z up for the simulated bedroom), metres, seconds";
  json bodies = json::array();
  for (const auto& p : s.projectiles)
    bodies.push_back({{"name", p.name}, {"kind", "projectile"}, {"source", p.source},
                      {"muzzle", vec(p.muzzle)}, {"direction", vec(p.direction)},
                      {"speed", p.speed}, {"mass", p.mass}, {"diameter", p.diameter},
                      {"drag_coefficient", p.drag_coefficient}, {"fire_time", p.fire_time},
                      {"spread_deg", p.spread_deg}});
  for (const auto& o : s.objects)
    bodies.push_back({{"name", o.name}, {"kind", "object"}, {"shape", to_string(o.shape)},
                      {"mass", o.mass}, {"friction", o.friction}, {"restitution", o.restitution}});
  for (const auto& p : s.people)
    bodies.push_back({{"name", p.name}, {"kind", to_string(p.kind)}, {"height", p.height}});
  j["bodies"] = bodies;
  json events = json::array();
  for (const SimEvent& e : result.events) events.push_back(event_json(e));
  j["events"] = events;
  json finals = json::array();
  for (const FinalState& f : result.final_states)
    finals.push_back({{"body", f.body}, {"kind", f.kind}, {"position", vec(f.position)},
                      {"rotation_wxyz", quat(f.rotation)}, {"at_rest", f.at_rest}});
  j["final"] = finals;
  return j.dump(2) + "\n";
}

SimulateSummary simulate_case(const fs::path& case_dir, const fs::path& scenario_path,
                              const SimulateOptions& options) {
  if (!fs::is_directory(case_dir)) throw_input_error(case_dir, "no such case folder");
  SimulateSummary summary;
  Scenario& s = summary.scenario;
  s = read_scenario(scenario_path, case_dir);
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
  std::optional<forensics::CaseFolder> folder;
  if (fs::is_regular_file(case_dir / "manifest.json"))
    folder.emplace(forensics::CaseFolder::open(case_dir, forensics::CaseAccess::Change));
  const fs::path rel = fs::path("simulations") / s.name;
  const std::vector<fs::path> outputs = {rel / "scenario.json", rel / "events.json",
                                         rel / "animation.glb"};
  std::optional<forensics::CaseChange> change;
  if (folder) change.emplace(*folder, outputs);

  // Everything is checked and run before the case is touched.
  const auto start = std::chrono::steady_clock::now();
  summary.result = simulate(s, mesh);
  summary.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  const std::string events = events_json(s, summary.result, s.mesh.generic_string(),
                                         forensics::sha256_file(mesh_path));
  fs::create_directories(simulations);
  const std::string tag = std::to_string(::getpid());
  const fs::path temp = simulations / ("." + s.name + ".tmp-" + tag);
  const fs::path old = simulations / ("." + s.name + ".old-" + tag);
  std::error_code ec;
  fs::remove_all(temp, ec);
  try {
    fs::create_directories(temp);
    write_text(temp / "scenario.json", s.source_text);
    write_text(temp / "events.json", events);
    write_simulation_glb(temp / "animation.glb", s, summary.result);
    if (fs::exists(summary.folder)) fs::rename(summary.folder, old);
    fs::rename(temp, summary.folder);
    fs::remove_all(old, ec);
  } catch (...) {
    fs::remove_all(temp, ec);
    if (!fs::exists(summary.folder) && fs::exists(old)) fs::rename(old, summary.folder, ec);
    throw;
  }

  if (folder) {
    forensics::LogStep step;
    step.step = "simulate";
    const json parameters = {{"scenario", s.name},
                             {"label", std::string(kIllustrativeLabel)},
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

}  // namespace locard::sim
