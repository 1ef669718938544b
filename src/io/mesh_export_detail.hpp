#pragma once
// What the mesh writers (mesh_export.cpp, obj_writer.cpp, fbx_writer.cpp) share: input checks,
// the colours to write, the inferred-triangle flags and the axis turn. Not installed.

#include <locard/core/triangle_mesh.hpp>
#include <locard/io/mesh_export.hpp>

#include <Eigen/Core>

#include <cstddef>
#include <filesystem>
#include <vector>

namespace locard::detail {

// Throws InputError naming `path` when the flags or colours do not match the mesh, or a
// triangle refers to a vertex that does not exist.
void check_mesh_for_export(const TriangleMesh& mesh, const MeshExportOptions& options,
                           const std::filesystem::path& path);

// The mesh's own colours (grey when it has none), inferred vertices magenta when asked.
std::vector<Rgb8> export_colors(const TriangleMesh& mesh, const MeshExportOptions& options);

inline bool is_inferred(const MeshExportOptions& options, std::size_t t) {
  return !options.inferred_triangles.empty() && options.inferred_triangles[t] != 0;
}
bool any_inferred(const MeshExportOptions& options);

// Locard (z-up) -> the file's axes: unchanged for z-up; for y-up a rotation of -90 degrees
// about x, (x, y, z) -> (x, z, -y), so the floor (z = 0) lands on y = 0 and handedness stays.
inline Eigen::Vector3f to_file_axes(const Eigen::Vector3f& p, UpAxis up) {
  return up == UpAxis::Y ? Eigen::Vector3f(p.x(), p.z(), -p.y()) : p;
}
inline Eigen::Vector3f from_file_axes(const Eigen::Vector3f& p, UpAxis up) {
  return up == UpAxis::Y ? Eigen::Vector3f(p.x(), -p.z(), p.y()) : p;
}

}  // namespace locard::detail
