#include <locard/sim/measurements.hpp>

#include <locard/core/atomic_file.hpp>
#include <locard/sim/scene_mesh.hpp>

#include <nlohmann/json.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace locard::sim {
namespace {

Measurement box_extent(const SceneObject& o, const Eigen::Vector3d& scanner) {
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(o.yaw_deg * std::numbers::pi / 180.0, Eigen::Vector3d::UnitZ())
          .toRotationMatrix();
  const Eigen::Vector3d half = 0.5 * o.size;
  int k = 0;
  o.size.maxCoeff(&k);
  // The edge along the longest axis that is nearest the scanner, so it is likely in view.
  const Eigen::Vector3d toward = R.transpose() * (scanner - o.center);
  Eigen::Vector3d corner;
  for (int i = 0; i < 3; ++i) corner[i] = (toward[i] >= 0.0 ? 1.0 : -1.0) * half[i];
  Eigen::Vector3d a_local = corner, b_local = corner;
  a_local[k] = -half[k];
  b_local[k] = half[k];
  Measurement m;
  m.a = o.center + R * a_local;
  m.b = o.center + R * b_local;
  return m;
}

Measurement cylinder_extent(const SceneObject& o, const Eigen::Vector3d& scanner) {
  // Rim points are taken at the facet vertices, which lie on the mesh (a chord would not).
  const int n = std::max(o.segments, 3);
  const Eigen::Vector3d toward = scanner - o.center;
  const double facing = std::atan2(toward.y(), toward.x());
  auto vertex_index = [&](double phi) {
    const double step = 2.0 * std::numbers::pi / n;
    long k = std::lround(phi / step);
    return static_cast<int>(((k % n) + n) % n);
  };
  auto rim = [&](int k, double z) {
    const double phi = 2.0 * std::numbers::pi * k / n;
    return Eigen::Vector3d(o.center.x() + o.radius * std::cos(phi),
                           o.center.y() + o.radius * std::sin(phi), z);
  };
  const double z0 = o.center.z() - 0.5 * o.height;
  const double z1 = o.center.z() + 0.5 * o.height;
  Measurement m;
  if (o.height >= 2.0 * o.radius) {
    const int k = vertex_index(facing);
    m.a = rim(k, z0);
    m.b = rim(k, z1);
  } else {
    // Across the cap the scanner looks at, perpendicular to the line of sight.
    const double z = scanner.z() >= z1 ? z1 : z0;
    const int k = vertex_index(facing + 0.5 * std::numbers::pi);
    m.a = rim(k, z);
    m.b = rim((k + n / 2) % n, z);
  }
  return m;
}

Measurement mesh_extent(const SceneObject& o) {
  const TriangleMesh mesh = object_mesh(o);
  Eigen::Vector3f lo = mesh.vertices.front(), hi = lo;
  for (const auto& v : mesh.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  int k = 0;
  (hi - lo).maxCoeff(&k);
  // The lowest vertex along that axis, and of the highest ones the nearest to it, so that the
  // pair runs as parallel to the axis as the mesh allows (a box gives exactly its edge).
  std::size_t i_lo = 0;
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
    if (mesh.vertices[i][k] < mesh.vertices[i_lo][k]) i_lo = i;
  const float top = hi[k] - 1e-6f * (hi[k] - lo[k]);
  std::size_t i_hi = i_lo;
  float best = std::numeric_limits<float>::max();
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    if (mesh.vertices[i][k] < top) continue;
    const float d = (mesh.vertices[i] - mesh.vertices[i_lo]).squaredNorm();
    if (d < best) {
      best = d;
      i_hi = i;
    }
  }
  Measurement m;
  m.a = mesh.vertices[i_lo].cast<double>();
  m.b = mesh.vertices[i_hi].cast<double>();
  return m;
}

}  // namespace

std::vector<Measurement> derive_measurements(const Scene& scene) {
  std::vector<Measurement> out;
  const Eigen::Vector3d half = 0.5 * scene.room.size;
  const double mid = half.z();
  Measurement width;
  width.name = "Room width";
  width.a = {-half.x(), 0.0, mid};
  width.b = {half.x(), 0.0, mid};
  Measurement depth;
  depth.name = "Room depth";
  depth.a = {0.0, -half.y(), mid};
  depth.b = {0.0, half.y(), mid};
  out.push_back(width);
  out.push_back(depth);
  const Eigen::Vector3d scanner = scene.scanner.position;
  for (const SceneObject& o : scene.objects) {
    Measurement m;
    switch (o.shape) {
      case ShapeKind::Box: m = box_extent(o, scanner); break;
      case ShapeKind::Cylinder: m = cylinder_extent(o, scanner); break;
      case ShapeKind::Mesh: m = mesh_extent(o); break;
    }
    m.name = o.name + " (largest extent)";
    out.push_back(m);
  }
  for (auto& m : out) m.derived = true;
  return out;
}

std::vector<Measurement> scene_measurements(const Scene& scene) {
  return scene.measurements.empty() ? derive_measurements(scene) : scene.measurements;
}

void write_measurements_json(const std::filesystem::path& path, const std::string& scene_name,
                             const std::vector<Measurement>& measurements) {
  using nlohmann::ordered_json;
  ordered_json list = ordered_json::array();
  for (const Measurement& m : measurements) {
    ordered_json item;
    item["name"] = m.name;
    item["a"] = {m.a.x(), m.a.y(), m.a.z()};
    item["b"] = {m.b.x(), m.b.y(), m.b.z()};
    item["distance_m"] = m.distance();
    item["source"] = m.derived ? "derived" : "scene";
    list.push_back(item);
  }
  // One measurement per line: easy to read and to diff, still plain JSON.
  AtomicFile file(path, /*binary=*/false);
  auto& out = file.stream();
  out << "{\n  \"scene\": " << ordered_json(scene_name).dump() << ",\n  \"units\": \"m\",\n"
      << "  \"measurements\": [";
  for (std::size_t i = 0; i < list.size(); ++i)
    out << (i ? ",\n    " : "\n    ") << list[i].dump();
  out << (list.empty() ? "]\n}\n" : "\n  ]\n}\n");
  file.commit();
}

}  // namespace locard::sim
