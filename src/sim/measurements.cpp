#include <locard/sim/measurements.hpp>

#include <locard/core/atomic_file.hpp>
#include <locard/core/raycaster.hpp>
#include <locard/sim/scan_protocol.hpp>
#include <locard/sim/scene_mesh.hpp>

#include <nlohmann/json.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <string>

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

// Whether the scan sees a surface point: in at least one view it projects inside the image (a
// few pixels in), lies within the sensor's range, and the ray from that view's centre reaches
// it unoccluded (a point on an edge is hit within 2 mm of itself) at an incidence under 65
// degrees, where neither Kinect drops it.
class ScanVisibility {
 public:
  ScanVisibility(const Scene& scene, const KinectModel& model)
      : mesh_(build_scene_mesh(scene)), raycaster_(mesh_.mesh), K_(model.intrinsics),
        min_range_m_(model.min_range_m), max_range_m_(model.max_range_m) {
    for (const StampedPose& pose : tripod_scan_trajectory(scene.scanner))
      views_.push_back(pose.T_world_camera);
  }

  bool seen(const Eigen::Vector3d& p) const {
    constexpr double kMarginPx = 4.0;
    const double cos_max_incidence = std::cos(65.0 * std::numbers::pi / 180.0);
    for (const Isometry3d& T_world_camera : views_) {
      const Eigen::Vector3d q = T_world_camera.inverse() * p;
      if (q.z() < min_range_m_ + 0.05 || q.z() > max_range_m_ - 0.05) continue;
      const double u = K_.fx * q.x() / q.z() + K_.cx, v = K_.fy * q.y() / q.z() + K_.cy;
      if (u < kMarginPx || v < kMarginPx || u > K_.width - 1 - kMarginPx ||
          v > K_.height - 1 - kMarginPx)
        continue;
      const Eigen::Vector3d o = T_world_camera.translation();
      const Eigen::Vector3d d = p - o;
      const RayHit hit = raycaster_.intersect(o.cast<float>(), d.cast<float>());
      if (!hit.hit() || std::abs(hit.t - 1.0) * d.norm() > 0.002) continue;
      const Eigen::Vector3d n = mesh_.triangle_normals[hit.triangle].cast<double>();
      if (std::abs(n.dot(d)) / d.norm() >= cos_max_incidence) return true;
    }
    return false;
  }
  bool seen(const Measurement& m) const { return seen(m.a) && seen(m.b); }

 private:
  SceneMesh mesh_;
  Raycaster raycaster_;
  CameraIntrinsics K_;
  double min_range_m_;
  double max_range_m_;
  std::vector<Isometry3d> views_;
};

Measurement named(Measurement m, std::string name) {
  m.name = std::move(name);
  m.derived = true;
  return m;
}

// Wall to wall along `axis` (0: x, 1: y), on lines through or near the tripod at heights the
// pitch rings look at: the nearer wall is met at the ring's pitch.
std::optional<Measurement> seen_room_span(const Scene& scene, const ScanVisibility& vis, int axis) {
  const Eigen::Vector3d half = 0.5 * scene.room.size;
  const Eigen::Vector3d s = scene.scanner.position;
  const int other = 1 - axis;
  const double nearer = half[axis] - std::abs(s[axis]);
  std::vector<double> heights;
  for (const double pitch : scene.scanner.pitch_deg)
    heights.push_back(s.z() + nearer * std::tan(pitch * std::numbers::pi / 180.0));
  heights.push_back(s.z());
  heights.push_back(half.z());
  std::vector<double> offsets;
  for (const double d : {0.0, 0.3, -0.3, 0.6, -0.6, 1.0, -1.0}) offsets.push_back(s[other] + d);
  for (const double z_raw : heights) {
    const double z = std::clamp(z_raw, 0.05, scene.room.size.z() - 0.05);
    for (const double c : offsets) {
      if (std::abs(c) > half[other] - 0.05) continue;
      Measurement m;
      m.a[axis] = -half[axis];
      m.b[axis] = half[axis];
      m.a[other] = m.b[other] = c;
      m.a.z() = m.b.z() = z;
      if (vis.seen(m)) return m;
    }
  }
  return std::nullopt;
}

std::optional<Measurement> seen_room_height(const Scene& scene, const ScanVisibility& vis) {
  const Eigen::Vector3d half = 0.5 * scene.room.size;
  const Eigen::Vector3d s = scene.scanner.position;
  for (const double r : {1.0, 1.5, 2.0, 2.5, 3.0, 3.5}) {
    for (int k = 0; k < 8; ++k) {
      const double phi = 2.0 * std::numbers::pi * k / 8.0;
      const double x = s.x() + r * std::cos(phi), y = s.y() + r * std::sin(phi);
      if (std::abs(x) > half.x() - 0.05 || std::abs(y) > half.y() - 0.05) continue;
      Measurement m;
      m.a = {x, y, 0.0};
      m.b = {x, y, scene.room.size.z()};
      if (vis.seen(m)) return m;
    }
  }
  return std::nullopt;
}

// A box's twelve edges, longest first (stable among equals).
std::vector<Measurement> box_edges(const SceneObject& o) {
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(o.yaw_deg * std::numbers::pi / 180.0, Eigen::Vector3d::UnitZ())
          .toRotationMatrix();
  auto corner = [&](int bits) {
    Eigen::Vector3d local;
    for (int i = 0; i < 3; ++i) local[i] = ((bits >> i) & 1 ? 0.5 : -0.5) * o.size[i];
    return Eigen::Vector3d(o.center + R * local);
  };
  std::vector<Measurement> lines;
  for (int bits = 0; bits < 8; ++bits)
    for (int axis = 0; axis < 3; ++axis)
      if (!((bits >> axis) & 1)) {
        Measurement m;
        m.a = corner(bits);
        m.b = corner(bits | (1 << axis));
        lines.push_back(m);
      }
  std::stable_sort(lines.begin(), lines.end(), [](const Measurement& x, const Measurement& y) {
    return x.distance() > y.distance();
  });
  return lines;
}

// A mesh's feature edges, longest first: edges where its surface folds by at least
// kCreaseDeg, or where it ends - the edges a tape is laid along and whose ends a person finds
// by touch. A smooth surface (a ball's facets fold by about 20 degrees) has none: its size is
// not a tape measurement. Edges are keyed by their end points' positions, as a mesh built of
// pieces repeats vertices.
constexpr double kCreaseDeg = 45.0;

std::vector<Measurement> crease_edges(const TriangleMesh& mesh) {
  struct Edge {
    Eigen::Vector3f a, b;
    std::vector<Eigen::Vector3f> normals;  // of the triangles that share it
  };
  std::map<std::array<float, 6>, Edge> edges;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3f& p0 = mesh.vertices[t[0]];
    const Eigen::Vector3f n =
        (mesh.vertices[t[1]] - p0).cross(mesh.vertices[t[2]] - p0).normalized();
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3f a = mesh.vertices[t[k]], b = mesh.vertices[t[(k + 1) % 3]];
      if (std::lexicographical_compare(b.data(), b.data() + 3, a.data(), a.data() + 3))
        std::swap(a, b);
      Edge& e = edges[{a.x(), a.y(), a.z(), b.x(), b.y(), b.z()}];
      e.a = a;
      e.b = b;
      e.normals.push_back(n);
    }
  }
  const float cos_crease = static_cast<float>(std::cos(kCreaseDeg * std::numbers::pi / 180.0));
  const auto folds = [&](const std::vector<Eigen::Vector3f>& ns) {
    if (ns.size() == 1) return true;  // the surface ends there
    for (std::size_t i = 0; i < ns.size(); ++i)
      for (std::size_t j = i + 1; j < ns.size(); ++j)
        if (ns[i].dot(ns[j]) < cos_crease) return true;
    return false;
  };
  std::vector<Measurement> out;
  for (const auto& [key, e] : edges) {
    if (!folds(e.normals)) continue;
    Measurement m;
    m.a = e.a.cast<double>();
    m.b = e.b.cast<double>();
    if (m.distance() > 1e-6) out.push_back(m);
  }
  std::stable_sort(out.begin(), out.end(), [](const Measurement& x, const Measurement& y) {
    return x.distance() > y.distance();
  });
  return out;
}

// Cylinder heights, floor to top along the side, the line facing the scanner first: the rim's
// points between facets are nothing a tape can hold, so a diameter across a cap is left out.
std::vector<Measurement> cylinder_heights(const SceneObject& o, const Eigen::Vector3d& scanner) {
  const int n = std::max(o.segments, 3);
  const double facing = std::atan2(scanner.y() - o.center.y(), scanner.x() - o.center.x());
  const double z0 = o.center.z() - 0.5 * o.height, z1 = o.center.z() + 0.5 * o.height;
  std::vector<std::pair<double, Measurement>> lines;
  for (int k = 0; k < n; ++k) {
    const double phi = 2.0 * std::numbers::pi * k / n;
    const Eigen::Vector2d rim(o.center.x() + o.radius * std::cos(phi),
                              o.center.y() + o.radius * std::sin(phi));
    Measurement m;
    m.a = {rim.x(), rim.y(), z0};
    m.b = {rim.x(), rim.y(), z1};
    lines.emplace_back(std::abs(std::remainder(phi - facing, 2.0 * std::numbers::pi)), m);
  }
  std::stable_sort(lines.begin(), lines.end(),
                   [](const auto& x, const auto& y) { return x.first < y.first; });
  std::vector<Measurement> out;
  for (const auto& [angle, m] : lines) out.push_back(m);
  return out;
}

// What an investigator measures on an object with a tape, where the scan sees both ends: a
// box's longest seen edge, a cylinder's height, a mesh's longest seen feature edge (none on a
// ball).
std::optional<Measurement> seen_object_tape_line(const SceneObject& o,
                                                 const Eigen::Vector3d& scanner,
                                                 const ScanVisibility& vis) {
  switch (o.shape) {
    case ShapeKind::Box: {
      const Measurement largest = box_extent(o, scanner);
      if (vis.seen(largest)) return named(largest, o.name + " (longest edge)");
      for (const Measurement& m : box_edges(o))
        if (vis.seen(m)) return named(m, o.name + " (longest seen edge)");
      return std::nullopt;
    }
    case ShapeKind::Cylinder:
      for (const Measurement& m : cylinder_heights(o, scanner))
        if (vis.seen(m)) return named(m, o.name + " (height)");
      return std::nullopt;
    case ShapeKind::Mesh:
      for (const Measurement& m : crease_edges(object_mesh(o)))
        if (vis.seen(m)) return named(m, o.name + " (longest seen edge)");
      return std::nullopt;
  }
  return std::nullopt;
}

}  // namespace

std::vector<Measurement> derive_seen_measurements(const Scene& scene, const KinectModel& model) {
  const ScanVisibility vis(scene, model);
  std::vector<Measurement> out;
  if (auto m = seen_room_span(scene, vis, 0)) out.push_back(named(*m, "Room width"));
  if (auto m = seen_room_span(scene, vis, 1)) out.push_back(named(*m, "Room depth"));
  if (auto m = seen_room_height(scene, vis)) out.push_back(named(*m, "Room height"));
  for (const SceneObject& o : scene.objects)
    if (auto m = seen_object_tape_line(o, scene.scanner.position, vis)) out.push_back(*m);
  return out;
}

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
