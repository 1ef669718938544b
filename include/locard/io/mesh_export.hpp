#pragma once
// Exports a coloured triangle mesh to the formats viewers, modelling tools and game engines
// open, keeping the colour, the size (metres) and the way up in each, and reads them back
// (through assimp) for the tests. What each tool shows is in docs/export-formats.md.
//
//   .ply   binary PLY, float x y z + uchar red green blue (write_ply); Locard's frame as is
//   .obj   Wavefront OBJ + .mtl + .png beside it: the colour baked into a texture atlas (every
//          triangle its own patch, see texture_atlas.hpp) with `vt` per corner, so tools that
//          ignore vertex colours (CloudCompare, Unity) keep it; vertex colours also as
//          "v x y z r g b" (0..1) for the tools that read that extension (Blender, MeshLab)
//   .glb   glTF 2.0 binary: POSITION float, COLOR_0 normalised unsigned byte RGBA, uint32
//          indices, an unlit-looking white material (metallic 0, roughness 1)
//   .gltf  the same with the buffer embedded as a data: URI
//   .fbx   binary FBX 7.4, our own writer (fbx_writer.cpp): one Geometry with vertex colours
//          (LayerElementColor), normals when the mesh has them, a Model and its materials;
//          GlobalSettings say metres (UnitScaleFactor 100) and which axis is up
// Axes: Locard works z-up (the simulator, surveying convention); PLY keeps that frame exactly.
// glTF is y-up by its specification. OBJ and FBX follow MeshExportOptions::up: y-up by default
// (Blender's and Unity's OBJ convention; FBX declares it in GlobalSettings, so importers turn
// it either way), z-up for CloudCompare and surveying tools. y-up is the rotation of -90
// degrees about x, (x, y, z) -> (x, z, -y). Metres throughout.
//
// Triangles flagged as inferred (filled holes) go in their own group / primitive / material
// ("inferred", magenta) so a viewer shows them apart; with show_inferred their vertices are
// also coloured magenta. Every writer goes through AtomicFile (the OBJ's .mtl and .png too).

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

// The axis that points up in an exported OBJ or FBX (glTF is always y-up, PLY always Locard's
// z-up frame).
enum class UpAxis { Z, Y };
std::string_view to_string(UpAxis up);              // "z", "y"
std::optional<UpAxis> parse_up_axis(std::string_view name);  // "z" or "y"

struct MeshExportOptions {
  std::vector<std::uint8_t> inferred_triangles;  // empty, or one flag per triangle (1 = filled)
  bool show_inferred = false;  // colour the inferred triangles' vertices magenta
  UpAxis up = UpAxis::Y;       // OBJ and FBX
};

// Writes by the format its extension names; throws InputError for an unknown extension.
// Returns every file written, the named one first (an OBJ's .mtl and .png follow it).
std::vector<std::filesystem::path> write_mesh(const std::filesystem::path& path,
                                              const TriangleMesh& mesh,
                                              const MeshExportOptions& options = {});
// mesh.obj + mesh.mtl + mesh.png (the texture atlas), in that order.
std::vector<std::filesystem::path> write_obj(const std::filesystem::path& path,
                                             const TriangleMesh& mesh,
                                             const MeshExportOptions& options = {});
void write_gltf(const std::filesystem::path& path, const TriangleMesh& mesh,
                const MeshExportOptions& options = {});  // .glb binary or .gltf text by extension
void write_fbx(const std::filesystem::path& path, const TriangleMesh& mesh,
               const MeshExportOptions& options = {});

// Reads any mesh assimp understands (OBJ, glTF/GLB, FBX, PLY, ...) with identical vertices
// joined, all meshes of the file merged, vertex colours kept (rounded to 8 bits), and turned
// back to Locard's z-up frame: glTF from y-up, OBJ and FBX from `up` (what they were written
// with), PLY as is. Throws InputError naming the file.
TriangleMesh read_mesh_assimp(const std::filesystem::path& path, UpAxis up = UpAxis::Y);

}  // namespace locard
