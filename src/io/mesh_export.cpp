// Mesh export to PLY, OBJ + MTL, glTF 2.0 / GLB (own writer) and FBX (assimp), and the
// assimp-based reader used to check every export. See mesh_export.hpp for the conventions.
#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/io/mesh_export.hpp>
#include <locard/io/ply.hpp>

#include <assimp/Exporter.hpp>
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <string>

namespace locard {
namespace {

namespace fs = std::filesystem;

constexpr Rgb8 kInferredColor{255, 0, 255};
constexpr Rgb8 kDefaultColor{200, 200, 200};

// z-up (Locard) -> y-up (OBJ, glTF, FBX): (x, y, z) -> (x, z, -y).
Eigen::Vector3f to_y_up(const Eigen::Vector3f& p) { return {p.x(), p.z(), -p.y()}; }
Eigen::Vector3f from_y_up(const Eigen::Vector3f& p) { return {p.x(), -p.z(), p.y()}; }

void check_flags(const TriangleMesh& mesh, const MeshExportOptions& options,
                 const fs::path& path) {
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

// The colours to write: the mesh's own (grey when it has none), inferred vertices magenta
// when asked.
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

bool is_inferred(const MeshExportOptions& options, std::size_t t) {
  return !options.inferred_triangles.empty() && options.inferred_triangles[t];
}

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
    const Eigen::Vector3f p = to_y_up(v);
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

// --- assimp scene for FBX ---------------------------------------------------------------------

std::unique_ptr<aiScene> build_assimp_scene(const TriangleMesh& mesh,
                                            const MeshExportOptions& options) {
  auto scene = std::make_unique<aiScene>();
  scene->mRootNode = new aiNode("locard");
  const std::vector<Rgb8> colors = export_colors(mesh, options);
  std::vector<std::vector<std::size_t>> groups(2);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    groups[is_inferred(options, t) ? 1 : 0].push_back(t);
  const unsigned mesh_count = groups[1].empty() ? 1u : 2u;

  scene->mNumMaterials = 2;
  scene->mMaterials = new aiMaterial*[2];
  for (int m = 0; m < 2; ++m) {
    auto* material = new aiMaterial();
    const aiString name(m == 0 ? "observed" : "inferred");
    material->AddProperty(&name, AI_MATKEY_NAME);
    const aiColor3D diffuse = m == 0 ? aiColor3D(1.f, 1.f, 1.f) : aiColor3D(1.f, 0.f, 1.f);
    material->AddProperty(&diffuse, 1, AI_MATKEY_COLOR_DIFFUSE);
    scene->mMaterials[m] = material;
  }
  scene->mNumMeshes = mesh_count;
  scene->mMeshes = new aiMesh*[mesh_count];
  scene->mRootNode->mNumMeshes = mesh_count;
  scene->mRootNode->mMeshes = new unsigned[mesh_count];
  for (unsigned m = 0; m < mesh_count; ++m) {
    // Each group gets its own compact vertex list (observed first: all vertices, in order,
    // so a mesh without inferred triangles keeps its vertex order exactly).
    std::vector<std::uint32_t> local(mesh.vertices.size(), std::numeric_limits<std::uint32_t>::max());
    std::vector<std::uint32_t> order;
    if (m == 0) {
      order.resize(mesh.vertices.size());
      for (std::uint32_t v = 0; v < order.size(); ++v) order[v] = local[v] = v;
    } else {
      for (std::size_t t : groups[m])
        for (std::uint32_t v : mesh.triangles[t])
          if (local[v] == std::numeric_limits<std::uint32_t>::max()) {
            local[v] = static_cast<std::uint32_t>(order.size());
            order.push_back(v);
          }
    }
    auto* out = new aiMesh();
    out->mName = aiString(m == 0 ? "observed" : "inferred");
    out->mMaterialIndex = m;
    out->mPrimitiveTypes = groups[m].empty() ? aiPrimitiveType_POINT : aiPrimitiveType_TRIANGLE;
    out->mNumVertices = static_cast<unsigned>(order.size());
    out->mVertices = new aiVector3D[order.size()];
    out->mColors[0] = new aiColor4D[order.size()];
    for (std::size_t i = 0; i < order.size(); ++i) {
      const Eigen::Vector3f p = to_y_up(mesh.vertices[order[i]]);
      out->mVertices[i] = aiVector3D(p.x(), p.y(), p.z());
      const Rgb8 c = colors[order[i]];
      out->mColors[0][i] = aiColor4D(c.r / 255.f, c.g / 255.f, c.b / 255.f, 1.f);
    }
    out->mNumFaces = static_cast<unsigned>(groups[m].size());
    out->mFaces = new aiFace[groups[m].size()];
    for (std::size_t f = 0; f < groups[m].size(); ++f) {
      aiFace& face = out->mFaces[f];
      face.mNumIndices = 3;
      face.mIndices = new unsigned[3];
      for (int j = 0; j < 3; ++j) face.mIndices[j] = local[mesh.triangles[groups[m][f]][j]];
    }
    scene->mMeshes[m] = out;
    scene->mRootNode->mMeshes[m] = m;
  }
  return scene;
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

std::optional<MeshFormat> mesh_format_from_path(const fs::path& path) {
  const std::string ext = lower_extension(path);
  if (ext.size() < 2) return std::nullopt;
  return parse_mesh_format(std::string_view(ext).substr(1));
}

void write_obj(const fs::path& path, const TriangleMesh& mesh, const MeshExportOptions& options) {
  check_flags(mesh, options, path);
  const std::vector<Rgb8> colors = export_colors(mesh, options);
  fs::path mtl_path = path;
  mtl_path.replace_extension(".mtl");
  {
    AtomicFile mtl(mtl_path, false);
    mtl.stream() << "# Locard materials: vertex colours carry the surface colour\n"
                    "newmtl observed\nKa 0 0 0\nKd 1 1 1\nKs 0 0 0\nd 1\nillum 1\n\n"
                    "newmtl inferred\nKa 0 0 0\nKd 1 0 1\nKs 0 0 0\nd 1\nillum 1\n";
    mtl.commit();
  }
  AtomicFile file(path, false);
  std::ofstream& out = file.stream();
  std::string buffer;
  buffer.reserve(1 << 20);
  auto flush = [&] {
    out.write(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    buffer.clear();
  };
  fmt::format_to(std::back_inserter(buffer),
                 "# Locard {} mesh: {} vertices, {} triangles; metres, y-up (Locard z-up turned "
                 "-90 degrees about x); vertex colours as v x y z r g b\nmtllib {}\no locard_mesh\n",
                 LOCARD_VERSION, mesh.vertices.size(), mesh.triangles.size(),
                 mtl_path.filename().string());
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Eigen::Vector3f p = to_y_up(mesh.vertices[i]);
    const Rgb8 c = colors[i];
    fmt::format_to(std::back_inserter(buffer), "v {} {} {} {} {} {}\n", p.x(), p.y(), p.z(),
                   c.r / 255.f, c.g / 255.f, c.b / 255.f);
    if (buffer.size() > (1 << 20) - 256) flush();
  }
  for (int inferred = 0; inferred < 2; ++inferred) {
    bool header = false;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      if (is_inferred(options, t) != (inferred == 1)) continue;
      if (!header) {
        fmt::format_to(std::back_inserter(buffer), "g {}\nusemtl {}\n",
                       inferred ? "inferred" : "observed", inferred ? "inferred" : "observed");
        header = true;
      }
      const auto& tri = mesh.triangles[t];
      fmt::format_to(std::back_inserter(buffer), "f {} {} {}\n", tri[0] + 1, tri[1] + 1,
                     tri[2] + 1);
      if (buffer.size() > (1 << 20) - 256) flush();
    }
  }
  flush();
  file.commit();
}

void write_gltf(const fs::path& path, const TriangleMesh& mesh, const MeshExportOptions& options) {
  check_flags(mesh, options, path);
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

void write_fbx(const fs::path& path, const TriangleMesh& mesh, const MeshExportOptions& options) {
  check_flags(mesh, options, path);
  if (mesh.vertices.empty()) throw_input_error(path, "the mesh has no vertices to export");
  const std::unique_ptr<aiScene> scene = build_assimp_scene(mesh, options);
  // assimp's FBX writer seeks back to patch block offsets, which its in-memory blob stream
  // does not support: it writes a scratch file beside the target, copied through AtomicFile.
  const fs::path scratch = fs::path(path.string() + ".assimp-tmp");
  Assimp::Exporter exporter;
  if (exporter.Export(scene.get(), options.fbx_ascii ? "fbxa" : "fbx", scratch.string()) !=
      aiReturn_SUCCESS) {
    std::error_code ignored;
    fs::remove(scratch, ignored);
    throw Error(path.string() + ": assimp could not write FBX: " + exporter.GetErrorString());
  }
  std::string bytes;
  {
    std::ifstream in(scratch, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  std::error_code ignored;
  fs::remove(scratch, ignored);
  AtomicFile file(path, true);
  file.stream().write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  file.commit();
}

void write_mesh(const fs::path& path, const TriangleMesh& mesh, const MeshExportOptions& options) {
  const auto format = mesh_format_from_path(path);
  if (!format)
    throw_input_error(path, "unknown mesh format; use .ply, .obj, .glb, .gltf or .fbx");
  switch (*format) {
    case MeshFormat::Ply: {
      check_flags(mesh, options, path);
      if (options.show_inferred && !options.inferred_triangles.empty()) {
        TriangleMesh shown = mesh;
        shown.vertex_colors = export_colors(mesh, options);
        write_ply(path, shown);
      } else {
        write_ply(path, mesh);
      }
      return;
    }
    case MeshFormat::Obj: write_obj(path, mesh, options); return;
    case MeshFormat::Gltf:
    case MeshFormat::Glb: write_gltf(path, mesh, options); return;
    case MeshFormat::Fbx: write_fbx(path, mesh, options); return;
  }
}

TriangleMesh read_mesh_assimp(const fs::path& path) {
  if (!fs::exists(path)) throw_input_error(path, "no such file");
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(
      path.string(), aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                         aiProcess_PreTransformVertices);
  if (!scene) throw_input_error(path, std::string("assimp cannot read it: ") +
                                          importer.GetErrorString());
  const auto format = mesh_format_from_path(path);
  const bool y_up = format && *format != MeshFormat::Ply;
  TriangleMesh mesh;
  bool colors = true;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) colors &= scene->mMeshes[m]->HasVertexColors(0);
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* in = scene->mMeshes[m];
    const auto base = static_cast<std::uint32_t>(mesh.vertices.size());
    for (unsigned i = 0; i < in->mNumVertices; ++i) {
      const Eigen::Vector3f p(in->mVertices[i].x, in->mVertices[i].y, in->mVertices[i].z);
      mesh.vertices.push_back(y_up ? from_y_up(p) : p);
      if (colors) {
        const aiColor4D& c = in->mColors[0][i];
        auto u8 = [](float x) {
          return static_cast<std::uint8_t>(std::lround(std::clamp(x, 0.f, 1.f) * 255.f));
        };
        mesh.vertex_colors.push_back({u8(c.r), u8(c.g), u8(c.b)});
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
