// `reconstruct` on range scans (docs/laser-scans.md):
//  - a folder of PLY scans cut from a known surface (the bunny's reference mesh, 3 slabs
//    overlapping by 60 %) and moved by
//    known poses, no poses given: the case recovers every relative pose within 0.5 degree and
//    1 mm, a junk scan is reported by index and left out (and the case says too few verified),
//    and cloud/registered.e57 reads back with one scan per registered view at its pose;
//  - the Stanford bunny's bun.conf: every scan registered and the mesh within 1 mm (mean) of
//    the reference reconstruction bun_zipper.ply (release builds: the whole bunny).
#include <locard/core/error.hpp>
#include <locard/forensics/reconstruct.hpp>
#include <locard/io/e57.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/point_cloud_io.hpp>
#include <locard/io/stanford_conf.hpp>
#include <locard/io/trajectory_io.hpp>
#include <locard/surface/mesh_evaluation.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <Eigen/Geometry>

#include <cstdio>
#include <fstream>
#include <random>

namespace locard::forensics {
namespace {

namespace fs = std::filesystem;

using test::kSanitized;

const fs::path kBunny = test::shared_data() / "stanford-bunny" / "bunny";

ReconstructParameters quick_parameters() {
  ReconstructParameters p;
  p.pdf = false;
  p.formats = {MeshFormat::Ply};
  p.render_width = 160;
  p.render_height = 100;
  return p;
}

Isometry3d pose(double rx, double ry, double rz, double tx, double ty, double tz) {
  Isometry3d T = Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(rx, Eigen::Vector3d::UnitX()) *
                Eigen::AngleAxisd(ry, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(rz, Eigen::Vector3d::UnitZ()))
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(tx, ty, tz);
  return T;
}

// Overlapping slabs of the reference surface along x, each moved into its own frame by
// T_scan_world (so T_world_scan, the truth, is its inverse).
struct CutScans {
  std::vector<PointCloud> scans;
  std::vector<Isometry3d> T_world_scan;
};

CutScans cut_bunny(std::size_t pieces) {
  const TriangleMesh ref = read_ply_mesh(kBunny / "reconstruction" / "bun_zipper.ply");
  float lo = 1e9f, hi = -1e9f;
  for (const Eigen::Vector3f& v : ref.vertices) {
    lo = std::min(lo, v.x());
    hi = std::max(hi, v.x());
  }
  const float width = (hi - lo) / (0.4f * static_cast<float>(pieces - 1) + 1.0f);  // 60 % overlap
  CutScans out;
  for (std::size_t k = 0; k < pieces; ++k) {
    const float a = lo + 0.4f * width * static_cast<float>(k), b = a + width;
    const double kd = static_cast<double>(k);
    const Isometry3d T_world_scan = pose(0.3 * kd, -0.5 * kd, 0.8 * kd, 0.05 * kd, -0.02, 0.1 * kd);
    PointCloud scan;
    for (const Eigen::Vector3f& v : ref.vertices)
      if (v.x() >= a && v.x() <= b)
        scan.positions.push_back((T_world_scan.inverse() * v.cast<double>()).cast<float>());
    out.scans.push_back(std::move(scan));
    out.T_world_scan.push_back(T_world_scan);
  }
  return out;
}

TEST(ReconstructScans, FolderOfCutScansRecoversThePosesReportsAJunkScanAndExportsE57) {
  const fs::path dir = test::scratch_dir();
  const fs::path scans_dir = dir / "scans";
  fs::create_directories(scans_dir);
  const CutScans cut = cut_bunny(3);
  for (std::size_t k = 0; k < cut.scans.size(); ++k)
    write_ply(scans_dir / ("piece" + std::to_string(k) + ".ply"), cut.scans[k]);
  // A fourth "scan" that overlaps nothing: a random blob far away.
  PointCloud junk;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-0.05f, 0.05f);
  for (int i = 0; i < 3000; ++i) junk.positions.emplace_back(5.0f + u(rng), u(rng), u(rng));
  write_ply(scans_dir / "piece9_junk.ply", junk);

  const ReconstructSummary s = reconstruct_case(scans_dir, dir / "case", quick_parameters(), false);
  EXPECT_EQ(s.frames, 4u);
  EXPECT_EQ(s.registered, 3u);
  EXPECT_EQ(s.flagged, (std::vector<std::int64_t>{3}));
  EXPECT_FALSE(s.enough_verified);  // 3 of 4 < 90 %: the CLI exits 4
  EXPECT_GT(s.triangles, 1000u);

  // Poses: the case is in scan 0's frame; compare T_world_scan relative to scan 0.
  const Trajectory t = read_tum_trajectory(dir / "case" / "alignment" / "trajectory.txt");
  ASSERT_EQ(t.size(), 3u);
  const Isometry3d T_truth_case = cut.T_world_scan[0] * t[0].T_world_camera.inverse();
  for (std::size_t k = 0; k < 3; ++k) {
    const Isometry3d estimate = T_truth_case * t[k].T_world_camera;
    const double dr = rotation_difference_deg(cut.T_world_scan[k], estimate);
    const double dt = translation_difference_m(cut.T_world_scan[k], estimate);
    std::printf("  piece %zu: %.3f deg, %.3f mm\n", k, dr, 1000.0 * dt);
    EXPECT_LT(dr, 0.5) << "piece " << k;
    EXPECT_LT(dt, 0.001) << "piece " << k;
  }
  const auto report = nlohmann::json::parse(std::ifstream(dir / "case" / "alignment" / "stage_report.json"));
  ASSERT_EQ(report["scans"].size(), 4u);
  EXPECT_FALSE(report["scans"][3]["verified"].get<bool>());
  EXPECT_GT(report["scans"][1]["confidence"].get<double>(), 0.3);

  // The E57 export: one scan per registered view, its points in its own frame, its pose.
  const E57File e57 = read_e57(dir / "case" / "cloud" / "registered.e57");
  ASSERT_EQ(e57.scans.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_TRUE(e57.scans[k].has_pose);
    EXPECT_EQ(e57.scans[k].name, "piece" + std::to_string(k) + ".ply");
    EXPECT_EQ(e57.scans[k].cloud.size(), cut.scans[k].size());
    EXPECT_LT(translation_difference_m(e57.scans[k].T_file_scan, t[k].T_world_camera), 1e-6);
    EXPECT_LT(rotation_difference_deg(e57.scans[k].T_file_scan, t[k].T_world_camera), 1e-4);
  }
}

// An E57 of three bunny scans, two with their bun.conf pose and one without (registered by
// features against the others): every scan registered, within 0.5 degree and 1 mm of bun.conf
// relative to the first.
TEST(ReconstructScans, AnE57OfScansWithAndWithoutPoses) {
  const fs::path dir = test::scratch_dir();
  const StanfordConf conf = read_stanford_conf(kBunny / "data" / "bun.conf");
  const std::vector<std::size_t> pick = {0, 1, 7};  // bun000, bun045, bun315
  std::vector<E57Scan> scans;
  for (std::size_t i : pick) {
    E57Scan e;
    e.name = conf.scans[i].name;
    e.cloud = read_point_cloud(conf.scans[i].file);
    e.has_pose = i != 7;
    if (e.has_pose) e.T_file_scan = conf.scans[i].T_world_scan;
    scans.push_back(std::move(e));
  }
  write_e57(dir / "scans.e57", scans);
  const ReconstructSummary s = reconstruct_case(dir / "scans.e57", dir / "case", quick_parameters(), false);
  EXPECT_EQ(s.registered, 3u);
  const Trajectory t = read_tum_trajectory(dir / "case" / "alignment" / "trajectory.txt");
  ASSERT_EQ(t.size(), 3u);
  const Isometry3d T_conf_case = conf.scans[0].T_world_scan * t[0].T_world_camera.inverse();
  for (std::size_t k = 0; k < 3; ++k) {
    const Isometry3d& truth = conf.scans[pick[k]].T_world_scan;
    const Isometry3d estimate = T_conf_case * t[k].T_world_camera;
    EXPECT_LT(rotation_difference_deg(truth, estimate), 0.5) << k;
    EXPECT_LT(translation_difference_m(truth, estimate), 0.001) << k;
  }
  const auto c = nlohmann::json::parse(std::ifstream(dir / "case" / "case.json"));
  EXPECT_EQ(c["inputs"]["format"], "E57 scans");
}

TEST(ReconstructScans, RefusesASingleScanAndAnUnknownScanPoseSource) {
  const fs::path dir = test::scratch_dir();
  fs::create_directories(dir / "one");
  write_ply(dir / "one" / "a.ply", cut_bunny(2).scans[0]);
  EXPECT_THROW(reconstruct_case(dir / "one", dir / "case", quick_parameters(), false), InputError);
  // An unknown pose source in a parameter file is refused with the key named, before any case.
  {
    std::ofstream(dir / "params.json") << R"({"scan_poses": "guess"})";
  }
  try {
    (void)ReconstructParameters::from_json_file(dir / "params.json", quick_parameters());
    ADD_FAILURE() << "an unknown scan_poses was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("scan_poses"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("input, global"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir / "case2" / "case.json"));
}

TEST(ReconstructScans, BunnyConfMeshWithinOneMillimetreOfTheReference) {
  if (kSanitized) GTEST_SKIP() << "the whole bunny: release builds only";
  const fs::path dir = test::scratch_dir();
  const ReconstructSummary s =
      reconstruct_case(kBunny / "data" / "bun.conf", dir / "case", quick_parameters(), false);
  EXPECT_EQ(s.registered, 10u);
  EXPECT_TRUE(s.flagged.empty());
  EXPECT_TRUE(s.enough_verified);
  const TriangleMesh mesh = read_ply_mesh(dir / "case" / "mesh" / "mesh.ply");
  const TriangleMesh ref = read_ply_mesh(kBunny / "reconstruction" / "bun_zipper.ply");
  MeshEvaluationOptions eo;
  eo.completeness_threshold = 0.001;
  eo.sample_spacing = 0.001;
  const MeshEvaluation e = evaluate_mesh(ref, mesh, eo);
  std::printf("  bunny: %zu vertices, mean %.3f mm, median %.3f mm, p90 %.3f mm, completeness "
              "(1 mm) %.1f %%, %.1f s\n",
              e.mesh_vertices, 1000 * e.accuracy_mean, 1000 * e.accuracy_median,
              1000 * e.accuracy_p90, 100 * e.completeness, s.seconds);
  EXPECT_LT(e.accuracy_mean, 0.001);
  EXPECT_GT(e.completeness, 0.9);
  const E57File e57 = read_e57(dir / "case" / "cloud" / "registered.e57");
  EXPECT_EQ(e57.scans.size(), 10u);
}

}  // namespace
}  // namespace locard::forensics
