// Scene files: strict JSON reading. Every key is known, every required key present, every value
// of the right type and range; otherwise an InputError names the file, the place
// ("objects[2] \"bed\"") and the key, because a typo in a scene must not silently become a
// default.
#include <locard/sim/scene.hpp>

#include <locard/core/error.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/strict_json.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

namespace locard::sim {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

// StrictObject (io/strict_json.hpp) and the one thing scene files add: a texture name.
class ObjectReader : public StrictObject {
 public:
  using StrictObject::StrictObject;

  Texture texture_or(const std::string& key, Texture fallback) {
    const json* v = optional(key);
    if (!v) return fallback;
    const std::string name = string_value(*v, key);
    for (Texture t : {Texture::Plain, Texture::Checker, Texture::Noise})
      if (name == to_string(t)) return t;
    fail(place(key) + ": unknown texture '" + name + "' (known: plain, checker, noise)");
  }
};

RoomSpec read_room(const json& j, const fs::path& file) {
  ObjectReader r(j, "room", file);
  RoomSpec room;
  room.size = r.positive_vec3("size");
  room.wall_color = r.color_or("wall_color", room.wall_color);
  room.floor_color = r.color_or("floor_color", room.floor_color);
  room.ceiling_color = r.color_or("ceiling_color", room.ceiling_color);
  room.texture = r.texture_or("texture", room.texture);
  room.texture_scale = r.positive_or("texture_scale", room.texture_scale);
  r.finish();
  return room;
}

TriangleMesh read_inline_mesh(ObjectReader& r);  // below: the mesh written inline

SceneObject read_object(const json& j, std::size_t index, const fs::path& file,
                        const fs::path& base_dir) {
  std::string where = "objects[" + std::to_string(index) + "]";
  if (j.is_object() && j.contains("name") && j.at("name").is_string())
    where += " \"" + j.at("name").get<std::string>() + "\"";
  ObjectReader r(j, where, file);
  SceneObject o;
  o.name = r.string("name");
  const std::string shape = r.string("shape");
  o.center = r.vec3("center");
  o.yaw_deg = r.number_or("yaw_deg", 0.0);
  o.color = r.color_or("color", o.color, &o.has_color);
  o.texture = r.texture_or("texture", o.texture);
  o.texture_scale = r.positive_or("texture_scale", o.texture_scale);
  if (shape == "box") {
    o.shape = ShapeKind::Box;
    o.size = r.positive_vec3("size");
  } else if (shape == "cylinder") {
    o.shape = ShapeKind::Cylinder;
    o.radius = r.positive("radius");
    o.height = r.positive("height");
    const double segments = r.number_or("segments", o.segments);
    if (segments < 3 || segments > 4096 || segments != std::floor(segments))
      r.fail(r.place("segments") + ": expected an integer from 3 to 4096");
    o.segments = static_cast<int>(segments);
  } else if (shape == "mesh") {
    o.shape = ShapeKind::Mesh;
    // Either a PLY file or the mesh inline ("vertices" + "triangles", e.g. a generated room).
    if (r.has("vertices") || r.has("triangles")) {
      if (r.has("file")) r.fail(where + ": give either 'file' or 'vertices' + 'triangles', not both");
      o.mesh = read_inline_mesh(r);
    } else {
      o.file = r.string("file");
      if (o.file.is_relative()) o.file = base_dir / o.file;
    }
    o.scale = r.positive_or("scale", 1.0);
  } else {
    r.fail(r.place("shape") + ": unknown shape '" + shape + "' (known: box, cylinder, mesh)");
  }
  r.finish();
  if (o.shape == ShapeKind::Mesh && !o.file.empty()) {
    if (!fs::is_regular_file(o.file))
      r.fail(where + ".file: mesh file not found: " + o.file.string());
    o.mesh = read_ply_mesh(o.file);
    if (o.mesh.triangles.empty())
      throw_input_error(o.file, "mesh of " + where + " has no triangles");
  }
  return o;
}

// "vertices": [[x, y, z], ...] and "triangles": [[i, j, k], ...] (counter-clockwise seen from
// outside, indices into vertices), in the object frame like a PLY's.
TriangleMesh read_inline_mesh(ObjectReader& r) {
  const json& vertices = r.required("vertices");
  const json& triangles = r.required("triangles");
  if (!vertices.is_array() || vertices.empty())
    r.fail(r.place("vertices") + ": expected a non-empty array of [x, y, z], found " +
           ObjectReader::describe(vertices));
  if (!triangles.is_array() || triangles.empty())
    r.fail(r.place("triangles") + ": expected a non-empty array of [i, j, k], found " +
           ObjectReader::describe(triangles));
  TriangleMesh mesh;
  for (std::size_t i = 0; i < vertices.size(); ++i)
    mesh.vertices.push_back(
        r.vec3_value(vertices[i], "vertices[" + std::to_string(i) + "]").cast<float>());
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    const json& t = triangles[i];
    const std::string key = "triangles[" + std::to_string(i) + "]";
    if (!t.is_array() || t.size() != 3)
      r.fail(r.place(key) + ": expected 3 vertex indices, found " + ObjectReader::describe(t));
    std::array<std::uint32_t, 3> tri{};
    for (int k = 0; k < 3; ++k) {
      if (!t[k].is_number_integer() || t[k].get<std::int64_t>() < 0 ||
          t[k].get<std::int64_t>() >= static_cast<std::int64_t>(mesh.vertices.size()))
        r.fail(r.place(key) + ": expected vertex indices from 0 to " +
               std::to_string(mesh.vertices.size() - 1) + ", found " + t.dump());
      tri[static_cast<std::size_t>(k)] = static_cast<std::uint32_t>(t[k].get<std::int64_t>());
    }
    mesh.triangles.push_back(tri);
  }
  return mesh;
}

Measurement read_measurement(const json& j, std::size_t index, const fs::path& file) {
  ObjectReader r(j, "measurements[" + std::to_string(index) + "]", file);
  Measurement m;
  m.name = r.string("name");
  m.a = r.vec3("a");
  m.b = r.vec3("b");
  r.finish();
  return m;
}

ScannerSpec read_scanner(const json& j, const fs::path& file) {
  ObjectReader r(j, "scanner", file);
  ScannerSpec s;
  const std::string model = r.string_or("model", std::string(to_string(s.model)));
  const std::optional<ScannerModel> parsed = parse_scanner_model(model);
  if (!parsed)
    r.fail(r.place("model") + ": unknown scanner model '" + model +
           "' (known: kinect_v2, kinect_v1)");
  s.model = *parsed;
  s.position = r.vec3_or("position", s.position);
  // "views": one count for every pitch row, or an array with one count a row.
  const auto view_count = [&](const json& v, const std::string& where) {
    const double views = r.number_value(v, where);
    if (views < 1 || views > 100000 || views != std::floor(views))
      r.fail(r.place(where) + ": expected an integer from 1 to 100000");
    return static_cast<int>(views);
  };
  if (const json* views = r.optional("views")) {
    if (views->is_array()) {
      if (views->empty()) r.fail(r.place("views") + ": expected one view count a pitch row");
      for (std::size_t i = 0; i < views->size(); ++i)
        s.ring_views.push_back(view_count((*views)[i], "views[" + std::to_string(i) + "]"));
      s.views = s.ring_views.front();
    } else {
      s.views = view_count(*views, "views");
    }
  }
  if (const json* pitch = r.optional("pitch_deg")) {
    if (!pitch->is_array() || pitch->empty())
      r.fail(r.place("pitch_deg") + ": expected a non-empty array of angles in degrees, found " +
             ObjectReader::describe(*pitch));
    s.pitch_deg.clear();
    for (std::size_t i = 0; i < pitch->size(); ++i) {
      const double p = r.number_value((*pitch)[i], "pitch_deg[" + std::to_string(i) + "]");
      if (p < -90.0 || p > 90.0) r.fail(r.place("pitch_deg") + ": angles must lie in [-90, 90]");
      s.pitch_deg.push_back(p);
    }
  }
  if (!s.ring_views.empty() && s.ring_views.size() != s.pitch_deg.size())
    r.fail(r.place("views") + fmt::format(": {} view counts for {} pitch rows (one a row, or one "
                                          "number for all)",
                                          s.ring_views.size(), s.pitch_deg.size()));
  s.yaw_jitter_deg = r.non_negative_or("yaw_jitter_deg", s.yaw_jitter_deg);
  s.position_jitter_m = r.non_negative_or("position_jitter_m", s.position_jitter_m);
  if (const json* seed = r.optional("seed")) {
    if (!seed->is_number_integer() || (seed->is_number_integer() && !seed->is_number_unsigned() &&
                                       seed->get<std::int64_t>() < 0))
      r.fail(r.place("seed") + ": expected a non-negative integer, found " + seed->dump());
    s.seed = seed->get<std::uint64_t>();
  }
  s.noise = r.boolean_or("noise", s.noise);
  r.finish();
  return s;
}

// 1-based line of a byte offset, for parse errors.
long line_of(std::string_view text, std::size_t byte) {
  byte = std::min(byte, text.size());
  return 1 + static_cast<long>(std::count(text.begin(), text.begin() + static_cast<long>(byte), '\n'));
}

}  // namespace

std::string_view to_string(Texture texture) {
  switch (texture) {
    case Texture::Plain: return "plain";
    case Texture::Checker: return "checker";
    case Texture::Noise: return "noise";
  }
  return "plain";
}

std::string_view to_string(ScannerModel model) {
  switch (model) {
    case ScannerModel::KinectV2: return "kinect_v2";
    case ScannerModel::KinectV1: return "kinect_v1";
  }
  return "kinect_v2";
}

std::optional<ScannerModel> parse_scanner_model(std::string_view name) {
  for (ScannerModel m : {ScannerModel::KinectV2, ScannerModel::KinectV1})
    if (name == to_string(m)) return m;
  return std::nullopt;
}

std::string_view to_string(ShapeKind shape) {
  switch (shape) {
    case ShapeKind::Box: return "box";
    case ShapeKind::Cylinder: return "cylinder";
    case ShapeKind::Mesh: return "mesh";
  }
  return "box";
}

Scene parse_scene(std::string_view json_text, const fs::path& source, const fs::path& base_dir) {
  json j;
  try {
    j = json::parse(json_text.begin(), json_text.end());
  } catch (const json::parse_error& e) {
    // e.what() reads "[json.exception.parse_error.101] parse error at line 3, column 5: ...".
    std::string what = e.what();
    if (const auto p = what.find("] "); p != std::string::npos) what = what.substr(p + 2);
    throw_input_error(source, "not valid JSON: " + what, line_of(json_text, e.byte ? e.byte - 1 : 0));
  } catch (const json::out_of_range& e) {
    // "number overflow parsing '1e400'": a number beyond the range of a double.
    std::string what = e.what();
    if (const auto p = what.find("] "); p != std::string::npos) what = what.substr(p + 2);
    const std::size_t q0 = what.find('\''), q1 = what.rfind('\'');
    const std::size_t at = q0 != q1 ? json_text.find(what.substr(q0 + 1, q1 - q0 - 1)) : 0;
    throw_input_error(source, "not valid JSON: " + what + " (not a finite double)",
                      line_of(json_text, at == std::string_view::npos ? 0 : at));
  }
  ObjectReader r(j, "scene", source);
  Scene scene;
  scene.source = source;
  scene.source_text = std::string(json_text);
  scene.name = r.string_or("name", source.stem().string());
  if (scene.name.empty()) r.fail("scene.name: must not be empty");
  scene.room = read_room(r.required("room"), source);
  const json& objects = r.array("objects", false);
  for (std::size_t i = 0; i < objects.size(); ++i)
    scene.objects.push_back(read_object(objects[i], i, source, base_dir));
  const json& measurements = r.array("measurements", false);
  for (std::size_t i = 0; i < measurements.size(); ++i)
    scene.measurements.push_back(read_measurement(measurements[i], i, source));
  if (const json* scanner = r.optional("scanner")) scene.scanner = read_scanner(*scanner, source);
  r.finish();
  return scene;
}

namespace {

using ordered_json = nlohmann::ordered_json;

ordered_json vec3_json(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
ordered_json color_json(Rgb8 c) { return {c.r, c.g, c.b}; }
// A float as the shortest decimal that reads back to the same float: compact and exact.
double shortest(float x) { return std::strtod(fmt::format("{}", x).c_str(), nullptr); }

ordered_json object_json(const SceneObject& o) {
  ordered_json j;
  j["name"] = o.name;
  j["shape"] = to_string(o.shape);
  j["center"] = vec3_json(o.center);
  j["yaw_deg"] = o.yaw_deg;
  if (o.shape != ShapeKind::Mesh || o.has_color) j["color"] = color_json(o.color);
  j["texture"] = to_string(o.texture);
  j["texture_scale"] = o.texture_scale;
  switch (o.shape) {
    case ShapeKind::Box: j["size"] = vec3_json(o.size); break;
    case ShapeKind::Cylinder:
      j["radius"] = o.radius;
      j["height"] = o.height;
      j["segments"] = o.segments;
      break;
    case ShapeKind::Mesh:
      if (!o.file.empty()) {
        j["file"] = o.file.string();
      } else {
        ordered_json vertices = ordered_json::array();
        for (const Eigen::Vector3f& v : o.mesh.vertices)
          vertices.push_back({shortest(v.x()), shortest(v.y()), shortest(v.z())});
        ordered_json triangles = ordered_json::array();
        for (const auto& t : o.mesh.triangles) triangles.push_back({t[0], t[1], t[2]});
        j["vertices"] = std::move(vertices);
        j["triangles"] = std::move(triangles);
      }
      j["scale"] = o.scale;
      break;
  }
  return j;
}

}  // namespace

std::string scene_json(const Scene& scene) {
  ordered_json room;
  room["size"] = vec3_json(scene.room.size);
  room["wall_color"] = color_json(scene.room.wall_color);
  room["floor_color"] = color_json(scene.room.floor_color);
  room["ceiling_color"] = color_json(scene.room.ceiling_color);
  room["texture"] = to_string(scene.room.texture);
  room["texture_scale"] = scene.room.texture_scale;
  const ScannerSpec& sc = scene.scanner;
  ordered_json scanner;
  scanner["model"] = to_string(sc.model);
  scanner["position"] = vec3_json(sc.position);
  if (sc.ring_views.empty()) scanner["views"] = sc.views;
  else scanner["views"] = sc.ring_views;
  scanner["pitch_deg"] = sc.pitch_deg;
  scanner["yaw_jitter_deg"] = sc.yaw_jitter_deg;
  scanner["position_jitter_m"] = sc.position_jitter_m;
  scanner["seed"] = sc.seed;
  scanner["noise"] = sc.noise;

  std::string out = "{\n  \"name\": " + ordered_json(scene.name).dump() + ",\n  \"room\": " +
                    room.dump() + ",\n  \"objects\": [";
  for (std::size_t i = 0; i < scene.objects.size(); ++i)
    out += (i ? ",\n    " : "\n    ") + object_json(scene.objects[i]).dump();
  out += scene.objects.empty() ? "],\n" : "\n  ],\n";
  out += "  \"measurements\": [";
  for (std::size_t i = 0; i < scene.measurements.size(); ++i) {
    const Measurement& m = scene.measurements[i];
    ordered_json j;
    j["name"] = m.name;
    j["a"] = vec3_json(m.a);
    j["b"] = vec3_json(m.b);
    out += (i ? ",\n    " : "\n    ") + j.dump();
  }
  out += scene.measurements.empty() ? "],\n" : "\n  ],\n";
  out += "  \"scanner\": " + scanner.dump() + "\n}\n";
  return out;
}

Scene read_scene(const fs::path& path) {
  if (!fs::exists(path)) throw_input_error(path, "scene file not found");
  if (!fs::is_regular_file(path)) throw_input_error(path, "not a regular file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw_input_error(path, "cannot open the scene file");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw_input_error(path, "read error");
  return parse_scene(text.str(), path, path.parent_path());
}

}  // namespace locard::sim
