#include <locard/core/error.hpp>
#include <locard/io/mesh_export.hpp>
#include <locard/io/image_io.hpp>
#include <locard/io/ply.hpp>

#include "test_support.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <iterator>
#include <set>
#include <map>
#include <tuple>

namespace locard {
namespace {

// A coloured, welded mesh with distinct positions and colours: a 6x5 grid bent into a roof,
// far from the origin in y so that a wrong axis turn cannot go unnoticed.
TriangleMesh coloured_grid() {
  TriangleMesh mesh;
  const int nx = 6, ny = 5;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      mesh.vertices.emplace_back(0.1f * i - 0.25f, 3.0f + 0.1f * j, 0.05f * std::abs(i - 2) + 1.f);
      mesh.vertex_colors.push_back({static_cast<std::uint8_t>(40 * i + 3),
                                    static_cast<std::uint8_t>(50 * j + 1),
                                    static_cast<std::uint8_t>(7 * (i + j))});
    }
  for (int j = 0; j + 1 < ny; ++j)
    for (int i = 0; i + 1 < nx; ++i) {
      const std::uint32_t a = j * nx + i, b = a + 1, c = a + nx, d = c + 1;
      mesh.triangles.push_back({a, b, d});
      mesh.triangles.push_back({a, d, c});
    }
  return mesh;
}

// Vertices matched by position (import may reorder them): same count, same colours, the
// same triangles as vertex-position triples.
void expect_same_mesh(const TriangleMesh& expected, const TriangleMesh& actual) {
  ASSERT_EQ(actual.vertex_count(), expected.vertex_count());
  ASSERT_EQ(actual.triangle_count(), expected.triangle_count());
  ASSERT_EQ(actual.vertex_colors.size(), actual.vertex_count()) << "colours lost";
  auto key = [](const Eigen::Vector3f& p) {
    return std::make_tuple(std::lround(p.x() * 1e5), std::lround(p.y() * 1e5),
                           std::lround(p.z() * 1e5));
  };
  std::map<std::tuple<long, long, long>, std::size_t> index;
  for (std::size_t i = 0; i < expected.vertex_count(); ++i) index[key(expected.vertices[i])] = i;
  std::vector<std::size_t> to_expected(actual.vertex_count());
  for (std::size_t i = 0; i < actual.vertex_count(); ++i) {
    auto it = index.find(key(actual.vertices[i]));
    ASSERT_NE(it, index.end()) << "vertex " << i << " moved: " << actual.vertices[i].transpose();
    to_expected[i] = it->second;
    EXPECT_LT((actual.vertices[i] - expected.vertices[it->second]).norm(), 1e-6f);
    EXPECT_EQ(actual.vertex_colors[i], expected.vertex_colors[it->second]) << "vertex " << i;
  }
  std::multiset<std::array<std::size_t, 3>> a, b;
  auto canonical = [](std::array<std::size_t, 3> t) {  // rotate so the smallest comes first
    const auto m = std::min_element(t.begin(), t.end()) - t.begin();
    return std::array<std::size_t, 3>{t[m], t[(m + 1) % 3], t[(m + 2) % 3]};
  };
  for (const auto& t : expected.triangles) a.insert(canonical({t[0], t[1], t[2]}));
  for (const auto& t : actual.triangles)
    b.insert(canonical({to_expected[t[0]], to_expected[t[1]], to_expected[t[2]]}));
  EXPECT_EQ(a, b) << "triangles or their winding changed";
}

// Every format read back by assimp (an independent reader: our FBX and OBJ writers share no
// code with it), for both up axes where the format has a choice.
class MeshExportRoundTrip
    : public ::testing::TestWithParam<std::tuple<const char*, UpAxis>> {};

TEST_P(MeshExportRoundTrip, AssimpReadsBackVerticesColoursAndTriangles) {
  const auto [extension, up] = GetParam();
  const TriangleMesh mesh = coloured_grid();
  const auto path = test::scratch_dir() / (std::string("grid.") + extension);
  MeshExportOptions options;
  options.up = up;
  write_mesh(path, mesh, options);
  ASSERT_TRUE(std::filesystem::exists(path));
  expect_same_mesh(mesh, read_mesh_assimp(path, up));
}

INSTANTIATE_TEST_SUITE_P(Formats, MeshExportRoundTrip,
                         ::testing::Combine(::testing::Values("ply", "obj", "glb", "gltf", "fbx"),
                                            ::testing::Values(UpAxis::Y, UpAxis::Z)));

// The up axis turns OBJ and FBX only: read back as if z-up (no turn undone), a y-up OBJ or FBX
// has Locard's z as its y. glTF is read back from its fixed y-up, PLY is Locard's frame.
TEST(MeshExport, UpAxisTurnsObjAndFbxOnly) {
  const TriangleMesh mesh = coloured_grid();  // z in [1, 1.15], y in [3, 3.4]
  const auto dir = test::scratch_dir();
  for (const char* ext : {"obj", "fbx", "glb", "ply"})
    for (UpAxis up : {UpAxis::Y, UpAxis::Z}) {
      MeshExportOptions options;
      options.up = up;
      const auto path = dir / fmt::format("m_{}.{}", to_string(up), ext);
      write_mesh(path, mesh, options);
      const TriangleMesh raw = read_mesh_assimp(path, UpAxis::Z);  // file axes as they are
      float max_y = -1e9f;
      for (const auto& v : raw.vertices) max_y = std::max(max_y, v.y());
      const std::string e = ext;
      const bool turned = (e == "obj" || e == "fbx") && up == UpAxis::Y;
      EXPECT_NEAR(max_y, turned ? 1.15f : 3.4f, 1e-5f) << path;
    }
}

TEST(MeshExport, ObjListsItsMaterialAndTextureFiles) {
  const auto dir = test::scratch_dir();
  const auto written = write_mesh(dir / "grid.obj", coloured_grid());
  ASSERT_EQ(written.size(), 3u);
  EXPECT_EQ(written[1].filename(), "grid.mtl");
  EXPECT_EQ(written[2].filename(), "grid.png");
  EXPECT_EQ(test::list_folder(dir), "grid.mtl\ngrid.obj\ngrid.png\n");  // no temporary left
  std::ifstream mtl(dir / "grid.mtl");
  const std::string text((std::istreambuf_iterator<char>(mtl)), {});
  EXPECT_NE(text.find("map_Kd grid.png"), std::string::npos);
  const ColorImage texture = read_color_image(dir / "grid.png");
  EXPECT_EQ(texture.width() % 5, 0);  // whole atlas cells
}

TEST(MeshExport, PlyRoundTripsThroughOwnReader) {
  const TriangleMesh mesh = coloured_grid();
  const auto path = test::scratch_dir() / "grid.ply";
  write_mesh(path, mesh);
  const TriangleMesh back = read_ply_mesh(path);
  EXPECT_EQ(back.vertices, mesh.vertices);
  EXPECT_EQ(back.vertex_colors, mesh.vertex_colors);
  EXPECT_EQ(back.triangles, mesh.triangles);
}

TEST(MeshExport, GltfIsYUpWithNormalisedByteColours) {
  const TriangleMesh mesh = coloured_grid();
  const auto path = test::scratch_dir() / "grid.gltf";
  write_mesh(path, mesh);
  std::ifstream in(path);
  const auto json = nlohmann::json::parse(in);
  EXPECT_EQ(json["asset"]["version"], "2.0");
  const auto& prim = json["meshes"][0]["primitives"][0];
  const auto& color = json["accessors"][prim["attributes"]["COLOR_0"].get<int>()];
  EXPECT_EQ(color["componentType"], 5121);
  EXPECT_TRUE(color["normalized"].get<bool>());
  const auto& pos = json["accessors"][prim["attributes"]["POSITION"].get<int>()];
  // Locard z in [1, 1.15] becomes glTF y; Locard y in [3, 3.4] becomes glTF -z.
  EXPECT_NEAR(pos["min"][1].get<double>(), 1.0, 1e-6);
  EXPECT_NEAR(pos["max"][2].get<double>(), -3.0, 1e-6);
}

TEST(MeshExport, InferredTrianglesGetTheirOwnMaterialAndOptionalColour) {
  const TriangleMesh mesh = coloured_grid();
  MeshExportOptions options;
  options.inferred_triangles.assign(mesh.triangle_count(), 0);
  options.inferred_triangles[3] = 1;
  options.show_inferred = true;
  const auto dir = test::scratch_dir();
  write_mesh(dir / "m.glb", mesh, options);
  write_mesh(dir / "m.obj", mesh, options);
  write_mesh(dir / "m.fbx", mesh, options);
  for (const char* name : {"m.glb", "m.obj", "m.fbx"}) {
    const TriangleMesh back = read_mesh_assimp(dir / name);
    EXPECT_EQ(back.triangle_count(), mesh.triangle_count()) << name;
    std::size_t magenta = 0;
    for (const Rgb8& c : back.vertex_colors) magenta += c == Rgb8{255, 0, 255};
    EXPECT_GE(magenta, 3u) << name;
  }
  std::ifstream obj(dir / "m.obj");
  const std::string text((std::istreambuf_iterator<char>(obj)), {});
  EXPECT_NE(text.find("usemtl inferred"), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(dir / "m.mtl"));
}

TEST(MeshExport, RejectsUnknownExtensionAndMismatchedFlags) {
  const TriangleMesh mesh = coloured_grid();
  const auto dir = test::scratch_dir();
  EXPECT_THROW(write_mesh(dir / "m.stl", mesh), InputError);
  MeshExportOptions bad;
  bad.inferred_triangles = {1};
  EXPECT_THROW(write_mesh(dir / "m.glb", mesh, bad), InputError);
  EXPECT_EQ(test::list_folder(dir), "");
}

}  // namespace
}  // namespace locard
