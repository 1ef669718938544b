// Scene files: strict JSON reading. Every key is known, every required key present, every value
// of the right type and range; otherwise an InputError names the file, the place
// ("objects[2] \"bed\"") and the key, because a typo in a scene must not silently become a
// default.
#include <locard/sim/scene.hpp>

#include <locard/core/error.hpp>
#include <locard/io/ply.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
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
    o.file = r.string("file");
    if (o.file.is_relative()) o.file = base_dir / o.file;
    o.scale = r.positive("scale", 1.0);
  } else {
    r.fail(r.place("shape") + ": unknown shape '" + shape + "' (known: box, cylinder, mesh)");
  }
  r.finish();
  if (o.shape == ShapeKind::Mesh) {
    if (!fs::is_regular_file(o.file))
      r.fail(where + ".file: mesh file not found: " + o.file.string());
    o.mesh = read_ply_mesh(o.file);
    if (o.mesh.triangles.empty())
      throw_input_error(o.file, "mesh of " + where + " has no triangles");
  }
  return o;
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
  s.model = r.string_or("model", s.model);
  if (s.model != "kinect_v2")
    r.fail(r.place("model") + ": unknown scanner model '" + s.model + "' (known: kinect_v2)");
  s.position = r.vec3_or("position", s.position);
  const double views = r.number_or("views", s.views);
  if (views < 1 || views > 100000 || views != std::floor(views))
    r.fail(r.place("views") + ": expected an integer from 1 to 100000");
  s.views = static_cast<int>(views);
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
