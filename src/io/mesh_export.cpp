// Mesh export to PLY and glTF 2.0 / GLB (own writer), the helpers every writer shares
// (mesh_export_detail.hpp), and the assimp-based reader the tests use. OBJ is in
// obj_writer.cpp, FBX in fbx_writer.cpp. See mesh_export.hpp for the conventions.
#include "mesh_export_detail.hpp"

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/io/mesh_export.hpp>
#include <locard/io/ply.hpp>

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

namespace locard {

namespace detail {

namespace {
constexpr Rgb8 kInferredColor{255, 0, 255};
constexpr Rgb8 kDefaultColor{200, 200, 200};
}  // namespace

void check_mesh_for_export(const TriangleMesh& mesh, const MeshExportOptions& options,
                           const std::filesystem::path& path) {
  if (!options.inferred_triangles.empty() &&
      options.inferred_triangles.size() != mesh.triangles.size())
    throw_input_error(path, fmt::format("{} inferred-triangle flags for {} triangles",
                                        options.inferred_triangles.size(),
                                        mesh.triangles.size()));
  if (!mesh.vertex_colors.empty() && mesh.vertex_colors.size() != mesh.vertices.size())
    throw_input_error(path, fmt::format("{} vertex colours for {} vertices",
                                        mesh.vertex_colors.size(), mesh.vertices.size()));
  for (const auto& t : mesh.triangles)
    for (std::uint32_t v : t)
      if (v >= mesh.vertices.size())
        throw_input_error(path, fmt::format("a triangle refers to vertex {} of {}", v,
                                            mesh.vertices.size()));
}

std::vector<Rgb8> export_colors(const TriangleMesh& mesh, const MeshExportOptions& options) {
  std::vector<Rgb8> colors = mesh.vertex_colors.empty()
                                 ? std::vector<Rgb8>(mesh.vertices.size(), kDefaultColor)
                                 : mesh.vertex_colors;
  if (options.show_inferred && !options.inferred_triangles.empty())
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
      if (options.inferred_triangles[t])
        for (std::uint32_t v : mesh.triangles[t]) colors[v] = kInferredColor;
  return colors;
}

bool any_inferred(const MeshExportOptions& options) {
  return std::find(options.inferred_triangles.begin(), options.inferred_triangles.end(), 1) !=
         options.inferred_triangles.end();
}

}  // namespace detail

namespace {

namespace fs = std::filesystem;
using detail::export_colors;
using detail::is_inferred;

std::string lower_extension(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

// --- glTF -----------------------------------------------------------------------------------

std::string base64(const std::vector<std::uint8_t>& data) {
  static constexpr char kTable[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((data.size() + 2) / 3 * 4);
  for (std::size_t i = 0; i < data.size(); i += 3) {
    const std::uint32_t n = (std::uint32_t{data[i]} << 16) |
                            (i + 1 < data.size() ? std::uint32_t{data[i + 1]} << 8 : 0u) |
                            (i + 2 < data.size() ? std::uint32_t{data[i + 2]} : 0u);
    out += kTable[(n >> 18) & 63];
    out += kTable[(n >> 12) & 63];
    out += i + 1 < data.size() ? kTable[(n >> 6) & 63] : '=';
    out += i + 2 < data.size() ? kTable[n & 63] : '=';
  }
  return out;
}

template <typename T>
void append_bytes(std::vector<std::uint8_t>& buffer, const T* data, std::size_t count) {
  const auto* bytes = reinterpret_cast<const std::uint8_t*>(data);
  buffer.insert(buffer.end(), bytes, bytes + count * sizeof(T));
}

// JSON + binary buffer of a glTF 2.0 asset with one mesh: a primitive of observed triangles
// and, when there are any, one of inferred triangles, sharing POSITION and COLOR_0.
std::pair<nlohmann::json, std::vector<std::uint8_t>> build_gltf(const TriangleMesh& mesh,
                                                                const MeshExportOptions& options) {
  using nlohmann::json;
  const std::size_t n = mesh.vertices.size();
  std::vector<std::uint8_t> bin;
  json views = json::array(), accessors = json::array();

  std::vector<float> positions;
  positions.reserve(3 * n);
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
  Eigen::Vector3f hi = -lo;
  for (const auto& v : mesh.vertices) {
    const Eigen::Vector3f p = detail::to_file_axes(v, UpAxis::Y);  // glTF: y-up
    positions.insert(positions.end(), {p.x(), p.y(), p.z()});
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  append_bytes(bin, positions.data(), positions.size());
  views.push_back({{"buffer", 0}, {"byteOffset", 0}, {"byteLength", bin.size()}, {"target", 34962}});
  accessors.push_back({{"bufferView", 0}, {"componentType", 5126}, {"count", n}, {"type", "VEC3"},
                       {"min", {lo.x(), lo.y(), lo.z()}}, {"max", {hi.x(), hi.y(), hi.z()}}});

  const std::vector<Rgb8> colors = export_colors(mesh, options);
  std::vector<std::uint8_t> rgba;
  rgba.reserve(4 * n);
  for (const Rgb8& c : colors) rgba.insert(rgba.end(), {c.r, c.g, c.b, std::uint8_t{255}});
  const std::size_t color_offset = bin.size();
  append_bytes(bin, rgba.data(), rgba.size());
  views.push_back({{"buffer", 0}, {"byteOffset", color_offset}, {"byteLength", rgba.size()},
                   {"byteStride", 4}, {"target", 34962}});
  accessors.push_back({{"bufferView", 1}, {"componentType", 5121}, {"normalized", true},
                       {"count", n}, {"type", "VEC4"}});

  json primitives = json::array();
  for (int inferred = 0; inferred < 2; ++inferred) {
    std::vector<std::uint32_t> indices;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
      if (is_inferred(options, t) == (inferred == 1))
        indices.insert(indices.end(), mesh.triangles[t].begin(), mesh.triangles[t].end());
    if (indices.empty()) continue;
    const std::size_t offset = bin.size();
    append_bytes(bin, indices.data(), indices.size());
    views.push_back({{"buffer", 0}, {"byteOffset", offset},
                     {"byteLength", indices.size() * 4}, {"target", 34963}});
    accessors.push_back({{"bufferView", views.size() - 1}, {"componentType", 5125},
                         {"count", indices.size()}, {"type", "SCALAR"}});
    primitives.push_back({{"attributes", {{"POSITION", 0}, {"COLOR_0", 1}}},
                          {"indices", accessors.size() - 1},
                          {"material", inferred},
                          {"mode", 4}});
  }
  if (primitives.empty()) {  // a vertex-only mesh: points
    primitives.push_back({{"attributes", {{"POSITION", 0}, {"COLOR_0", 1}}}, {"material", 0},
                          {"mode", 0}});
  }
  auto material = [](const char* name, std::array<double, 4> color) {
    return json{{"name", name},
                {"pbrMetallicRoughness",
                 {{"baseColorFactor", color}, {"metallicFactor", 0.0}, {"roughnessFactor", 1.0}}},
                {"doubleSided", true}};
  };
  json gltf = {
      {"asset", {{"version", "2.0"}, {"generator", std::string("Locard ") + LOCARD_VERSION}}},
      {"scene", 0},
      {"scenes", {{{"nodes", {0}}}}},
      {"nodes", {{{"mesh", 0}, {"name", "locard_mesh"}}}},
      {"meshes", {{{"name", "locard_mesh"}, {"primitives", primitives}}}},
      {"materials",
       {material("observed", {1.0, 1.0, 1.0, 1.0}), material("inferred", {1.0, 0.0, 1.0, 1.0})}},
      {"bufferViews", views},
      {"accessors", accessors},
      {"buffers", {{{"byteLength", bin.size()}}}},
      {"extras",
       {{"units", "metres"},
        {"axes", "y-up (Locard z-up turned by -90 degrees about x)"},
        {"inferred_triangles",
         std::count(options.inferred_triangles.begin(), options.inferred_triangles.end(), 1)}}}};
  return {gltf, bin};
}

}  // namespace

std::string_view to_string(MeshFormat format) {
  switch (format) {
    case MeshFormat::Ply: return "ply";
    case MeshFormat::Obj: return "obj";
    case MeshFormat::Gltf: return "gltf";
    case MeshFormat::Glb: return "glb";
    case MeshFormat::Fbx: return "fbx";
  }
  return "unknown";
}

std::optional<MeshFormat> parse_mesh_format(std::string_view name) {
  for (MeshFormat f : {MeshFormat::Ply, MeshFormat::Obj, MeshFormat::Gltf, MeshFormat::Glb,
                       MeshFormat::Fbx})
    if (name == to_string(f)) return f;
  return std::nullopt;
}

std::string_view to_string(UpAxis up) { return up == UpAxis::Z ? "z" : "y"; }

std::optional<UpAxis> parse_up_axis(std::string_view name) {
  if (name == "z") return UpAxis::Z;
  if (name == "y") return UpAxis::Y;
  return std::nullopt;
}

std::optional<MeshFormat> mesh_format_from_path(const fs::path& path) {
  const std::string ext = lower_extension(path);
  if (ext.size() < 2) return std::nullopt;
  return parse_mesh_format(std::string_view(ext).substr(1));
}

void write_gltf(const fs::path& path, const TriangleMesh& mesh, const MeshExportOptions& options) {
  detail::check_mesh_for_export(mesh, options, path);
  if (mesh.vertices.empty()) throw_input_error(path, "the mesh has no vertices to export");
  auto [gltf, bin] = build_gltf(mesh, options);
  AtomicFile file(path, true);
  if (lower_extension(path) == ".gltf") {
    gltf["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64(bin);
    file.stream() << gltf.dump(1) << "\n";
  } else {
    std::string json = gltf.dump();
    json.append((4 - json.size() % 4) % 4, ' ');
    bin.resize((bin.size() + 3) / 4 * 4, 0);
    const std::uint32_t header[3] = {0x46546C67u, 2u,
                                     static_cast<std::uint32_t>(12 + 8 + json.size() + 8 +
                                                                bin.size())};
    const std::uint32_t json_chunk[2] = {static_cast<std::uint32_t>(json.size()), 0x4E4F534Au};
    const std::uint32_t bin_chunk[2] = {static_cast<std::uint32_t>(bin.size()), 0x004E4942u};
    auto& out = file.stream();
    out.write(reinterpret_cast<const char*>(header), sizeof(header));
    out.write(reinterpret_cast<const char*>(json_chunk), sizeof(json_chunk));
    out.write(json.data(), static_cast<std::streamsize>(json.size()));
    out.write(reinterpret_cast<const char*>(bin_chunk), sizeof(bin_chunk));
    out.write(reinterpret_cast<const char*>(bin.data()), static_cast<std::streamsize>(bin.size()));
  }
  file.commit();
}

std::vector<fs::path> write_mesh(const fs::path& path, const TriangleMesh& mesh,
                                const MeshExportOptions& options) {
  const auto format = mesh_format_from_path(path);
  if (!format)
    throw_input_error(path, "unknown mesh format; use .ply, .obj, .glb, .gltf or .fbx");
  switch (*format) {
    case MeshFormat::Ply: {
      detail::check_mesh_for_export(mesh, options, path);
      if (options.show_inferred && !options.inferred_triangles.empty()) {
        TriangleMesh shown = mesh;
        shown.vertex_colors = export_colors(mesh, options);
        write_ply(path, shown);
      } else {
        write_ply(path, mesh);
      }
      return {path};
    }
    case MeshFormat::Obj: return write_obj(path, mesh, options);
    case MeshFormat::Gltf:
    case MeshFormat::Glb: write_gltf(path, mesh, options); return {path};
    case MeshFormat::Fbx: write_fbx(path, mesh, options); return {path};
  }
  return {};
}

namespace {

// The file's axes: glTF is y-up by specification, OBJ and FBX as written, PLY z-up.
UpAxis file_up_axis(const fs::path& path, UpAxis written) {
  const auto format = mesh_format_from_path(path);
  if (!format || *format == MeshFormat::Ply) return UpAxis::Z;
  if (*format == MeshFormat::Gltf || *format == MeshFormat::Glb) return UpAxis::Y;
  return written;
}

std::uint8_t unit_to_byte(float x) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(x, 0.f, 1.f) * 255.f));
}

}  // namespace

TriangleMesh read_mesh_assimp(const fs::path& path, UpAxis up) {
  if (!fs::exists(path)) throw_input_error(path, "no such file");
  Assimp::Importer importer;
  // Texture coordinates and normals would split vertices at every corner (the OBJ's atlas
  // gives each triangle its own); drop them so identical positions and colours join again.
  importer.SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS, aiComponent_TEXCOORDS | aiComponent_NORMALS |
                                                          aiComponent_TANGENTS_AND_BITANGENTS);
  const aiScene* scene = importer.ReadFile(
      path.string(), aiProcess_RemoveComponent | aiProcess_Triangulate |
                         aiProcess_JoinIdenticalVertices | aiProcess_PreTransformVertices);
  if (!scene) throw_input_error(path, std::string("assimp cannot read it: ") +
                                          importer.GetErrorString());
  const UpAxis file_up = file_up_axis(path, up);
  TriangleMesh mesh;
  bool colors = true;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) colors &= scene->mMeshes[m]->HasVertexColors(0);
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* in = scene->mMeshes[m];
    const auto base = static_cast<std::uint32_t>(mesh.vertices.size());
    for (unsigned i = 0; i < in->mNumVertices; ++i) {
      const Eigen::Vector3f p(in->mVertices[i].x, in->mVertices[i].y, in->mVertices[i].z);
      mesh.vertices.push_back(detail::from_file_axes(p, file_up));
      if (colors) {
        const aiColor4D& c = in->mColors[0][i];
        mesh.vertex_colors.push_back({unit_to_byte(c.r), unit_to_byte(c.g), unit_to_byte(c.b)});
      }
    }
    for (unsigned f = 0; f < in->mNumFaces; ++f) {
      const aiFace& face = in->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines
      mesh.triangles.push_back({base + face.mIndices[0], base + face.mIndices[1],
                                base + face.mIndices[2]});
    }
  }
  return mesh;
}

}  // namespace locard
