// write_fbx: one coloured mesh as a binary FBX 7.4 document (fbx_binary.hpp), laid out as the
// FBX SDK lays out a static mesh so that Blender, assimp and engines import it:
//
//   FBXHeaderExtension, FileId, CreationTime, Creator   (fixed values: the same mesh gives the
//                                                        same bytes)
//   GlobalSettings   axes (up, front, coord with signs) and UnitScaleFactor 100: FBX counts
//                    in centimetres, so 100 says one unit is a metre
//   Definitions      object counts per type
//   Objects          Geometry "Mesh": Vertices, PolygonVertexIndex (the last corner of each
//                    polygon stored as ~index), LayerElementNormal (ByVertice, Direct) when
//                    the mesh has normals, LayerElementColor (ByPolygonVertex, IndexToDirect:
//                    one RGBA per vertex, the corners index it), LayerElementMaterial
//                    (ByPolygon: 0 observed, 1 inferred), Layer 0 listing them;
//                    Model "Mesh"; Material "observed" (white), "inferred" (magenta)
//   Connections      Model -> root, Geometry -> Model, Materials -> Model (in index order)
#include "fbx_binary.hpp"
#include "mesh_export_detail.hpp"

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/io/mesh_export.hpp>

#include <fmt/format.h>

#include <limits>
#include <string>

namespace locard {
namespace {

namespace fs = std::filesystem;
using detail::FbxNode;
using detail::fbx_property;

// Object ids: any distinct non-zero int64 (0 is the scene root).
constexpr std::int64_t kGeometryId = 1000001, kModelId = 1000002, kMaterialId = 1000003;

std::string fbx_name(std::string_view name, std::string_view fbx_class) {
  std::string s(name);
  s += std::string_view("\0\1", 2);
  s += fbx_class;
  return s;
}

FbxNode header_extension() {
  FbxNode h("FBXHeaderExtension");
  h.child("FBXHeaderVersion").i32(1003);
  h.child("FBXVersion").i32(7400);
  h.child("EncryptionType").i32(0);
  FbxNode& stamp = h.child("CreationTimeStamp");
  stamp.child("Version").i32(1000);
  const std::pair<const char*, int> fields[] = {{"Year", 1970}, {"Month", 1}, {"Day", 1},
                                                {"Hour", 10}, {"Minute", 0}, {"Second", 0},
                                                {"Millisecond", 0}};  // = CreationTime
  for (const auto& [field, value] : fields) stamp.child(field).i32(value);
  h.child("Creator").string(fmt::format("Locard {}", LOCARD_VERSION));
  return h;
}

// The axis triple Blender's importer and the FBX SDK decode (Blender's RIGHT_HAND_AXES): y-up
// is the SDK's default (up +Y, front +Z, coord +X), z-up Blender's own (up +Z, front -Y,
// coord +X).
FbxNode global_settings(UpAxis up) {
  FbxNode g("GlobalSettings");
  g.child("Version").i32(1000);
  FbxNode& p = g.child("Properties70");
  const bool y = up == UpAxis::Y;
  const std::pair<const char*, int> axes[] = {
      {"UpAxis", y ? 1 : 2},   {"UpAxisSign", 1},    {"FrontAxis", y ? 2 : 1},
      {"FrontAxisSign", y ? 1 : -1}, {"CoordAxis", 0}, {"CoordAxisSign", 1},
      {"OriginalUpAxis", y ? 1 : 2}, {"OriginalUpAxisSign", 1}};
  for (const auto& [name, value] : axes) fbx_property(p, name, "int", "Integer").i32(value);
  fbx_property(p, "UnitScaleFactor", "double", "Number").f64(100.0);
  fbx_property(p, "OriginalUnitScaleFactor", "double", "Number").f64(100.0);
  return g;
}

FbxNode definitions(int materials) {
  FbxNode d("Definitions");
  d.child("Version").i32(100);
  d.child("Count").i32(3 + materials);
  const std::pair<const char*, int> types[] = {
      {"GlobalSettings", 1}, {"Model", 1}, {"Geometry", 1}, {"Material", materials}};
  for (const auto& [type, count] : types) d.child("ObjectType").string(type).child("Count").i32(count);
  return d;
}

void layer_header(FbxNode& layer, int version, const char* name, const char* mapping,
                  const char* reference) {
  layer.child("Version").i32(version);
  layer.child("Name").string(name);
  layer.child("MappingInformationType").string(mapping);
  layer.child("ReferenceInformationType").string(reference);
}

void add_vertices(FbxNode& geometry, const TriangleMesh& mesh, UpAxis up) {
  std::vector<double> xyz;
  xyz.reserve(3 * mesh.vertices.size());
  for (const Eigen::Vector3f& v : mesh.vertices) {
    const Eigen::Vector3f p = detail::to_file_axes(v, up);
    xyz.insert(xyz.end(), {p.x(), p.y(), p.z()});
  }
  geometry.child("Vertices").f64_array(xyz);
  std::vector<std::int32_t> corners;
  corners.reserve(3 * mesh.triangles.size());
  for (const auto& t : mesh.triangles)
    corners.insert(corners.end(), {static_cast<std::int32_t>(t[0]), static_cast<std::int32_t>(t[1]),
                                   ~static_cast<std::int32_t>(t[2])});  // ~: polygon ends here
  geometry.child("PolygonVertexIndex").i32_array(corners);
}

void add_normals(FbxNode& geometry, const TriangleMesh& mesh, UpAxis up) {
  FbxNode& layer = geometry.child("LayerElementNormal").i32(0);
  layer_header(layer, 102, "", "ByVertice", "Direct");
  std::vector<double> n;
  n.reserve(3 * mesh.vertex_normals.size());
  for (const Eigen::Vector3f& v : mesh.vertex_normals) {
    const Eigen::Vector3f p = detail::to_file_axes(v, up);  // a rotation: normals turn alike
    n.insert(n.end(), {p.x(), p.y(), p.z()});
  }
  layer.child("Normals").f64_array(n);
}

void add_colors(FbxNode& geometry, const std::vector<Rgb8>& colors) {
  FbxNode& layer = geometry.child("LayerElementColor").i32(0);
  layer_header(layer, 101, "Col", "ByVertice", "Direct");  // "Col": Blender's name
  std::vector<double> rgba;
  rgba.reserve(4 * colors.size());
  for (const Rgb8& c : colors) rgba.insert(rgba.end(), {c.r / 255.0, c.g / 255.0, c.b / 255.0, 1.0});
  layer.child("Colors").f64_array(rgba);
}

void add_material_layer(FbxNode& geometry, const TriangleMesh& mesh,
                        const MeshExportOptions& options) {
  FbxNode& layer = geometry.child("LayerElementMaterial").i32(0);
  if (!detail::any_inferred(options)) {
    layer_header(layer, 101, "", "AllSame", "IndexToDirect");
    layer.child("Materials").i32_array({0});
    return;
  }
  layer_header(layer, 101, "", "ByPolygon", "IndexToDirect");
  std::vector<std::int32_t> material(mesh.triangles.size());
  for (std::size_t t = 0; t < material.size(); ++t) material[t] = detail::is_inferred(options, t);
  layer.child("Materials").i32_array(material);
}

FbxNode geometry(const TriangleMesh& mesh, const MeshExportOptions& options) {
  FbxNode g("Geometry");
  g.i64(kGeometryId).string(fbx_name("locard_mesh", "Geometry")).string("Mesh");
  g.child("Properties70");
  g.child("GeometryVersion").i32(124);
  add_vertices(g, mesh, options.up);
  const bool normals = mesh.vertex_normals.size() == mesh.vertices.size() && !mesh.vertices.empty();
  if (normals) add_normals(g, mesh, options.up);
  add_colors(g, detail::export_colors(mesh, options));
  add_material_layer(g, mesh, options);
  FbxNode& layer = g.child("Layer").i32(0);
  layer.child("Version").i32(100);
  for (const char* type : {"LayerElementNormal", "LayerElementColor", "LayerElementMaterial"}) {
    if (!normals && std::string_view(type) == "LayerElementNormal") continue;
    FbxNode& element = layer.child("LayerElement");
    element.child("Type").string(type);
    element.child("TypedIndex").i32(0);
  }
  return g;
}

FbxNode model() {
  FbxNode m("Model");
  m.i64(kModelId).string(fbx_name("locard_mesh", "Model")).string("Mesh");
  m.child("Version").i32(232);
  FbxNode& p = m.child("Properties70");
  fbx_property(p, "DefaultAttributeIndex", "int", "Integer").i32(0);
  m.child("Shading").boolean(true);
  m.child("Culling").string("CullingOff");
  return m;
}

FbxNode material(std::int64_t id, const char* name, double r, double g, double b) {
  FbxNode m("Material");
  m.i64(id).string(fbx_name(name, "Material")).string("");
  m.child("Version").i32(102);
  m.child("ShadingModel").string("lambert");
  m.child("MultiLayer").i32(0);
  FbxNode& p = m.child("Properties70");
  fbx_property(p, "DiffuseColor", "Color", "", "A").f64(r).f64(g).f64(b);
  fbx_property(p, "DiffuseFactor", "Number", "", "A").f64(1.0);
  return m;
}

std::vector<FbxNode> fbx_document(const TriangleMesh& mesh, const MeshExportOptions& options) {
  const int materials = detail::any_inferred(options) ? 2 : 1;
  std::vector<FbxNode> doc;
  doc.push_back(header_extension());
  static constexpr char kFileId[] = "\x28\xb3\x2a\xeb\xb6\x24\xcc\xc2\xbf\xc8\xb0\x2a\xa9\x2b\xfc\xf1";
  doc.emplace_back("FileId").raw(std::string_view(kFileId, 16));
  doc.emplace_back("CreationTime").string("1970-01-01 10:00:00:000");
  doc.emplace_back("Creator").string(fmt::format("Locard {}", LOCARD_VERSION));
  doc.push_back(global_settings(options.up));
  doc.emplace_back("References");
  doc.push_back(definitions(materials));
  FbxNode& objects = doc.emplace_back("Objects");
  objects.add(geometry(mesh, options));
  objects.add(model());
  objects.add(material(kMaterialId, "observed", 1, 1, 1));
  if (materials == 2) objects.add(material(kMaterialId + 1, "inferred", 1, 0, 1));
  FbxNode& connections = doc.emplace_back("Connections");
  connections.child("C").string("OO").i64(kModelId).i64(0);
  connections.child("C").string("OO").i64(kGeometryId).i64(kModelId);
  for (int m = 0; m < materials; ++m)
    connections.child("C").string("OO").i64(kMaterialId + m).i64(kModelId);
  return doc;
}

}  // namespace

void write_fbx(const fs::path& path, const TriangleMesh& mesh, const MeshExportOptions& options) {
  detail::check_mesh_for_export(mesh, options, path);
  if (mesh.vertices.empty()) throw_input_error(path, "the mesh has no vertices to export");
  if (mesh.vertices.size() > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
    throw_input_error(path, "FBX indices are 32-bit: too many vertices");
  const std::string bytes = detail::encode_fbx_file(fbx_document(mesh, options));
  AtomicFile file(path, true);
  file.stream().write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  file.commit();
}

}  // namespace locard
