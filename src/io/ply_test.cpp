#include <locard/core/error.hpp>
#include <locard/io/ply.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <string>

namespace locard {
namespace {

namespace fs = std::filesystem;
using test::list_folder;
using test::scratch_dir;
using test::shared_data;

fs::path bunny() { return shared_data() / "stanford-bunny" / "bunny"; }

void write_bytes(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// Appends a value in little- or big-endian byte order.
template <typename T>
void put(std::string& s, T v, bool big_endian) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big_endian != (std::endian::native == std::endian::big)) std::reverse(b, b + sizeof(T));
  s.append(b, sizeof(T));
}

// A cloud with every attribute, values chosen to exercise float bits (tiny, huge, negative zero).
PointCloud random_cloud(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-5.0f, 5.0f);
  std::uniform_int_distribution<int> byte(0, 255);
  PointCloud c;
  ScalarField intensity{"intensity", {}};
  for (std::size_t i = 0; i < n; ++i) {
    c.positions.emplace_back(u(rng), u(rng) * 1e-3f, u(rng) * 1e4f);
    c.normals.push_back(Eigen::Vector3f(u(rng), u(rng), u(rng)).normalized());
    c.colors.push_back({static_cast<std::uint8_t>(byte(rng)), static_cast<std::uint8_t>(byte(rng)),
                        static_cast<std::uint8_t>(byte(rng))});
    intensity.values.push_back(u(rng) * 1e-7f);
  }
  c.positions[0] = {-0.0f, 1e-30f, 3.4e38f};
  c.scalars.push_back(std::move(intensity));
  return c;
}

template <typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "no InputError";
}

TEST(Ply, ReadsStanfordRangeScanAscii) {
  const fs::path path = bunny() / "data" / "bun000.ply";
  const PointCloud cloud = read_ply(path);
  ASSERT_EQ(cloud.size(), 40256u);  // "element vertex 40256"; the range_grid lists are skipped
  EXPECT_FALSE(cloud.has_normals());
  EXPECT_FALSE(cloud.has_colors());
  EXPECT_TRUE(cloud.scalars.empty());
  // First and last vertex lines of the file, exactly as float parses them.
  EXPECT_EQ(cloud.positions.front(), Eigen::Vector3f(-0.06325f, 0.0359793f, 0.0420873f));
  EXPECT_EQ(cloud.positions.back(), Eigen::Vector3f(-0.018f, 0.18794f, -0.0197253f));
  EXPECT_EQ(read_ply(bunny() / "data" / "bun045.ply").size(), 40097u);
}

TEST(Ply, ReadsZipperedBunnyMesh) {
  const fs::path path = bunny() / "reconstruction" / "bun_zipper.ply";
  const TriangleMesh mesh = read_ply_mesh(path);
  EXPECT_EQ(mesh.vertex_count(), 35947u);
  EXPECT_EQ(mesh.triangle_count(), 69451u);
  EXPECT_EQ(mesh.vertices.front(), Eigen::Vector3f(-0.0378297f, 0.12794f, 0.00447467f));
  EXPECT_EQ(mesh.triangles.front(), (std::array<std::uint32_t, 3>{21216, 21215, 20399}));
  EXPECT_EQ(mesh.triangles.back(), (std::array<std::uint32_t, 3>{17277, 17346, 17345}));
  // As a cloud the extra vertex properties survive as scalar fields.
  const PointCloud cloud = read_ply(path);
  ASSERT_EQ(cloud.size(), 35947u);
  const ScalarField* confidence = cloud.find_scalar("confidence");
  ASSERT_NE(confidence, nullptr);
  EXPECT_EQ(confidence->values.front(), 0.850855f);
  EXPECT_EQ(cloud.find_scalar("intensity")->values.back(), 0.5f);
}

TEST(Ply, BinaryRoundTripIsExact) {
  const fs::path dir = scratch_dir();
  const PointCloud cloud = random_cloud(1000, 7);
  write_ply(dir / "c.ply", cloud);
  const PointCloud back = read_ply(dir / "c.ply");
  EXPECT_EQ(back.positions, cloud.positions);
  EXPECT_EQ(back.normals, cloud.normals);
  EXPECT_EQ(back.colors, cloud.colors);
  EXPECT_EQ(back.scalars, cloud.scalars);
  EXPECT_EQ(std::signbit(back.positions[0].x()), true);  // -0 kept
  // 3 + 3 floats, 3 bytes, 1 float per vertex after the header.
  const auto size = fs::file_size(dir / "c.ply");
  EXPECT_GT(size, 1000u * 31u);
  EXPECT_LT(size, 1000u * 31u + 400u);
}

TEST(Ply, AsciiRoundTripKeepsEveryFloat) {
  const fs::path dir = scratch_dir();
  const PointCloud cloud = random_cloud(500, 8);
  write_ply(dir / "c.ply", cloud, PlyEncoding::Ascii);
  const PointCloud back = read_ply(dir / "c.ply");
  ASSERT_EQ(back.size(), cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    // Written with the shortest digits that read back to the same float, so exact.
    EXPECT_EQ(back.positions[i], cloud.positions[i]) << i;
    EXPECT_LT((back.normals[i] - cloud.normals[i]).norm(), 1e-7f) << i;
    EXPECT_EQ(back.colors[i], cloud.colors[i]) << i;
  }
  EXPECT_EQ(back.normals, cloud.normals);
  EXPECT_EQ(back.scalars, cloud.scalars);
}

TEST(Ply, WritesStandardPropertyNamesViewersUnderstand) {
  const fs::path dir = scratch_dir();
  write_ply(dir / "c.ply", random_cloud(3, 1));
  std::ifstream in(dir / "c.ply", std::ios::binary);
  std::string header, line;
  while (std::getline(in, line) && line != "end_header") header += line + "\n";
  EXPECT_EQ(header.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u) << header;
  EXPECT_NE(header.find("\nelement vertex 3\n"), std::string::npos) << header;
  for (const char* p : {"property float x\nproperty float y\nproperty float z\n",
                        "property float nx\nproperty float ny\nproperty float nz\n",
                        "property uchar red\nproperty uchar green\nproperty uchar blue\n",
                        "property float intensity\n"})
    EXPECT_NE(header.find(p), std::string::npos) << p << " missing in\n" << header;
}

TEST(Ply, MeshRoundTripBothEncodings) {
  const fs::path dir = scratch_dir();
  const TriangleMesh mesh = read_ply_mesh(bunny() / "reconstruction" / "bun_zipper_res4.ply");
  ASSERT_EQ(mesh.vertex_count(), 453u);
  ASSERT_EQ(mesh.triangle_count(), 948u);
  TriangleMesh coloured = mesh;
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i) {
    coloured.vertex_colors.push_back({static_cast<std::uint8_t>(i), 20, 255});
    coloured.vertex_normals.push_back(Eigen::Vector3f::UnitZ());
  }
  for (PlyEncoding enc : {PlyEncoding::BinaryLittleEndian, PlyEncoding::Ascii}) {
    write_ply(dir / "m.ply", coloured, enc);
    const TriangleMesh back = read_ply_mesh(dir / "m.ply");
    EXPECT_EQ(back.vertices, coloured.vertices);
    EXPECT_EQ(back.vertex_normals, coloured.vertex_normals);
    EXPECT_EQ(back.vertex_colors, coloured.vertex_colors);
    EXPECT_EQ(back.triangles, coloured.triangles);
  }
}

// Every property type, big- and little-endian, float colours, a vertex list and an unknown
// element with lists; the same numbers must come out of both byte orders.
std::string typed_binary_ply(bool big) {
  std::string s = std::string("ply\nformat ") + (big ? "binary_big_endian" : "binary_little_endian") +
                  " 1.0\ncomment every type\n"
                  "element vertex 2\n"
                  "property double x\nproperty float32 y\nproperty int z\n"
                  "property char c8\nproperty uint8 u8\nproperty short s16\nproperty ushort u16\n"
                  "property uint u32\n"
                  "property float diffuse_red\nproperty float diffuse_green\nproperty float diffuse_blue\n"
                  "property list uchar int neighbours\n"
                  "element material 1\nproperty list int float weights\nproperty uchar flag\n"
                  "end_header\n";
  for (int i = 0; i < 2; ++i) {
    put<double>(s, 1.25 + i, big);
    put<float>(s, -2.5f, big);
    put<std::int32_t>(s, 7 - i, big);
    put<std::int8_t>(s, -3, big);
    put<std::uint8_t>(s, 200, big);
    put<std::int16_t>(s, -30000, big);
    put<std::uint16_t>(s, 60000, big);
    put<std::uint32_t>(s, 4000000000u, big);
    put<float>(s, 1.0f, big);
    put<float>(s, 0.5f, big);
    put<float>(s, 0.0f, big);
    put<std::uint8_t>(s, static_cast<std::uint8_t>(i), big);  // list of i ints
    for (int k = 0; k < i; ++k) put<std::int32_t>(s, k, big);
  }
  put<std::int32_t>(s, 2, big);
  put<float>(s, 0.1f, big);
  put<float>(s, 0.2f, big);
  put<std::uint8_t>(s, 1, big);
  return s;
}

TEST(Ply, ReadsEveryTypeInBothByteOrders) {
  const fs::path dir = scratch_dir();
  for (bool big : {false, true}) {
    write_bytes(dir / "t.ply", typed_binary_ply(big));
    const PointCloud c = read_ply(dir / "t.ply");
    ASSERT_EQ(c.size(), 2u) << big;
    EXPECT_EQ(c.positions[0], Eigen::Vector3f(1.25f, -2.5f, 7.0f));
    EXPECT_EQ(c.positions[1], Eigen::Vector3f(2.25f, -2.5f, 6.0f));
    ASSERT_TRUE(c.has_colors());
    EXPECT_EQ(c.colors[1], (Rgb8{255, 128, 0}));  // float 0..1 colours
    ASSERT_EQ(c.scalars.size(), 5u);
    EXPECT_EQ(c.find_scalar("c8")->values[0], -3.0f);
    EXPECT_EQ(c.find_scalar("u8")->values[0], 200.0f);
    EXPECT_EQ(c.find_scalar("s16")->values[0], -30000.0f);
    EXPECT_EQ(c.find_scalar("u16")->values[1], 60000.0f);
    EXPECT_EQ(c.find_scalar("u32")->values[1], 4e9f);
  }
}

TEST(Ply, ReadsAsciiWithCommentsColoursNormalsAndPolygons) {
  const fs::path dir = scratch_dir();
  write_bytes(dir / "a.ply",
              "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\nobj_info scanner x\r\n"
              "element vertex 4\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\n"
              "property float nx\r\nproperty float ny\r\nproperty float nz\r\n"
              "property uchar red\r\nproperty uchar green\r\nproperty uchar blue\r\n"
              "property uchar alpha\r\nproperty float quality\r\n"
              "element face 1\r\nproperty list uchar float texcoord\r\n"
              "property list uchar uint vertex_index\r\nend_header\r\n"
              "0 0 0 0 0 1 255 0 10 255 0.5\r\n"
              "1 0 0 0 0 1 0 255 20 128 +1.5e-3\r\n"
              "\r\n"
              "1 1 0 0 0 1 0 0 255 0 nan\r\n"
              "0 1 0 0 0 1 1 2 3 4 -7\r\n"
              "8 0 0 1 0 1 1 0 1 4 0 1 2 3\r\n");
  const TriangleMesh m = read_ply_mesh(dir / "a.ply");
  ASSERT_EQ(m.vertex_count(), 4u);
  EXPECT_EQ(m.vertices[2], Eigen::Vector3f(1, 1, 0));
  EXPECT_EQ(m.vertex_normals[3], Eigen::Vector3f(0, 0, 1));
  EXPECT_EQ(m.vertex_colors[0], (Rgb8{255, 0, 10}));
  EXPECT_EQ(m.vertex_colors[3], (Rgb8{1, 2, 3}));
  // The quad becomes a fan of two triangles.
  ASSERT_EQ(m.triangle_count(), 2u);
  EXPECT_EQ(m.triangles[0], (std::array<std::uint32_t, 3>{0, 1, 2}));
  EXPECT_EQ(m.triangles[1], (std::array<std::uint32_t, 3>{0, 2, 3}));
  const PointCloud c = read_ply(dir / "a.ply");
  ASSERT_EQ(c.scalars.size(), 1u);  // alpha is not a scalar; quality is
  EXPECT_EQ(c.scalars[0].name, "quality");
  EXPECT_EQ(c.scalars[0].values[1], 1.5e-3f);
  EXPECT_TRUE(std::isnan(c.scalars[0].values[2]));
}

TEST(Ply, BadInputNamesFileAndLine) {
  const fs::path dir = scratch_dir();
  const fs::path f = dir / "bad.ply";
  const std::string head = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
                           "property float y\nproperty float z\nend_header\n";
  struct Case {
    const char* what;
    std::string bytes;
    std::string expect;  // substring of the message after the path
  };
  const std::vector<Case> cases = {
      {"not a ply", "PLY\nformat ascii 1.0\n", ":1: not a PLY file"},
      {"unknown encoding", "ply\nformat binary_middle_endian 1.0\nend_header\n", ":2: unknown PLY encoding"},
      {"no end_header", "ply\nformat ascii 1.0\nelement vertex 1\n", "no 'end_header'"},
      {"unknown type", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n",
       ":4: unknown property type 'float128'"},
      {"unknown keyword", "ply\nformat ascii 1.0\nelemnt vertex 1\nend_header\n", ":3: unknown header keyword"},
      {"no xyz", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n", "lacks"},
      {"not a number", head + "1 2 3\n1 zwei 3\n", ":9: 'zwei' is not a number"},
      {"too few values", head + "1 2 3\n1 2\n", ":9: too few values"},
      {"too many values", head + "1 2 3 4\n1 2 3\n", ":8: more values"},
      {"too few lines", head + "1 2 3\n", "file ends after 1 of 2 vertex"},
      {"too many lines", head + "1 2 3\n4 5 6\n7 8 9\n", ":10: data after the last element"},
      {"bad face", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                   "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                   "end_header\n0 0 0\n3 0 0 5\n", ":11: face 0 refers to vertex 5"},
      {"truncated binary", "ply\nformat binary_little_endian 1.0\nelement vertex 2\n"
                           "property float x\nproperty float y\nproperty float z\nend_header\n" +
                               std::string(20, '\0'),
       "truncated"},
      {"trailing binary", "ply\nformat binary_little_endian 1.0\nelement vertex 1\n"
                          "property float x\nproperty float y\nproperty float z\nend_header\n" +
                              std::string(16, '\0'),
       "4 bytes follow the last element"},
  };
  for (const auto& c : cases) {
    write_bytes(f, c.bytes);
    // The mesh reader checks face indices too; the cloud reader skips faces.
    const bool face_case = c.expect.find("face") != std::string::npos;
    for (const bool mesh : {true, false}) {
      if (face_case && !mesh) continue;
      const std::string msg = mesh ? error_of([&] { read_ply_mesh(f); }) : error_of([&] { read_ply(f); });
      EXPECT_EQ(msg.rfind(f.string(), 0), 0u) << c.what << ": " << msg;
      EXPECT_NE(msg.find(c.expect), std::string::npos) << c.what << ": " << msg;
    }
  }
  EXPECT_NE(error_of([&] { read_ply(dir / "missing.ply"); }).find("missing.ply: no such file"),
            std::string::npos);
  // A truncated big file must not allocate for the count it claims.
  write_bytes(f, "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000000\n"
                 "property float x\nproperty float y\nproperty float z\nend_header\n");
  EXPECT_NE(error_of([&] { read_ply(f); }).find("truncated"), std::string::npos);
}

TEST(Ply, FailedWriteLeavesNoFile) {
  const fs::path dir = scratch_dir();
  PointCloud cloud = random_cloud(10, 3);
  cloud.normals.pop_back();
  EXPECT_THROW(write_ply(dir / "c.ply", cloud), Error);
  TriangleMesh mesh;
  mesh.vertices = {Eigen::Vector3f::Zero(), Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitY()};
  mesh.triangles = {{0, 1, 3}};
  try {
    write_ply(dir / "m.ply", mesh);
    ADD_FAILURE() << "no throw";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("m.ply: cannot write: triangle 0 refers to vertex 3"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(list_folder(dir), "");
  EXPECT_THROW(write_ply(dir / "no-such-folder" / "c.ply", random_cloud(2, 1)), InputError);
  EXPECT_EQ(list_folder(dir), "");
}

}  // namespace
}  // namespace locard
