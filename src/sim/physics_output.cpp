// Writing a simulation run's files (see physics_output.hpp).
#include <locard/sim/physics_output.hpp>

#include <locard/core/atomic_file.hpp>
#include <locard/sim/physics_gltf.hpp>

#include <LinearMath/btScalar.h>
#include <nlohmann/json.hpp>

#include <cmath>
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

void write_simulation_folder(const fs::path& folder, const Scenario& s,
                             const SimulationResult& result, const std::string& events) {
  const fs::path parent = folder.parent_path();
  const std::string name = folder.filename().string();
  fs::create_directories(parent);
  const std::string tag = std::to_string(::getpid());
  const fs::path temp = parent / ("." + name + ".tmp-" + tag);
  const fs::path old = parent / ("." + name + ".old-" + tag);
  std::error_code ec;
  fs::remove_all(temp, ec);
  try {
    fs::create_directories(temp);
    write_text(temp / "scenario.json", s.source_text);
    write_text(temp / "events.json", events);
    write_simulation_glb(temp / "animation.glb", s, result);
    if (fs::exists(folder)) fs::rename(folder, old);
    fs::rename(temp, folder);
    fs::remove_all(old, ec);
  } catch (...) {
    fs::remove_all(temp, ec);
    if (!fs::exists(folder) && fs::exists(old)) fs::rename(old, folder, ec);
    throw;
  }
}

}  // namespace locard::sim
