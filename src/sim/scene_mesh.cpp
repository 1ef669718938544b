#include <locard/sim/scene_mesh.hpp>

#include <locard/core/error.hpp>
#include <locard/sim/counter_rng.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace locard::sim {
namespace {

Eigen::Matrix3d yaw_rotation(double yaw_deg) {
  return Eigen::AngleAxisd(yaw_deg * std::numbers::pi / 180.0, Eigen::Vector3d::UnitZ())
      .toRotationMatrix();
}

// Appends a flat quad (corners counter-clockwise seen from the side `normal` points to).
void add_quad(TriangleMesh& mesh, const std::array<Eigen::Vector3d, 4>& corners,
              const Eigen::Vector3d& normal, Rgb8 color) {
  const auto base = static_cast<std::uint32_t>(mesh.vertices.size());
  for (const auto& c : corners) {
    mesh.vertices.push_back(c.cast<float>());
    mesh.vertex_normals.push_back(normal.cast<float>());
    mesh.vertex_colors.push_back(color);
  }
  mesh.triangles.push_back({base, base + 1, base + 2});
  mesh.triangles.push_back({base, base + 2, base + 3});
}

// Face of an axis-aligned unit box: the axis it is normal to and its sign.
struct BoxFace {
  int axis;
  double sign;
};
constexpr std::array<BoxFace, 6> kBoxFaces{{{0, -1}, {0, 1}, {1, -1}, {1, 1}, {2, -1}, {2, 1}}};

Eigen::Vector3f face_normal(const TriangleMesh& mesh, const std::array<std::uint32_t, 3>& tri) {
  const Eigen::Vector3f& a = mesh.vertices[tri[0]];
  const Eigen::Vector3f n = (mesh.vertices[tri[1]] - a).cross(mesh.vertices[tri[2]] - a);
  const float length = n.norm();
  return length > 0.0f ? Eigen::Vector3f(n / length) : Eigen::Vector3f::UnitZ();
}

// A part's texture seed: fixed for a scene (same name, same place in the file), so the
// ground-truth appearance never depends on the scanner's seed.
std::uint64_t part_seed(const std::string& name, std::size_t index) {
  std::uint64_t h = mix64(index + 1);
  for (unsigned char c : name) h = mix64(h ^ c);
  return h;
}

}  // namespace

void SceneMesh::add_part(const TriangleMesh& piece, const SurfaceMaterial& material,
                         const std::string& part_name) {
  if (piece.vertex_colors.size() != piece.vertices.size())
    throw Error("SceneMesh: part '" + part_name + "' has no vertex colours");
  const auto base = static_cast<std::uint32_t>(mesh.vertices.size());
  const auto material_index = static_cast<std::uint32_t>(materials.size());
  const auto part_index = static_cast<std::uint32_t>(part_names.size());
  materials.push_back(material);
  part_names.push_back(part_name);

  mesh.vertices.insert(mesh.vertices.end(), piece.vertices.begin(), piece.vertices.end());
  mesh.vertex_colors.insert(mesh.vertex_colors.end(), piece.vertex_colors.begin(),
                            piece.vertex_colors.end());
  for (const auto& tri : piece.triangles) {
    mesh.triangles.push_back({tri[0] + base, tri[1] + base, tri[2] + base});
    triangle_normals.push_back(face_normal(piece, tri));
    triangle_material.push_back(material_index);
    triangle_part.push_back(part_index);
  }
  if (piece.vertex_normals.size() == piece.vertices.size()) {
    mesh.vertex_normals.insert(mesh.vertex_normals.end(), piece.vertex_normals.begin(),
                               piece.vertex_normals.end());
  } else {
    // No normals in the piece (a PLY without them): average the faces around each vertex.
    std::vector<Eigen::Vector3f> normals(piece.vertices.size(), Eigen::Vector3f::Zero());
    for (const auto& tri : piece.triangles) {
      const Eigen::Vector3f n = face_normal(piece, tri);
      for (std::uint32_t i : tri) normals[i] += n;
    }
    for (auto& n : normals) n = n.norm() > 0.0f ? Eigen::Vector3f(n.normalized()) : Eigen::Vector3f::UnitZ();
    mesh.vertex_normals.insert(mesh.vertex_normals.end(), normals.begin(), normals.end());
  }
}

TriangleMesh box_mesh(const Eigen::Vector3d& center, const Eigen::Vector3d& size, double yaw_deg,
                      Rgb8 color, bool inward) {
  const Eigen::Matrix3d R = yaw_rotation(yaw_deg);
  const Eigen::Vector3d half = 0.5 * size;
  TriangleMesh mesh;
  for (const BoxFace& face : kBoxFaces) {
    // u, v span the face so that u x v points along the outward normal.
    const int a = face.axis;
    const int u_axis = (a + 1) % 3;
    const int v_axis = (a + 2) % 3;
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    normal[a] = face.sign;
    Eigen::Vector3d du = Eigen::Vector3d::Zero();
    Eigen::Vector3d dv = Eigen::Vector3d::Zero();
    du[u_axis] = half[u_axis];
    dv[v_axis] = half[v_axis];
    if (face.sign < 0) std::swap(du, dv);
    if (inward) {
      std::swap(du, dv);
      normal = -normal;
    }
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    c[a] = face.sign * half[a];
    std::array<Eigen::Vector3d, 4> corners{c - du - dv, c + du - dv, c + du + dv, c - du + dv};
    for (auto& p : corners) p = center + R * p;
    add_quad(mesh, corners, R * normal, color);
  }
  return mesh;
}

TriangleMesh cylinder_mesh(const Eigen::Vector3d& center, double radius, double height,
                           int segments, Rgb8 color) {
  TriangleMesh mesh;
  const int n = std::max(segments, 3);
  const double z0 = center.z() - 0.5 * height;
  const double z1 = center.z() + 0.5 * height;
  auto ring = [&](int i) {
    const double phi = 2.0 * std::numbers::pi * i / n;
    return Eigen::Vector3d(std::cos(phi), std::sin(phi), 0.0);
  };
  auto push = [&](const Eigen::Vector3d& p, const Eigen::Vector3d& normal) {
    mesh.vertices.push_back(p.cast<float>());
    mesh.vertex_normals.push_back(normal.cast<float>());
    mesh.vertex_colors.push_back(color);
    return static_cast<std::uint32_t>(mesh.vertices.size() - 1);
  };
  // Side: smooth normals, one vertex pair per facet edge.
  const auto side = static_cast<std::uint32_t>(mesh.vertices.size());
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d r = ring(i);
    const Eigen::Vector3d xy(center.x() + radius * r.x(), center.y() + radius * r.y(), 0.0);
    push({xy.x(), xy.y(), z0}, r);
    push({xy.x(), xy.y(), z1}, r);
  }
  for (int i = 0; i < n; ++i) {
    const std::uint32_t b0 = side + 2 * i, t0 = b0 + 1;
    const std::uint32_t b1 = side + 2 * ((i + 1) % n), t1 = b1 + 1;
    mesh.triangles.push_back({b0, b1, t1});
    mesh.triangles.push_back({b0, t1, t0});
  }
  // Caps: fans around their centres, flat normals.
  for (const double sign : {-1.0, 1.0}) {
    const double z = sign > 0 ? z1 : z0;
    const Eigen::Vector3d normal(0.0, 0.0, sign);
    const std::uint32_t middle = push({center.x(), center.y(), z}, normal);
    const auto first = static_cast<std::uint32_t>(mesh.vertices.size());
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d r = ring(i);
      push({center.x() + radius * r.x(), center.y() + radius * r.y(), z}, normal);
    }
    for (int i = 0; i < n; ++i) {
      const std::uint32_t a = first + i, b = first + (i + 1) % n;
      if (sign > 0)
        mesh.triangles.push_back({middle, a, b});
      else
        mesh.triangles.push_back({middle, b, a});
    }
  }
  return mesh;
}

TriangleMesh object_mesh(const SceneObject& object) {
  switch (object.shape) {
    case ShapeKind::Box:
      return box_mesh(object.center, object.size, object.yaw_deg, object.color);
    case ShapeKind::Cylinder:
      return cylinder_mesh(object.center, object.radius, object.height, object.segments,
                           object.color);
    case ShapeKind::Mesh: break;
  }
  // Mesh: scale, turn, then move the bounding-box centre onto `center`.
  TriangleMesh mesh = object.mesh;
  const Eigen::Matrix3f R = yaw_rotation(object.yaw_deg).cast<float>();
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f hi = -lo;
  for (auto& v : mesh.vertices) {
    v = R * (static_cast<float>(object.scale) * v);
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const Eigen::Vector3f shift = object.center.cast<float>() - 0.5f * (lo + hi);
  for (auto& v : mesh.vertices) v += shift;
  for (auto& n : mesh.vertex_normals) n = R * n;
  if (object.has_color || mesh.vertex_colors.size() != mesh.vertices.size())
    mesh.vertex_colors.assign(mesh.vertices.size(), object.color);
  return mesh;
}

SceneMesh build_scene_mesh(const Scene& scene) {
  SceneMesh out;
  // The room: an inward-facing box whose faces take the floor, ceiling and wall colours.
  const RoomSpec& room = scene.room;
  TriangleMesh walls = box_mesh({0.0, 0.0, 0.5 * room.size.z()}, room.size, 0.0,
                                room.wall_color, /*inward=*/true);
  for (std::size_t i = 0; i < walls.vertices.size(); ++i) {
    const float nz = walls.vertex_normals[i].z();
    if (nz > 0.5f) walls.vertex_colors[i] = room.floor_color;     // looks up: floor
    if (nz < -0.5f) walls.vertex_colors[i] = room.ceiling_color;  // looks down: ceiling
  }
  out.add_part(walls, {room.texture, room.texture_scale, part_seed("room", 0)}, "room");
  for (std::size_t i = 0; i < scene.objects.size(); ++i) {
    const SceneObject& object = scene.objects[i];
    out.add_part(object_mesh(object),
                 {object.texture, object.texture_scale, part_seed(object.name, i + 1)},
                 object.name);
  }
  return out;
}

}  // namespace locard::sim
