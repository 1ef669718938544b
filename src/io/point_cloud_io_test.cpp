#include <locard/core/error.hpp>
#include <locard/io/pcd.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/point_cloud_io.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <array>
#include <charconv>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>

namespace locard {
namespace {

namespace fs = std::filesystem;
using test::list_folder;
using test::scratch_dir;
using test::shared_data;

fs::path fragment_path() { return shared_data() / "open3d-testdata" / "fragment.pcd"; }

// The first n points of the Open3D fragment, with its colours and normals and a scalar field.
PointCloud fragment_head(std::size_t n) {
  PointCloud full = read_pcd(fragment_path());
  PointCloud c;
  c.positions.assign(full.positions.begin(), full.positions.begin() + n);
  c.normals.assign(full.normals.begin(), full.normals.begin() + n);
  c.colors.assign(full.colors.begin(), full.colors.begin() + n);
  ScalarField index{"index", {}};
  for (std::size_t i = 0; i < n; ++i) index.values.push_back(static_cast<float>(i));
  c.scalars.push_back(index);
  return c;
}

void expect_same(const PointCloud& a, const PointCloud& b) {
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_EQ(a.normals, b.normals);
  EXPECT_EQ(a.colors, b.colors);
  EXPECT_EQ(a.scalars, b.scalars);
}

TEST(PointCloudIo, PicksFormatFromExtension) {
  EXPECT_TRUE(is_point_cloud_file("a/b.ply"));
  EXPECT_TRUE(is_point_cloud_file("B.PCD"));
  EXPECT_TRUE(is_point_cloud_file("scan.E57"));
  EXPECT_FALSE(is_point_cloud_file("b.xyz"));
  EXPECT_FALSE(is_point_cloud_file("ply"));
  const fs::path bun = shared_data() / "stanford-bunny" / "bunny" / "data" / "bun000.ply";
  EXPECT_EQ(read_point_cloud(bun).positions, read_ply(bun).positions);
  EXPECT_EQ(read_point_cloud(fragment_path()).size(), 113662u);
  try {
    read_point_cloud("scan.xyz");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "scan.xyz: unknown point cloud extension '.xyz' (expected .ply, .pcd or .e57)");
  }
}

TEST(PointCloudIo, ConvertsBetweenFormatsLosslessly) {
  const fs::path dir = scratch_dir();
  const PointCloud cloud = fragment_head(5000);
  const std::array<std::pair<const char*, CloudWriteOptions>, 5> outputs = {{
      {"b.ply", {}},
      {"a.PLY", {.ascii = true}},
      {"b.pcd", {}},
      {"a.pcd", {.ascii = true}},
      {"c.pcd", {.compressed = true}},
  }};
  for (const auto& [name, options] : outputs) {
    write_point_cloud(dir / name, cloud, options);
    SCOPED_TRACE(name);
    expect_same(read_point_cloud(dir / name), cloud);
  }
  std::ifstream c(dir / "c.pcd");
  std::string text((std::istreambuf_iterator<char>(c)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\nDATA binary_compressed\n"), std::string::npos);
}

TEST(PointCloudIo, RejectsContradictoryOptionsWithoutWriting) {
  const fs::path dir = scratch_dir();
  const PointCloud cloud = fragment_head(10);
  EXPECT_THROW(write_point_cloud(dir / "c.ply", cloud, {.compressed = true}), InputError);
  EXPECT_THROW(write_point_cloud(dir / "c.pcd", cloud, {.ascii = true, .compressed = true}), InputError);
  EXPECT_THROW(write_point_cloud(dir / "c.xyz", cloud), InputError);
  PointCloud broken = cloud;
  broken.colors.pop_back();
  EXPECT_THROW(write_point_cloud(dir / "c.ply", broken), Error);
  EXPECT_THROW(write_point_cloud(dir / "c.pcd", broken, {.compressed = true}), Error);
  EXPECT_EQ(list_folder(dir), "");
}

// ---- cross-check with Open3D (Debian python3-open3d through /usr/bin/python3) ----------------

constexpr const char* kOpen3dScript = R"(import sys
try:
    import numpy as np
    import open3d as o3d
except ImportError as e:
    print("NO_OPEN3D", e)
    sys.exit(0)
def row(p, i):
    c = np.rint(np.asarray(p.colors)[i] * 255).astype(int)
    return " ".join(["%d %d %d" % tuple(c)] + ["%.9g" % v for v in np.asarray(p.points)[i]]
                    + ["%.9g" % v for v in np.asarray(p.normals)[i]])
for f in sys.argv[2:]:
    p = o3d.io.read_point_cloud(f)
    print("RESULT", len(p.points), row(p, 0), row(p, 1234))
o3d.io.write_point_cloud(sys.argv[1], o3d.io.read_point_cloud(sys.argv[2]), compressed=True)
)";

std::string run(const std::string& command) {
  std::string output;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return output;
  std::array<char, 4096> buf{};
  std::size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) output.append(buf.data(), n);
  ::pclose(pipe);
  return output;
}

// "r g b x y z nx ny nz" as Open3D printed it, checked against point i of `cloud`.
void expect_point(std::istringstream& in, const PointCloud& cloud, std::size_t i) {
  int r = -1, g = -1, b = -1;
  in >> r >> g >> b;
  EXPECT_EQ((Rgb8{static_cast<std::uint8_t>(r), static_cast<std::uint8_t>(g), static_cast<std::uint8_t>(b)}),
            cloud.colors[i]) << "point " << i;
  for (int k = 0; k < 6; ++k) {
    std::string word;
    in >> word;
    float v = 0.0f;  // %.9g of a float-valued double reads back as the same float
    std::from_chars(word.data(), word.data() + word.size(), v);
    EXPECT_EQ(v, k < 3 ? cloud.positions[i][k] : cloud.normals[i][k - 3]) << "point " << i << " value " << k;
  }
}

TEST(PointCloudIo, Open3dReadsOurFilesAndWeReadItsCompressedPcd) {
  const fs::path dir = scratch_dir();
  const PointCloud cloud = fragment_head(2000);
  const std::vector<std::string> files = {"b.ply", "a.ply", "c.pcd", "b.pcd", "a.pcd"};
  for (const auto& f : files)
    write_point_cloud(dir / f, cloud, {.ascii = f[0] == 'a', .compressed = f[0] == 'c'});
  std::ofstream(dir / "check.py") << kOpen3dScript;
  std::string command = "/usr/bin/python3 '" + (dir / "check.py").string() + "' '" +
                        (dir / "open3d.pcd").string() + "'";
  for (const auto& f : files) command += " '" + (dir / f).string() + "'";
  const std::string output = run(command);
  if (output.find("NO_OPEN3D") != std::string::npos) GTEST_SKIP() << "Open3D not installed: " << output;

  std::istringstream lines(output);
  std::string line;
  std::size_t results = 0;
  while (std::getline(lines, line)) {
    if (line.rfind("RESULT ", 0) != 0) continue;
    SCOPED_TRACE(files.at(results));
    std::istringstream in(line.substr(7));
    std::size_t count = 0;
    in >> count;
    EXPECT_EQ(count, 2000u);
    expect_point(in, cloud, 0);
    expect_point(in, cloud, 1234);
    ++results;
  }
  ASSERT_EQ(results, files.size()) << output;

  // Open3D's own binary_compressed writer (x y z rgb normals), read by Locard.
  const PointCloud theirs = read_pcd(dir / "open3d.pcd");
  ASSERT_EQ(theirs.size(), cloud.size());
  EXPECT_EQ(theirs.positions, cloud.positions);
  EXPECT_EQ(theirs.normals, cloud.normals);
  EXPECT_EQ(theirs.colors, cloud.colors);
}

}  // namespace
}  // namespace locard
