#pragma once
// Exports a coloured triangle mesh to the formats viewers and game engines open, keeping the
// colour in each, and reads them back (through assimp) to check that nothing was lost.
//
//   .ply   binary PLY, float x y z + uchar red green blue (write_ply); Locard's frame as is
//   .obj   Wavefront OBJ + .mtl beside it; vertex colours as "v x y z r g b" (0..1), the
//          extension MeshLab, Blender, CloudCompare and assimp read
//   .glb   glTF 2.0 binary: POSITION float, COLOR_0 normalised unsigned byte RGBA, uint32
//          indices, an unlit-looking white material (metallic 0, roughness 1)
//   .gltf  the same with the buffer embedded as a data: URI
//   .fbx   FBX 7.5 binary (or ASCII, see fbx_ascii) through assimp's exporter, vertex colours
//          as LayerElementColor
// Axes: Locard works z-up (the simulator, surveying convention); PLY keeps that frame exactly.
// OBJ, glTF and FBX are y-up by convention (glTF by its specification), so their writers
// turn z-up into y-up: (x, y, z) -> (x, z, -y), a rotation of -90 degrees about x. The readers
// below turn it back, so a round trip gives the original coordinates. Metres throughout.
//
// Triangles flagged as inferred (filled holes) go in their own group / primitive / material
// ("inferred", magenta) so a viewer shows them apart; with show_inferred their vertices are
// also coloured magenta. Every writer goes through AtomicFile (the OBJ's .mtl too).

#include <locard/core/triangle_mesh.hpp>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string_view>
#include <vector>

namespace locard {

enum class MeshFormat { Ply, Obj, Gltf, Glb, Fbx };

std::string_view to_string(MeshFormat format);
// From the file extension (case-insensitive); empty when unknown.
std::optional<MeshFormat> mesh_format_from_path(const std::filesystem::path& path);
// "ply", "obj", "glb", "gltf", "fbx".
std::optional<MeshFormat> parse_mesh_format(std::string_view name);

struct MeshExportOptions {
  std::vector<std::uint8_t> inferred_triangles;  // empty, or one flag per triangle (1 = filled)
  bool show_inferred = false;  // colour the inferred triangles' vertices magenta
  // FBX as ASCII ("fbxa") instead of binary. assimp 5.2.5 cannot re-import its own binary FBX
  // ("FBX-Tokenize ... block offset is out of range"), so the round-trip test reads the ASCII
  // variant; binary stays the default because Blender imports only binary FBX.
  bool fbx_ascii = false;
};

// Writes by the format its extension names; throws InputError for an unknown extension.
void write_mesh(const std::filesystem::path& path, const TriangleMesh& mesh,
                const MeshExportOptions& options = {});
void write_obj(const std::filesystem::path& path, const TriangleMesh& mesh,
               const MeshExportOptions& options = {});
void write_gltf(const std::filesystem::path& path, const TriangleMesh& mesh,
                const MeshExportOptions& options = {});  // .glb binary or .gltf text by extension
void write_fbx(const std::filesystem::path& path, const TriangleMesh& mesh,
               const MeshExportOptions& options = {});

// Reads any mesh assimp understands (OBJ, glTF/GLB, FBX, PLY, ...) with identical vertices
// joined, all meshes of the file merged, vertex colours kept (rounded to 8 bits), and y-up
// formats (OBJ, glTF, FBX) turned back to z-up. Throws InputError naming the file.
TriangleMesh read_mesh_assimp(const std::filesystem::path& path);

}  // namespace locard
