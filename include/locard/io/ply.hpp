#pragma once
// PLY (Stanford polygon format) point clouds and triangle meshes.
// Reads ascii, binary_little_endian and binary_big_endian with any property types, including
// colours (uchar red/green/blue, optional alpha, or float 0..1 colours), normals (nx ny nz) and
// extra scalar properties (kept as ScalarFields). Writes binary_little_endian by default with
// float x y z, float nx ny nz, uchar red green blue: the layout CloudCompare, MeshLab and
// Blender all import with colour.
// Errors (malformed header, unknown encoding, truncated body, a value that does not parse,
// element counts that do not match the body) throw InputError naming the file and, for ascii,
// the line. Writers go through AtomicFile: on error no partial file is left behind.

#include <locard/core/point_cloud.hpp>
#include <locard/core/triangle_mesh.hpp>

#include <filesystem>

namespace locard {

enum class PlyEncoding { Ascii, BinaryLittleEndian };

// Reads the "vertex" element; faces and other elements are skipped.
PointCloud read_ply(const std::filesystem::path& path);
void write_ply(const std::filesystem::path& path, const PointCloud& cloud,
               PlyEncoding encoding = PlyEncoding::BinaryLittleEndian);

// Vertices plus the "face" element's vertex_indices (or vertex_index) lists; polygons are
// split into triangle fans. A file without faces gives a mesh with no triangles.
TriangleMesh read_ply_mesh(const std::filesystem::path& path);
void write_ply(const std::filesystem::path& path, const TriangleMesh& mesh,
               PlyEncoding encoding = PlyEncoding::BinaryLittleEndian);

}  // namespace locard
