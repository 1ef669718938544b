// `locard mesh` and `locard eval-mesh` end to end on a small simulated scan.
#include <locard/io/mesh_export.hpp>
#include <locard/io/ply.hpp>

#include "test_support.hpp"

#include <Eigen/Core>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

namespace locard {
namespace {

namespace fs = std::filesystem;

class MeshCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scan_ = new fs::path(test::scratch_dir() / "scan");
    const auto r = test::run_cli("--quiet scan-sim -o '" + scan_->string() + "' --views 8 --pitch -10");
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  static void TearDownTestSuite() { delete scan_; }
  static fs::path* scan_;
};
fs::path* MeshCli::scan_ = nullptr;

TEST_F(MeshCli, FusesExportsAndEvaluates) {
  const fs::path out = test::scratch_dir() / "mesh";
  const auto r = test::run_cli("mesh '" + scan_->string() + "' -o '" + out.string() +
                               "' --voxel 0.03 --format ply,glb,obj,fbx --fill-holes 12");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("ground truth"), std::string::npos) << r.output;
  EXPECT_EQ(test::list_folder(out),
            "cloud.ply\nmesh.fbx\nmesh.glb\nmesh.json\nmesh.mtl\nmesh.obj\nmesh.ply\nmesh.png\n");
  const TriangleMesh ply = read_ply_mesh(out / "mesh.ply");
  EXPECT_GT(ply.triangle_count(), 5000u);
  EXPECT_EQ(ply.vertex_colors.size(), ply.vertex_count());
  // The GLB holds the same mesh (inferred triangles in their own primitive share vertices, so
  // assimp may duplicate the rim vertices: at least as many).
  const TriangleMesh glb = read_mesh_assimp(out / "mesh.glb");
  EXPECT_EQ(glb.triangle_count(), ply.triangle_count());
  EXPECT_GE(glb.vertex_count(), ply.vertex_count());
  std::ifstream report_file(out / "mesh.json");
  const auto report = nlohmann::json::parse(report_file);
  EXPECT_EQ(report["frames_fused"], 8);
  EXPECT_EQ(report["triangles"], ply.triangle_count());

  const auto eval = test::run_cli("eval-mesh '" + (*scan_ / "scene.ply").string() + "' '" +
                                  (out / "mesh.ply").string() + "' --json --spacing 0.03");
  ASSERT_EQ(eval.exit_code, 0) << eval.output;
  const auto j = nlohmann::json::parse(eval.output.substr(eval.output.find('{')));
  EXPECT_LT(j["accuracy_mean"].get<double>(), 0.01);  // 3 cm voxels, 8 views
  EXPECT_GT(j["completeness"].get<double>(), 0.85);
  EXPECT_NE(j["counted"].get<std::string>().find("8 views"), std::string::npos);
  EXPECT_LT(j["counted_samples"].get<std::size_t>(), j["gt_samples"].get<std::size_t>());
}

TEST_F(MeshCli, RefusesBadInputWithExitStatusTwo) {
  const fs::path out = test::scratch_dir() / "out";
  EXPECT_EQ(test::run_cli("mesh /nonexistent -o '" + out.string() + "'").exit_code, 2);
  EXPECT_EQ(test::run_cli("mesh '" + scan_->string() + "' -o '" + out.string() +
                          "' --format stl")
                .exit_code,
            2);
  fs::create_directories(out);
  std::ofstream(out / "keep.txt") << "x";
  const auto r = test::run_cli("mesh '" + scan_->string() + "' -o '" + out.string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--force"), std::string::npos);
  EXPECT_EQ(test::list_folder(out), "keep.txt\n");
  EXPECT_EQ(test::run_cli("eval-mesh /nonexistent.ply '" + (*scan_ / "scene.ply").string() + "'")
                .exit_code,
            2);
}

// Issue 14: CGAL's Poisson solver crashed (SIGSEGV) on points that span no volume. A flat grid
// and a straight line are now clear errors naming what is wrong, exit 2, nothing written; a
// slightly noisy plane still meshes.
TEST_F(MeshCli, PoissonOnAFlatGridOrALineIsAnErrorNotACrash) {
  const fs::path dir = test::scratch_dir();
  const auto write_ply = [&](const std::string& name, auto point) {
    std::ofstream f(dir / name);
    f << "ply\nformat ascii 1.0\nelement vertex 900\nproperty float x\nproperty float y\n"
         "property float z\nend_header\n";
    for (int i = 0; i < 900; ++i) {
      const Eigen::Vector3f p = point(i);
      f << p.x() << ' ' << p.y() << ' ' << p.z() << '\n';
    }
  };
  write_ply("grid.ply", [](int i) { return Eigen::Vector3f(0.01f * (i % 30), 0.01f * (i / 30), 0.f); });
  write_ply("line.ply", [](int i) { return Eigen::Vector3f(0.001f * i, 0.f, 0.f); });
  for (const char* name : {"grid", "line"}) {
    const fs::path out = dir / (std::string(name) + "-mesh");
    const auto r = test::run_cli("mesh '" + (dir / (std::string(name) + ".ply")).string() +
                                 "' -o '" + out.string() + "' --method poisson");
    EXPECT_EQ(r.exit_code, 2) << name << ": " << r.output;
    EXPECT_NE(r.output.find(name == std::string("grid") ? "lie on a plane" : "lie on a line"),
              std::string::npos)
        << r.output;
    EXPECT_FALSE(fs::exists(out) && !fs::is_empty(out)) << name;
  }
}

// Issue 14: one ground-truth vertex at inf, nan or 1e10 m made eval-mesh sample a huge
// triangle (12-16 GB, then bad_alloc or a hang). Now exit 2 at once, the file named.
TEST_F(MeshCli, EvalMeshRefusesAFarOrNonFiniteVertex) {
  const fs::path dir = test::scratch_dir();
  const auto write_mesh = [&](const fs::path& path, const std::string& fourth) {
    std::ofstream(path) << "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n"
                           "property float y\nproperty float z\nelement face 2\n"
                           "property list uchar int vertex_indices\nend_header\n"
                           "0 0 0\n1 0 0\n0 1 0\n" << fourth << "\n3 0 1 2\n3 1 3 2\n";
  };
  write_mesh(dir / "mesh.ply", "1 1 0");
  for (const std::string v : {"inf", "nan", "1e10"}) {
    const fs::path gt = dir / ("gt-" + v + ".ply");
    write_mesh(gt, v + " " + v + " 0");
    const auto r = test::run_cli("eval-mesh '" + gt.string() + "' '" + (dir / "mesh.ply").string() + "'");
    EXPECT_EQ(r.exit_code, 2) << v << ": " << r.output;
    EXPECT_NE(r.output.find("gt-" + v + ".ply"), std::string::npos) << r.output;
  }
}

TEST_F(MeshCli, TakesPosesFromATumTrajectory) {
  // The scan's own ground truth written as a separate trajectory: the same mesh as fusing at
  // the ground truth directly.
  const fs::path a = test::scratch_dir() / "a", b = test::scratch_dir() / "b";
  ASSERT_EQ(test::run_cli("--quiet mesh '" + scan_->string() + "' -o '" + a.string() +
                          "' --voxel 0.05 --format ply --no-cloud")
                .exit_code,
            0);
  const auto r = test::run_cli("mesh '" + scan_->string() + "' -o '" + b.string() +
                               "' --voxel 0.05 --format ply --no-cloud --trajectory '" +
                               (*scan_ / "groundtruth.txt").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("groundtruth.txt"), std::string::npos);
  const TriangleMesh ma = read_ply_mesh(a / "mesh.ply"), mb = read_ply_mesh(b / "mesh.ply");
  EXPECT_EQ(ma.vertices, mb.vertices);
  EXPECT_EQ(ma.triangles, mb.triangles);
}

}  // namespace
}  // namespace locard
