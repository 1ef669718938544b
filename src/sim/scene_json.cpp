// Scene files: strict JSON reading. Every key is known, every required key present, every value
// of the right type and range; otherwise an InputError names the file, the place
// ("objects[2] \"bed\"") and the key, because a typo in a scene must not silently become a
// default.
#include <locard/sim/scene.hpp>

#include <locard/core/error.hpp>
#include <locard/io/ply.hpp>

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

std::string type_phrase(const json& j) {
  switch (j.type()) {
    case json::value_t::null: return "null";
    case json::value_t::boolean: return "a boolean";
    case json::value_t::string: return "a string";
    case json::value_t::array: return "an array";
    case json::value_t::object: return "an object";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float: return "a number";
    default: return "a value of another type";
  }
}

// Reads one JSON object, remembering which keys were used so that leftovers can be reported.
class ObjectReader {
 public:
  ObjectReader(const json& j, std::string where, const fs::path& file)
      : j_(j), where_(std::move(where)), file_(file) {
    if (!j_.is_object()) fail(where_ + ": expected an object, found " + type_phrase(j_));
  }

  [[noreturn]] void fail(const std::string& what) const { throw_input_error(file_, what); }
  std::string place(const std::string& key) const { return where_ + "." + key; }

  bool has(const std::string& key) const { return j_.contains(key); }

  const json& required(const std::string& key) {
    known_.insert(key);
    if (!j_.contains(key)) fail(where_ + ": missing required key '" + key + "'");
    return j_.at(key);
  }
  const json* optional(const std::string& key) {
    known_.insert(key);
    return j_.contains(key) ? &j_.at(key) : nullptr;
  }

  double number(const json& value, const std::string& key) const {
    if (!value.is_number())
      fail(place(key) + ": expected a number, found " + type_phrase(value));
    const double x = value.get<double>();
    if (!std::isfinite(x)) fail(place(key) + ": expected a finite number");
    return x;
  }
  double number(const std::string& key) { return number(required(key), key); }
  double number_or(const std::string& key, double fallback) {
    const json* v = optional(key);
    return v ? number(*v, key) : fallback;
  }
  double positive(const std::string& key, std::optional<double> fallback = std::nullopt) {
    const double x = fallback ? number_or(key, *fallback) : number(key);
    if (!(x > 0.0)) fail(place(key) + ": expected a positive number, found " + fmt_number(x));
    return x;
  }
  double non_negative_or(const std::string& key, double fallback) {
    const double x = number_or(key, fallback);
    if (x < 0.0) fail(place(key) + ": expected a number >= 0, found " + fmt_number(x));
    return x;
  }

  std::string string(const std::string& key) { return string_value(required(key), key); }
  std::string string_or(const std::string& key, const std::string& fallback) {
    const json* v = optional(key);
    return v ? string_value(*v, key) : fallback;
  }
  std::string string_value(const json& value, const std::string& key) const {
    if (!value.is_string())
      fail(place(key) + ": expected a string, found " + type_phrase(value));
    return value.get<std::string>();
  }

  bool boolean_or(const std::string& key, bool fallback) {
    const json* v = optional(key);
    if (!v) return fallback;
    if (!v->is_boolean()) fail(place(key) + ": expected true or false, found " + type_phrase(*v));
    return v->get<bool>();
  }

  Eigen::Vector3d vec3(const std::string& key) { return vec3_value(required(key), key); }
  Eigen::Vector3d vec3_or(const std::string& key, const Eigen::Vector3d& fallback) {
    const json* v = optional(key);
    return v ? vec3_value(*v, key) : fallback;
  }
  Eigen::Vector3d vec3_value(const json& value, const std::string& key) const {
    if (!value.is_array() || value.size() != 3)
      fail(place(key) + ": expected an array of 3 numbers, found " + describe(value));
    Eigen::Vector3d out;
    for (int i = 0; i < 3; ++i) out[i] = number(value[i], key + "[" + std::to_string(i) + "]");
    return out;
  }
  Eigen::Vector3d positive_vec3(const std::string& key) {
    const Eigen::Vector3d v = vec3(key);
    if ((v.array() <= 0.0).any())
      fail(place(key) + ": expected three positive sizes, found [" + fmt_number(v.x()) + ", " +
           fmt_number(v.y()) + ", " + fmt_number(v.z()) + "]");
    return v;
  }

  Rgb8 color_or(const std::string& key, Rgb8 fallback, bool* given = nullptr) {
    const json* v = optional(key);
    if (given) *given = v != nullptr;
    if (!v) return fallback;
    if (!v->is_array() || v->size() != 3)
      fail(place(key) + ": expected an RGB array of 3 integers 0..255, found " + describe(*v));
    std::uint8_t c[3];
    for (int i = 0; i < 3; ++i) {
      const json& x = (*v)[i];
      if (!x.is_number_integer() || x.get<std::int64_t>() < 0 || x.get<std::int64_t>() > 255)
        fail(place(key) + ": expected an RGB array of 3 integers 0..255, found " + v->dump());
      c[i] = static_cast<std::uint8_t>(x.get<std::int64_t>());
    }
    return {c[0], c[1], c[2]};
  }

  Texture texture_or(const std::string& key, Texture fallback) {
    const json* v = optional(key);
    if (!v) return fallback;
    const std::string name = string_value(*v, key);
    for (Texture t : {Texture::Plain, Texture::Checker, Texture::Noise})
      if (name == to_string(t)) return t;
    fail(place(key) + ": unknown texture '" + name + "' (known: plain, checker, noise)");
  }

  // Every key present must have been asked for.
  void finish() const {
    for (const auto& item : j_.items()) {
      if (known_.count(item.key())) continue;
      std::string expected;
      for (const auto& k : known_) expected += (expected.empty() ? "" : ", ") + k;
      fail(where_ + ": unknown key '" + item.key() + "' (expected one of: " + expected + ")");
    }
  }

  static std::string fmt_number(double x) {
    std::ostringstream s;
    s << x;
    return s.str();
  }
  static std::string describe(const json& v) {
    return v.is_array() ? "an array of " + std::to_string(v.size()) : type_phrase(v);
  }

 private:
  const json& j_;
  std::string where_;
  const fs::path& file_;
  std::set<std::string> known_;
};

const json& array_at(ObjectReader& r, const std::string& key, bool required) {
  static const json kEmpty = json::array();
  const json* v = required ? &r.required(key) : r.optional(key);
  if (!v) return kEmpty;
  if (!v->is_array()) r.fail(key + ": expected an array, found " + type_phrase(*v));
  return *v;
}

RoomSpec read_room(const json& j, const fs::path& file) {
  ObjectReader r(j, "room", file);
  RoomSpec room;
  room.size = r.positive_vec3("size");
  room.wall_color = r.color_or("wall_color", room.wall_color);
  room.floor_color = r.color_or("floor_color", room.floor_color);
  room.ceiling_color = r.color_or("ceiling_color", room.ceiling_color);
  room.texture = r.texture_or("texture", room.texture);
  room.texture_scale = r.positive("texture_scale", room.texture_scale);
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
  o.texture_scale = r.positive("texture_scale", o.texture_scale);
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
    o.scale = r.positive("scale", 1.0);
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
    const double views = r.number(v, where);
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
      const double p = r.number((*pitch)[i], "pitch_deg[" + std::to_string(i) + "]");
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
  const json& objects = array_at(r, "objects", false);
  for (std::size_t i = 0; i < objects.size(); ++i)
    scene.objects.push_back(read_object(objects[i], i, source, base_dir));
  const json& measurements = array_at(r, "measurements", false);
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
