#pragma once
// A scene turned into one triangle mesh for ray casting and for the ground-truth `scene.ply`.
// Every triangle remembers which part it belongs to (the room or an object) and its surface
// material, so a hit can be coloured and labelled.

#include <locard/core/triangle_mesh.hpp>
#include <locard/sim/scene.hpp>

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace locard::sim {

struct SurfaceMaterial {
  Texture texture = Texture::Plain;
  double scale = 0.05;      // metres
  std::uint64_t seed = 0;   // procedural textures are seeded per part: fixed for a scene
};

struct SceneMesh {
  // Vertex colours hold the base albedo, vertex normals the shading normals; faces of boxes
  // and the room have their own vertices so that both stay flat.
  TriangleMesh mesh;
  std::vector<Eigen::Vector3f> triangle_normals;  // unit; outward, or into the room for walls
  std::vector<std::uint32_t> triangle_material;   // index into materials
  std::vector<std::uint32_t> triangle_part;       // index into part_names
  std::vector<SurfaceMaterial> materials;
  std::vector<std::string> part_names;            // "room", then the objects' names

  // Appends `piece` (which must carry vertex colours) as a new part with its own material.
  void add_part(const TriangleMesh& piece, const SurfaceMaterial& material,
                const std::string& part_name);
};

// Room (inward-facing box) plus every object, in world coordinates.
SceneMesh build_scene_mesh(const Scene& scene);

// One object in world coordinates, with vertex colours and normals.
TriangleMesh object_mesh(const SceneObject& object);

// Primitives (world coordinates, flat-shaded, uniform colour). `inward` flips the box so its
// faces look inside, as a room's walls do.
TriangleMesh box_mesh(const Eigen::Vector3d& center, const Eigen::Vector3d& size, double yaw_deg,
                      Rgb8 color, bool inward = false);
TriangleMesh cylinder_mesh(const Eigen::Vector3d& center, double radius, double height,
                           int segments, Rgb8 color);

}  // namespace locard::sim
