// Animated GLB of a simulation (layout in physics_gltf.hpp).
#include <locard/sim/physics_gltf.hpp>

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>

namespace locard::sim {
namespace {

using nlohmann::json;

constexpr int kFloat = 5126;
constexpr int kUint32 = 5125;
constexpr int kArrayBuffer = 34962;
constexpr int kElementArrayBuffer = 34963;

struct Geometry {
  std::vector<float> positions;  // xyz
  std::vector<std::uint32_t> indices;
};

void add_vertex(Geometry& g, double x, double y, double z) {
  g.positions.push_back(static_cast<float>(x));
  g.positions.push_back(static_cast<float>(y));
  g.positions.push_back(static_cast<float>(z));
}

Geometry box_geometry(const Eigen::Vector3d& size) {
  Geometry g;
  const Eigen::Vector3d h = size / 2.0;
  for (int i = 0; i < 8; ++i)
    add_vertex(g, (i & 1) ? h.x() : -h.x(), (i & 2) ? h.y() : -h.y(), (i & 4) ? h.z() : -h.z());
  // Counter-clockwise seen from outside.
  g.indices = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
               2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
  return g;
}

// A sphere (length 0) or a capsule along z: latitude rings, the upper half raised by length/2
// and the lower half lowered by it.
Geometry capsule_geometry(double radius, double length, int rings = 12, int segments = 16) {
  Geometry g;
  add_vertex(g, 0, 0, radius + length / 2);
  for (int r = 1; r < rings; ++r) {
    const double theta = std::numbers::pi * r / rings;
    const double z = radius * std::cos(theta) + (r * 2 <= rings ? length / 2 : -length / 2);
    for (int s = 0; s < segments; ++s) {
      const double phi = 2.0 * std::numbers::pi * s / segments;
      add_vertex(g, radius * std::sin(theta) * std::cos(phi), radius * std::sin(theta) * std::sin(phi), z);
    }
    if (r * 2 == rings)  // the equator twice: the cylinder between the two hemispheres
      for (int s = 0; s < segments; ++s) {
        const double phi = 2.0 * std::numbers::pi * s / segments;
        add_vertex(g, radius * std::cos(phi), radius * std::sin(phi), -length / 2);
      }
  }
  add_vertex(g, 0, 0, -radius - length / 2);
  const auto n_rings = static_cast<std::uint32_t>(rings - 1 + 1);  // latitude rings + equator copy
  const auto seg = static_cast<std::uint32_t>(segments);
  const auto last = static_cast<std::uint32_t>(g.positions.size() / 3 - 1);
  auto ring = [&](std::uint32_t r, std::uint32_t s) { return 1 + r * seg + (s % seg); };
  for (std::uint32_t s = 0; s < seg; ++s) g.indices.insert(g.indices.end(), {0, ring(0, s), ring(0, s + 1)});
  for (std::uint32_t r = 0; r + 1 < n_rings; ++r)
    for (std::uint32_t s = 0; s < seg; ++s)
      g.indices.insert(g.indices.end(), {ring(r, s), ring(r + 1, s), ring(r + 1, s + 1), ring(r, s),
                                         ring(r + 1, s + 1), ring(r, s + 1)});
  for (std::uint32_t s = 0; s < seg; ++s)
    g.indices.insert(g.indices.end(), {last, ring(n_rings - 1, s + 1), ring(n_rings - 1, s)});
  return g;
}

Geometry mesh_geometry(const TriangleMesh& mesh) {
  Geometry g;
  for (const auto& v : mesh.vertices) add_vertex(g, v.x(), v.y(), v.z());
  for (const auto& t : mesh.triangles) g.indices.insert(g.indices.end(), t.begin(), t.end());
  return g;
}

class GlbBuilder {
 public:
  // A bufferView + accessor over `count` elements of `type` ("SCALAR", "VEC3", ...).
  template <typename T>
  int accessor(const std::vector<T>& data, int component, const char* type, int components,
               int target, bool min_max) {
    while (bin_.size() % 4) bin_.push_back(0);
    const std::size_t offset = bin_.size();
    const std::size_t bytes = data.size() * sizeof(T);
    bin_.resize(offset + bytes);
    if (bytes) std::memcpy(bin_.data() + offset, data.data(), bytes);
    json view = {{"buffer", 0}, {"byteOffset", offset}, {"byteLength", bytes}};
    if (target) view["target"] = target;
    views_.push_back(view);
    json acc = {{"bufferView", views_.size() - 1},
                {"componentType", component},
                {"count", data.size() / static_cast<std::size_t>(components)},
                {"type", type}};
    if (min_max && !data.empty()) {
      json lo = json::array(), hi = json::array();
      for (int c = 0; c < components; ++c) {
        double a = std::numeric_limits<double>::max(), b = std::numeric_limits<double>::lowest();
        for (std::size_t i = static_cast<std::size_t>(c); i < data.size(); i += static_cast<std::size_t>(components)) {
          a = std::min(a, static_cast<double>(data[i]));
          b = std::max(b, static_cast<double>(data[i]));
        }
        lo.push_back(a);
        hi.push_back(b);
      }
      acc["min"] = lo;
      acc["max"] = hi;
    }
    accessors_.push_back(acc);
    return static_cast<int>(accessors_.size() - 1);
  }

  int material(Rgb8 color, const std::string& name) {
    materials_.push_back({{"name", name},
                          {"pbrMetallicRoughness",
                           {{"baseColorFactor", {color.r / 255.0, color.g / 255.0, color.b / 255.0, 1.0}},
                            {"metallicFactor", 0.0},
                            {"roughnessFactor", 0.8}}}});
    return static_cast<int>(materials_.size() - 1);
  }

  int mesh(const std::string& name, const Geometry& g, int material_index, int mode = 4) {
    json primitive = {{"attributes", {{"POSITION", accessor(g.positions, kFloat, "VEC3", 3, kArrayBuffer, true)}}},
                      {"material", material_index},
                      {"mode", mode}};
    if (!g.indices.empty())
      primitive["indices"] = accessor(g.indices, kUint32, "SCALAR", 1, kElementArrayBuffer, false);
    meshes_.push_back({{"name", name}, {"primitives", json::array({primitive})}});
    return static_cast<int>(meshes_.size() - 1);
  }

  json views_ = json::array(), accessors_ = json::array(), materials_ = json::array(),
       meshes_ = json::array();
  std::vector<std::uint8_t> bin_;
};

std::vector<float> to_floats(const std::vector<double>& v) {
  std::vector<float> out(v.size());
  std::transform(v.begin(), v.end(), out.begin(), [](double x) { return static_cast<float>(x); });
  return out;
}

}  // namespace

std::vector<std::uint8_t> simulation_glb(const Scenario& scenario, const SimulationResult& result) {
  GlbBuilder b;
  const std::string label(kIllustrativeLabel);
  json nodes = json::array();
  json root_children = json::array();
  json channels = json::array(), samplers = json::array();
  nodes.push_back({{"name", "simulation (illustrative)"},
                   {"rotation", {-std::numbers::sqrt2 / 2, 0.0, 0.0, std::numbers::sqrt2 / 2}},
                   {"children", json::array()},
                   {"extras", {{"label", label}, {"frame", "children in Locard's z-up world"}}}});
  int shared_input = -1;
  auto sampler = [&](int input, int output, const char* interpolation) {
    samplers.push_back({{"input", input}, {"output", output}, {"interpolation", interpolation}});
    return static_cast<int>(samplers.size() - 1);
  };
  auto channel = [&](int sampler_index, std::size_t node, const char* path) {
    channels.push_back({{"sampler", sampler_index}, {"target", {{"node", node}, {"path", path}}}});
  };
  // STEP scale 0 -> 1 at the fire time, so a projectile and its trail appear when fired.
  auto visibility = [&](std::size_t node, double from) {
    std::vector<float> times{0.0f}, scales{0, 0, 0};
    if (from > 0.0) {
      times.push_back(static_cast<float>(from));
      scales.insert(scales.end(), {1, 1, 1});
    } else {
      scales = {1, 1, 1};
    }
    const int in = b.accessor(times, kFloat, "SCALAR", 1, 0, true);
    const int out = b.accessor(scales, kFloat, "VEC3", 3, 0, false);
    channel(sampler(in, out, "STEP"), node, "scale");
  };

  for (const BodyTrack& t : result.tracks) {
    Geometry g;
    switch (t.geometry) {
      case TrackGeometry::Box: g = box_geometry(t.size); break;
      case TrackGeometry::Sphere: g = capsule_geometry(t.radius, 0.0); break;
      case TrackGeometry::Capsule: g = capsule_geometry(t.radius, t.length); break;
      case TrackGeometry::Mesh: g = mesh_geometry(t.mesh); break;
    }
    const int mesh = b.mesh(t.name, g, b.material(t.color, t.name));
    const std::size_t node = nodes.size();
    json n = {{"name", t.name}, {"mesh", mesh},
              {"extras", {{"label", label}, {"kind", t.kind}, {"body", t.owner}}}};
    if (!t.positions.empty()) {
      const Eigen::Vector3d& p = t.positions.front();
      const Eigen::Quaterniond& q = t.rotations.front();
      n["translation"] = {p.x(), p.y(), p.z()};
      n["rotation"] = {q.x(), q.y(), q.z(), q.w()};
    }
    nodes.push_back(n);
    root_children.push_back(node);
    if (t.times.empty()) continue;
    int input;
    if (t.kind != "projectile" && t.times == result.frame_times) {
      if (shared_input < 0) shared_input = b.accessor(to_floats(result.frame_times), kFloat, "SCALAR", 1, 0, true);
      input = shared_input;
    } else {
      input = b.accessor(to_floats(t.times), kFloat, "SCALAR", 1, 0, true);
    }
    std::vector<float> translation, rotation;
    for (std::size_t i = 0; i < t.times.size(); ++i) {
      const Eigen::Vector3d& p = t.positions[i];
      // Keep quaternions on one hemisphere so LINEAR interpolation takes the short way.
      Eigen::Quaterniond q = t.rotations[i].normalized();
      if (i > 0 && q.coeffs().dot(Eigen::Vector4d(rotation[rotation.size() - 4], rotation[rotation.size() - 3],
                                                   rotation[rotation.size() - 2], rotation[rotation.size() - 1])) < 0)
        q.coeffs() *= -1.0;
      translation.insert(translation.end(), {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())});
      rotation.insert(rotation.end(), {static_cast<float>(q.x()), static_cast<float>(q.y()),
                                       static_cast<float>(q.z()), static_cast<float>(q.w())});
    }
    channel(sampler(input, b.accessor(translation, kFloat, "VEC3", 3, 0, false), "LINEAR"), node, "translation");
    channel(sampler(input, b.accessor(rotation, kFloat, "VEC4", 4, 0, false), "LINEAR"), node, "rotation");
    if (t.kind == "projectile") {
      visibility(node, t.visible_from);
      if (t.trail.size() >= 2) {
        Geometry line;
        for (const auto& p : t.trail) add_vertex(line, p.x(), p.y(), p.z());
        const int trail_mesh = b.mesh(t.name + " trail", line, b.material({255, 60, 60}, t.name + " trail"), 3);
        const std::size_t trail_node = nodes.size();
        nodes.push_back({{"name", t.name + " trail"}, {"mesh", trail_mesh},
                         {"extras", {{"label", label}, {"kind", "trail"}, {"body", t.owner}}}});
        root_children.push_back(trail_node);
        visibility(trail_node, t.visible_from);
      }
    }
  }
  nodes[0]["children"] = root_children;

  json gltf;
  gltf["asset"] = {{"version", "2.0"},
                   {"generator", std::string("Locard ") + LOCARD_VERSION + " simulate"},
                   {"extras", {{"label", label},
                               {"scenario", scenario.name},
                               {"seed", scenario.seed},
                               {"duration_s", scenario.duration},
                               {"time_step_s", scenario.time_step},
                               {"fps", scenario.fps},
                               {"units", "metres, seconds"}}}};
  gltf["scene"] = 0;
  gltf["scenes"] = json::array({{{"name", scenario.name + " (illustrative)"}, {"nodes", {0}},
                                 {"extras", {{"label", label}}}}});
  gltf["nodes"] = nodes;
  gltf["meshes"] = b.meshes_;
  gltf["materials"] = b.materials_;
  gltf["accessors"] = b.accessors_;
  gltf["bufferViews"] = b.views_;
  if (!channels.empty())
    gltf["animations"] = json::array({{{"name", "simulation"}, {"channels", channels}, {"samplers", samplers}}});
  while (b.bin_.size() % 4) b.bin_.push_back(0);
  gltf["buffers"] = json::array({{{"byteLength", b.bin_.size()}}});

  std::string text = gltf.dump();
  while (text.size() % 4) text.push_back(' ');
  std::vector<std::uint8_t> out;
  auto put32 = [&](std::uint32_t v) {
    for (int k = 0; k < 4; ++k) out.push_back(static_cast<std::uint8_t>(v >> (8 * k)));
  };
  const auto total = static_cast<std::uint32_t>(12 + 8 + text.size() + 8 + b.bin_.size());
  put32(0x46546C67u);  // "glTF"
  put32(2u);
  put32(total);
  put32(static_cast<std::uint32_t>(text.size()));
  put32(0x4E4F534Au);  // "JSON"
  out.insert(out.end(), text.begin(), text.end());
  put32(static_cast<std::uint32_t>(b.bin_.size()));
  put32(0x004E4942u);  // "BIN\0"
  out.insert(out.end(), b.bin_.begin(), b.bin_.end());
  return out;
}

void write_simulation_glb(const std::filesystem::path& path, const Scenario& scenario,
                          const SimulationResult& result) {
  const std::vector<std::uint8_t> bytes = simulation_glb(scenario, result);
  AtomicFile file(path);
  file.stream().write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  file.commit();
}

}  // namespace locard::sim
