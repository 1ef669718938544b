// The `locard` command as a user runs it: real datasets, exit codes, no partial output.
#include "test_support.hpp"

#include <locard/io/mesh_export.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/point_cloud_io.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>

namespace locard {
namespace {

using test::run_cli;
using test::shared_data;

bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

TEST(Cli, EveryCommandHasHelp) {
  for (const char* command : {"", "info", "convert"}) {
    const auto result = run_cli(std::string(command) + " --help");
    EXPECT_EQ(result.exit_code, 0) << command << "\n" << result.output;
    EXPECT_TRUE(contains(result.output, "Usage")) << result.output;
  }
}

TEST(Cli, InfoOnSevenScenesReportsFramesPosesResolutionAndIntrinsics) {
  const auto result = run_cli("--quiet info '" +
                              (shared_data() / "7scenes-tsdf-fusion" / "data").string() + "'");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "format:        7-Scenes")) << result.output;
  EXPECT_TRUE(contains(result.output, "374 with images")) << result.output;
  EXPECT_TRUE(contains(result.output, "1000 poses")) << result.output;
  EXPECT_TRUE(contains(result.output, "640x480")) << result.output;
  EXPECT_TRUE(contains(result.output, "fx=585 fy=585 cx=320 cy=240")) << result.output;
  EXPECT_TRUE(contains(result.output, "preset seven_scenes")) << result.output;
  // 7-Scenes marks missing depth with 65535 as well as 0; neither is a measurement.
  EXPECT_TRUE(contains(result.output, "depth range:   0.801 m .. 3.")) << result.output;
}

TEST(Cli, InfoJsonOnOpen3dFramesGivesDepthRange) {
  // Frame 0 of the Open3D RGBD sample spans 955-2702 mm (SOURCE.md); the range over all 5
  // frames can only be wider.
  const auto result =
      run_cli("info --json '" + (shared_data() / "open3d-testdata" / "RGBD").string() + "'");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(contains(result.output, "\"frames\": 5")) << result.output;
  EXPECT_TRUE(contains(result.output, "\"fx\": 525.0")) << result.output;
}

TEST(Cli, InfoOnAMissingPathIsBadInput) {
  const auto result = run_cli("info /nonexistent/locard-data");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_TRUE(contains(result.output, "/nonexistent/locard-data")) << result.output;
}

TEST(Cli, ConvertPlyToPcdAndBackKeepsThePoints) {
  const auto dir = test::scratch_dir();
  const auto bunny = shared_data() / "stanford-bunny" / "bunny" / "data" / "bun000.ply";
  auto r = run_cli("--quiet convert '" + bunny.string() + "' '" + (dir / "b.pcd").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = run_cli("--quiet convert '" + (dir / "b.pcd").string() + "' '" + (dir / "b.ply").string() +
              "' --ascii");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const PointCloud original = read_point_cloud(bunny);
  const PointCloud round_trip = read_point_cloud(dir / "b.ply");
  ASSERT_EQ(round_trip.size(), 40256u);
  ASSERT_EQ(original.size(), round_trip.size());
  for (std::size_t i = 0; i < original.size(); i += 997)
    EXPECT_TRUE(original.positions[i].isApprox(round_trip.positions[i], 1e-6f)) << i;
}

TEST(Cli, ConvertRefusesToOverwriteWithoutForce) {
  const auto dir = test::scratch_dir();
  const auto bunny = shared_data() / "stanford-bunny" / "bunny" / "data" / "bun000.ply";
  std::ofstream(dir / "out.ply") << "keep me";
  const auto r = run_cli("convert '" + bunny.string() + "' '" + (dir / "out.ply").string() + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_TRUE(contains(r.output, "--force")) << r.output;
  std::ifstream in(dir / "out.ply");
  std::string content((std::istreambuf_iterator<char>(in)), {});
  EXPECT_EQ(content, "keep me");
}

TEST(Cli, ConvertOfATruncatedCloudFailsAndLeavesNoOutput) {
  const auto dir = test::scratch_dir();
  {
    std::ofstream bad(dir / "in.ply", std::ios::binary);
    bad << "ply\nformat binary_little_endian 1.0\nelement vertex 1000\n"
           "property float x\nproperty float y\nproperty float z\nend_header\n";
    bad << std::string(100, '\0');  // 100 bytes of the 12000 promised
  }
  const auto r = run_cli("convert '" + (dir / "in.ply").string() + "' '" +
                         (dir / "out.pcd").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(contains(r.output, "in.ply")) << r.output;
  EXPECT_EQ(test::list_folder(dir), "in.ply\n");
}

// A case's mesh.ply re-exported with the other up axis: the FBX and OBJ (with its .mtl and
// texture) hold the same vertices, in Locard's frame once the chosen turn is undone.
TEST(Cli, ConvertExportsAPlyMeshWithTheChosenUpAxis) {
  const auto dir = test::scratch_dir();
  TriangleMesh mesh;
  mesh.vertices = {{0.f, 3.f, 0.f}, {1.f, 3.f, 0.f}, {0.f, 3.f, 2.f}, {1.f, 3.5f, 2.f}};
  mesh.vertex_colors = {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {9, 99, 199}};
  mesh.triangles = {{0, 1, 2}, {1, 3, 2}};
  write_ply(dir / "mesh.ply", mesh);
  for (const char* out : {"m.fbx", "m.obj"}) {
    const auto r = run_cli("--quiet convert '" + (dir / "mesh.ply").string() + "' '" +
                           (dir / out).string() + "' --up z");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const TriangleMesh back = read_mesh_assimp(dir / out, UpAxis::Z);
    ASSERT_EQ(back.vertex_count(), 4u) << out;
    for (std::size_t i = 0; i < 4; ++i) {
      const auto& p = back.vertices[i];
      const bool found = std::any_of(mesh.vertices.begin(), mesh.vertices.end(),
                                     [&](const Eigen::Vector3f& q) { return (p - q).norm() < 1e-6f; });
      EXPECT_TRUE(found) << out << ": " << p.transpose();
    }
  }
  EXPECT_EQ(test::list_folder(dir), "m.fbx\nm.mtl\nm.obj\nm.png\nmesh.ply\n");
  const auto bad = run_cli("convert '" + (dir / "mesh.ply").string() + "' '" +
                           (dir / "x.fbx").string() + "' --up x");
  EXPECT_NE(bad.exit_code, 0);
}

// Issue 14: NaN and infinite coordinates passed info and convert silently.
TEST(Cli, InfoAndConvertSayHowManyPointsAreNotFinite) {
  const auto dir = test::scratch_dir();
  std::ofstream(dir / "nan.ply") << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                    "property float y\nproperty float z\nend_header\n"
                                    "0 0 0\nnan 1 1\n1 2 inf\n";
  auto r = run_cli("info '" + (dir / "nan.ply").string() + "'");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "non-finite:    2 points")) << r.output;
  r = run_cli("--quiet convert '" + (dir / "nan.ply").string() + "' '" + (dir / "out.pcd").string() + "'");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "2 of 3 points have NaN or infinite coordinates")) << r.output;
}

TEST(Cli, ConvertMergesASequenceAtItsGroundTruthPoses) {
  const auto dir = test::scratch_dir();
  const auto data = shared_data() / "7scenes-tsdf-fusion" / "data";
  const auto r = run_cli("--quiet convert '" + data.string() + "' '" +
                         (dir / "fused.ply").string() + "' --count 3 --stride 4");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const PointCloud cloud = read_point_cloud(dir / "fused.ply");
  EXPECT_TRUE(cloud.has_colors());
  // 3 frames of 160x120 samples, most of them valid.
  EXPECT_GT(cloud.size(), 3u * 160 * 120 * 8 / 10);
  EXPECT_LE(cloud.size(), 3u * 160 * 120);
}

}  // namespace
}  // namespace locard
