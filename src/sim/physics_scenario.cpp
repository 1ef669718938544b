// Scenario files: strict JSON reading, as for scene files (scene_json.cpp). Every key is known,
// every required key present, every number finite; otherwise an InputError names the file, the
// place ("objects[1] \"box\"") and the key, because a typo in a scenario must not silently
// become a default in something a court may be shown.
#include <locard/sim/physics_scenario.hpp>

#include <locard/core/error.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/strict_json.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

namespace locard::sim {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

using Reader = StrictObject;  // io/strict_json.hpp

std::string element_place(const std::string& list, std::size_t index, const json& j) {
  std::string where = list + "[" + std::to_string(index) + "]";
  if (j.is_object() && j.contains("name") && j.at("name").is_string())
    where += " \"" + j.at("name").get<std::string>() + "\"";
  return where;
}

std::string read_name(Reader& r) {
  std::string name = r.string("name");
  if (name.empty()) r.fail(r.place("name") + ": must not be empty");
  return name;
}

ProjectileSpec read_projectile(const json& j, std::size_t index, const fs::path& file,
                               const fs::path& case_dir) {
  Reader r(j, element_place("projectiles", index, j), file);
  ProjectileSpec p;
  p.name = read_name(r);
  // Exactly one way of giving the line of fire.
  const int ways = int(r.has("muzzle")) + int(r.has("from_points")) + int(r.has("trajectory"));
  if (ways != 1)
    r.fail(r.where() + ": give exactly one of 'muzzle' (with 'direction'), 'from_points' or "
                       "'trajectory', found " + std::to_string(ways));
  Eigen::Vector3d along;
  if (r.has("muzzle")) {
    p.muzzle = r.vec3("muzzle");
    along = r.vec3("direction");
    if (along.norm() < 1e-9) r.fail(r.place("direction") + ": must not be the zero vector");
  } else if (r.has("from_points")) {
    const json& pts = r.array("from_points", true);
    if (pts.size() != 2)
      r.fail(r.place("from_points") + ": expected two points [a, b], found " + Reader::describe(pts));
    const Eigen::Vector3d a = r.vec3_value(pts[0], "from_points[0]");
    const Eigen::Vector3d b = r.vec3_value(pts[1], "from_points[1]");
    if ((b - a).norm() < 1e-6) r.fail(r.place("from_points") + ": the two points coincide");
    p.muzzle = a;
    along = b - a;
    p.source = "from_points";
    p.starts_on_surface = true;
  } else {
    const std::string name = r.string("trajectory");
    if (case_dir.empty())
      r.fail(r.place("trajectory") + ": a trajectory analysis needs a case folder");
    const fs::path analyses = case_dir / "trajectories" / "analyses.json";
    if (!fs::is_regular_file(analyses))
      r.fail(r.place("trajectory") + ": analysis '" + name + "' asked for, but " +
             analyses.string() + " does not exist");
    bool found = false;
    std::string known;
    for (const TrajectoryLine& line : read_trajectory_analyses(analyses)) {
      known += (known.empty() ? "" : ", ") + line.name;
      if (line.name != name) continue;
      if (line.withdrawn)
        r.fail(r.place("trajectory") + ": analysis '" + name + "' was withdrawn from the case");
      p.muzzle = line.a;
      along = line.b - line.a;
      found = true;
      break;
    }
    if (!found)
      r.fail(r.place("trajectory") + ": no analysis named '" + name + "' in " +
             analyses.string() + " (found: " + (known.empty() ? "none" : known) + ")");
    p.source = "trajectory:" + name;
    p.starts_on_surface = true;
  }
  p.direction = along.normalized();
  p.speed = r.positive("speed");
  p.mass = r.positive_or("mass", p.mass);
  p.diameter = r.positive_or("diameter", p.diameter);
  p.drag_coefficient = r.non_negative_or("drag_coefficient", p.drag_coefficient);
  p.fire_time = r.non_negative_or("fire_time", p.fire_time);
  p.spread_deg = r.in_range_or("spread_deg", p.spread_deg, 0.0, 45.0);
  r.finish();
  return p;
}

// Mesh objects: scaled and centred on their bounding-box centre, like scene mesh objects.
void load_object_mesh(ObjectSpec& o, const std::string& where) {
  if (!fs::is_regular_file(o.file))
    throw_input_error(o.file, "mesh file of " + where + " not found");
  o.mesh = read_ply_mesh(o.file);
  if (o.mesh.vertices.size() < 4)
    throw_input_error(o.file, "mesh of " + where + " has fewer than 4 vertices: no solid hull");
  Eigen::Vector3f lo = o.mesh.vertices.front(), hi = lo;
  for (const auto& v : o.mesh.vertices) {
    if (!v.allFinite()) throw_input_error(o.file, "mesh of " + where + " has a non-finite vertex");
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const Eigen::Vector3f centre = 0.5f * (lo + hi);
  for (auto& v : o.mesh.vertices) v = (v - centre) * static_cast<float>(o.scale);
  if (((hi - lo) * static_cast<float>(o.scale)).minCoeff() < 1e-4f)
    throw_input_error(o.file, "mesh of " + where + " is flat (thinner than 0.1 mm)");
}

ObjectSpec read_object(const json& j, std::size_t index, const fs::path& file,
                       const fs::path& base_dir) {
  const std::string where = element_place("objects", index, j);
  Reader r(j, where, file);
  ObjectSpec o;
  o.name = read_name(r);
  const std::string shape = r.string("shape");
  if (shape == "box") {
    o.shape = ObjectShape::Box;
    o.size = r.vec3("size");
    if ((o.size.array() <= 0.0).any())
      r.fail(r.place("size") + ": expected three positive sizes");
  } else if (shape == "sphere") {
    o.shape = ObjectShape::Sphere;
    o.radius = r.positive("radius");
  } else if (shape == "mesh") {
    o.shape = ObjectShape::Mesh;
    o.file = r.string("file");
    if (o.file.is_relative()) o.file = base_dir / o.file;
    o.scale = r.positive_or("scale", 1.0);
  } else {
    r.fail(r.place("shape") + ": unknown shape '" + shape + "' (known: box, sphere, mesh)");
  }
  o.position = r.vec3("position");
  o.rotation_deg = r.vec3_or("rotation_deg", o.rotation_deg);
  o.velocity = r.vec3_or("velocity", o.velocity);
  o.angular_velocity_deg = r.vec3_or("angular_velocity_deg", o.angular_velocity_deg);
  o.mass = r.positive_or("mass", o.mass);
  o.friction = r.non_negative_or("friction", o.friction);
  o.restitution = r.in_range_or("restitution", o.restitution, 0.0, 1.0);
  o.color = r.color_or("color", o.color);
  r.finish();
  if (o.shape == ObjectShape::Mesh) load_object_mesh(o, where);
  return o;
}

PersonSpec read_person(const json& j, std::size_t index, const fs::path& file) {
  Reader r(j, element_place("people", index, j), file);
  PersonSpec p;
  p.name = read_name(r);
  const std::string kind = r.string("kind");
  p.height = r.in_range_or("height", p.height, 0.5, 2.5);
  p.color = r.color_or("color", p.color);
  if (kind == "ragdoll") {
    p.kind = PersonKind::Ragdoll;
    p.position = r.vec3("position");
    p.yaw_deg = r.number_or("yaw_deg", p.yaw_deg);
    p.mass = r.in_range_or("mass", p.mass, 5.0, 300.0);
    p.friction = r.non_negative_or("friction", p.friction);
    p.velocity = r.vec3_or("velocity", p.velocity);
  } else if (kind == "avatar") {
    p.kind = PersonKind::Avatar;
    p.radius = r.in_range_or("radius", p.radius, 0.05, 0.6);
    if (2.0 * p.radius >= p.height)
      r.fail(r.place("radius") + ": the capsule must be taller than it is wide");
    const json& path = r.array("path", true);
    if (path.empty()) r.fail(r.place("path") + ": expected at least one point");
    for (std::size_t i = 0; i < path.size(); ++i) {
      Reader pr(path[i], r.place("path") + "[" + std::to_string(i) + "]", file);
      PathPoint point;
      point.time = pr.number("time");
      point.position = pr.vec3("position");
      pr.finish();
      if (point.time < 0.0) pr.fail(pr.place("time") + ": must be >= 0");
      if (!p.path.empty() && !(point.time > p.path.back().time))
        pr.fail(pr.place("time") + ": times must increase along the path");
      p.path.push_back(point);
    }
    p.position = p.path.front().position;
  } else {
    r.fail(r.place("kind") + ": unknown kind '" + kind + "' (known: ragdoll, avatar)");
  }
  r.finish();
  return p;
}

// 1-based line of a byte offset, for parse errors.
long line_of(std::string_view text, std::size_t byte) {
  byte = std::min(byte, text.size());
  return 1 + static_cast<long>(std::count(text.begin(), text.begin() + static_cast<long>(byte), '\n'));
}

// JSON has no NaN or Infinity, so `"mass": NaN` is a syntax error to the parser. Find the key
// in front of such a token, so the message names it like any other non-finite value.
std::string key_before(std::string_view text, std::size_t start);

std::string non_finite_key(std::string_view text, std::size_t byte) {
  auto token_char = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '+' || c == '.';
  };
  std::size_t start = std::min(byte, text.size());
  while (start > 0 && token_char(text[start - 1])) --start;
  std::string token;
  for (std::size_t t = start; t < text.size() && token_char(text[t]); ++t)
    token += static_cast<char>(std::tolower(static_cast<unsigned char>(text[t])));
  if (!token.empty() && (token[0] == '-' || token[0] == '+')) token.erase(0, 1);
  if (token.rfind("nan", 0) != 0 && token.rfind("inf", 0) != 0) return {};
  return key_before(text, start);
}

std::string key_before(std::string_view text, std::size_t start) {
  const std::size_t colon = text.rfind(':', start);
  if (colon == std::string_view::npos) return {};
  const std::size_t close = text.rfind('"', colon);
  if (close == std::string_view::npos || close == 0) return {};
  const std::size_t open = text.rfind('"', close - 1);
  if (open == std::string_view::npos) return {};
  return std::string(text.substr(open + 1, close - open - 1));
}

json parse_json(std::string_view text, const fs::path& source) {
  try {
    return json::parse(text.begin(), text.end());
  } catch (const json::parse_error& e) {
    const std::size_t at = e.byte ? e.byte - 1 : 0;
    const long line = line_of(text, at);
    if (const std::string key = non_finite_key(text, at); !key.empty())
      throw_input_error(source, "key '" + key + "': expected a finite number (JSON has no NaN or "
                                "Infinity)", line);
    std::string what = e.what();
    if (const auto p = what.find("] "); p != std::string::npos) what = what.substr(p + 2);
    throw_input_error(source, "not valid JSON: " + what, line);
  } catch (const json::out_of_range& e) {
    // "number overflow parsing '1e999'": a number beyond double range.
    std::string what = e.what();
    const std::size_t q0 = what.find('\''), q1 = what.rfind('\'');
    const std::string number = q0 != q1 ? what.substr(q0 + 1, q1 - q0 - 1) : std::string();
    const std::size_t at = number.empty() ? std::string_view::npos : text.find(number);
    const std::string key = at == std::string_view::npos ? std::string() : key_before(text, at);
    throw_input_error(source, (key.empty() ? std::string() : "key '" + key + "': ") + "the number " +
                                  number + " is not a finite double",
                      at == std::string_view::npos ? 0 : line_of(text, at));
  }
}

std::string read_text(const fs::path& path, const std::string& what) {
  if (!fs::exists(path)) throw_input_error(path, what + " not found");
  if (!fs::is_regular_file(path)) throw_input_error(path, "not a regular file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw_input_error(path, "cannot open the " + what);
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw_input_error(path, "read error");
  return text.str();
}

Eigen::Vector3d analysis_point(const json& v, const std::string& where, const fs::path& file) {
  const json* p = &v;
  if (v.is_object()) {
    if (!v.contains("position")) throw_input_error(file, where + ": expected [x, y, z] or {\"position\": [x, y, z]}");
    p = &v.at("position");
  }
  if (!p->is_array() || p->size() != 3)
    throw_input_error(file, where + ": expected [x, y, z] or {\"position\": [x, y, z]}");
  Eigen::Vector3d out;
  for (int i = 0; i < 3; ++i) {
    if (!(*p)[i].is_number() || !std::isfinite((*p)[i].get<double>()))
      throw_input_error(file, where + ": expected finite coordinates");
    out[i] = (*p)[i].get<double>();
  }
  return out;
}

}  // namespace

std::string_view to_string(ObjectShape shape) {
  switch (shape) {
    case ObjectShape::Box: return "box";
    case ObjectShape::Sphere: return "sphere";
    case ObjectShape::Mesh: return "mesh";
  }
  return "box";
}

std::string_view to_string(PersonKind kind) {
  return kind == PersonKind::Ragdoll ? "ragdoll" : "avatar";
}

std::vector<TrajectoryLine> read_trajectory_analyses(const fs::path& path) {
  const std::string text = read_text(path, "trajectory analyses file");
  const json j = parse_json(text, path);
  const json* list = &j;
  if (j.is_object()) {
    if (!j.contains("analyses")) throw_input_error(path, "expected an array of analyses or an object with 'analyses'");
    list = &j.at("analyses");
  }
  if (!list->is_array()) throw_input_error(path, "'analyses' must be an array");
  std::vector<TrajectoryLine> lines;
  for (std::size_t i = 0; i < list->size(); ++i) {
    const json& a = (*list)[i];
    const std::string where = "analyses[" + std::to_string(i) + "]";
    if (!a.is_object()) throw_input_error(path, where + ": expected an object");
    TrajectoryLine line;
    for (const char* key : {"name", "id"})
      if (line.name.empty() && a.contains(key))
        line.name = a.at(key).is_string() ? a.at(key).get<std::string>() : a.at(key).dump();
    if (line.name.empty()) throw_input_error(path, where + ": has neither 'name' nor 'id'");
    if (!a.contains("points") || !a.at("points").is_array() || a.at("points").size() < 2)
      throw_input_error(path, where + " \"" + line.name + "\": expected 'points' with at least two points");
    const json& pts = a.at("points");
    line.a = analysis_point(pts[0], where + ".points[0]", path);
    line.b = analysis_point(pts[1], where + ".points[1]", path);
    // A rod fitted to three or more points: its fitted direction (first -> last), when given.
    if (a.contains("direction")) {
      const Eigen::Vector3d d = analysis_point(a.at("direction"), where + ".direction", path);
      if (d.norm() > 1e-9) line.b = line.a + d.normalized();
    }
    if ((line.b - line.a).norm() < 1e-6)
      throw_input_error(path, where + " \"" + line.name + "\": the first two points coincide");
    line.withdrawn = a.contains("withdrawn");
    lines.push_back(line);
  }
  return lines;
}

Scenario parse_scenario(std::string_view json_text, const fs::path& source,
                        const fs::path& base_dir, const fs::path& case_dir) {
  const json j = parse_json(json_text, source);
  Reader r(j, "scenario", source);
  Scenario s;
  s.source = source;
  s.source_text = std::string(json_text);
  s.name = r.string("name");
  // A folder name: simulations/<name>. Longer than kMaxNameBytes fails the file system (255
  // bytes on ext4) after the output folder was made - checked here, before anything is written.
  constexpr std::size_t kMaxNameBytes = 100;
  if (s.name.size() > kMaxNameBytes)
    r.fail(r.place("name") + ": at most " + std::to_string(kMaxNameBytes) +
           " bytes (it names the simulation's folder), found " + std::to_string(s.name.size()));
  if (s.name.empty() || s.name == "." || s.name == ".." ||
      s.name.find_first_of("/\\") != std::string::npos ||
      std::any_of(s.name.begin(), s.name.end(), [](char c) { return static_cast<unsigned char>(c) < 0x20; }))
    r.fail(r.place("name") + ": must be a non-empty folder name without '/', '\\' or control "
                             "characters, found \"" + s.name + "\"");
  s.description = r.string_or("description", "");
  if (const json* seed = r.optional("seed")) {
    if (!seed->is_number_integer() || (!seed->is_number_unsigned() && seed->get<std::int64_t>() < 0))
      r.fail(r.place("seed") + ": expected a non-negative integer, found " + seed->dump());
    s.seed = seed->get<std::uint64_t>();
  }
  s.duration = r.in_range_or("duration", s.duration, 1e-3, 600.0);
  s.fps = r.in_range_or("fps", s.fps, 1.0, 1000.0);
  s.time_step = r.in_range_or("time_step", s.time_step, 1e-5, 0.05);
  s.gravity = r.vec3_or("gravity", s.gravity);
  s.air_density = r.non_negative_or("air_density", s.air_density);
  s.mesh = r.string_or("mesh", s.mesh.string());
  const json& projectiles = r.array("projectiles", false);
  for (std::size_t i = 0; i < projectiles.size(); ++i)
    s.projectiles.push_back(read_projectile(projectiles[i], i, source, case_dir));
  const json& objects = r.array("objects", false);
  for (std::size_t i = 0; i < objects.size(); ++i)
    s.objects.push_back(read_object(objects[i], i, source, base_dir));
  const json& people = r.array("people", false);
  for (std::size_t i = 0; i < people.size(); ++i) s.people.push_back(read_person(people[i], i, source));
  r.finish();
  if (s.projectiles.empty() && s.objects.empty() && s.people.empty())
    r.fail("scenario: nothing to simulate (no projectiles, objects or people)");
  // Names label bodies in events and nodes in the animation: they must tell bodies apart.
  std::set<std::string> names;
  auto unique = [&](const std::string& name, const std::string& list) {
    if (!names.insert(name).second)
      r.fail(list + ": the name \"" + name + "\" is used twice (names must be unique)");
  };
  for (const auto& p : s.projectiles) unique(p.name, "projectiles");
  for (const auto& o : s.objects) unique(o.name, "objects");
  for (const auto& p : s.people) unique(p.name, "people");
  return s;
}

Scenario read_scenario(const fs::path& path, const fs::path& case_dir) {
  const std::string text = read_text(path, "scenario file");
  return parse_scenario(text, path, path.parent_path(), case_dir);
}

}  // namespace locard::sim
