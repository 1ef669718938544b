// `locard align` and `locard eval-trajectory` end to end: outputs, exit codes, bad input.
#include "test_support.hpp"

#include <locard/io/trajectory_io.hpp>
#include <locard/sim/scan_writer.hpp>
#include <locard/sim/scene.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>

namespace locard {
namespace {

namespace fs = std::filesystem;

TEST(AlignCli, WritesTrajectoryPoseGraphReportAndFusedCloud) {
  const fs::path base = test::scratch_dir();  // one per test: call it once
  const fs::path scan = base / "scan";
  sim::Scene scene = sim::builtin_scene("bedroom");
  sim::write_simulated_scan(scene, scan);  // the two-ring turn; the first 8 views are aligned
  const fs::path out = base / "out";
  const std::string args = "-q align '" + scan.string() + "' -o '" + out.string() + "' --frames 8";
  const auto r = test::run_cli(args);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* name : {"trajectory.txt", "pose_graph.json", "stage_report.json",
                           "stage_report.svg", "fused.ply"})
    EXPECT_TRUE(fs::exists(out / name)) << name << "\n" << test::list_folder(out);
  const Trajectory t = read_tum_trajectory(out / "trajectory.txt");
  EXPECT_EQ(t.size(), 8u);
  std::ifstream in(out / "stage_report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_TRUE(report["has_ground_truth"].get<bool>());
  EXPECT_TRUE(report["unregistered_frames"].empty());
  EXPECT_LT(report["stages"]["loop_closure"]["ate_rmse_m"].get<double>(), 0.01);
  std::ifstream pg(out / "pose_graph.json");
  const nlohmann::json graph = nlohmann::json::parse(pg);
  EXPECT_EQ(graph["nodes"].size(), 8u);
  EXPECT_GE(graph["edges"].size(), 7u);

  // eval-trajectory of the result against the scan's ground truth agrees with the report.
  const auto e = test::run_cli("eval-trajectory --json '" + (scan / "groundtruth.txt").string() +
                               "' '" + (out / "trajectory.txt").string() + "'");
  ASSERT_EQ(e.exit_code, 0) << e.output;
  const nlohmann::json ej = nlohmann::json::parse(e.output.substr(e.output.find('{')));
  EXPECT_EQ(ej["pairs"].get<std::size_t>(), 8u);
  EXPECT_NEAR(ej["ate_m"]["rmse"].get<double>(),
              report["stages"]["loop_closure"]["ate_rmse_m"].get<double>(), 1e-6);

  // A second run into the same folder needs --force.
  const auto again = test::run_cli(args);
  EXPECT_EQ(again.exit_code, 2) << again.output;
  EXPECT_NE(again.output.find("--force"), std::string::npos) << again.output;
}

// A set of range scans instead of an RGB-D sequence: multiway registration from identity. Three
// bunny scans in a folder of their own (no .conf: each scan is in its sensor's frame), then the
// whole bun.conf with its errors against the file.
TEST(AlignCli, RangeScanSetsAreRegisteredFromIdentity) {
  const fs::path base = test::scratch_dir();
  const fs::path data = test::shared_data() / "stanford-bunny" / "bunny" / "data";
  const fs::path scans = base / "scans";
  fs::create_directories(scans);
  for (const char* name : {"bun000.ply", "bun045.ply", "bun090.ply"})
    fs::copy_file(data / name, scans / name);
  auto r = test::run_cli("-q align '" + scans.string() + "' -o '" + (base / "a").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* name : {"aligned.conf", "scan_alignment.json", "fused.ply"})
    EXPECT_TRUE(fs::exists(base / "a" / name)) << name << "\n" << test::list_folder(base / "a");
  std::ifstream in(base / "a" / "scan_alignment.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  ASSERT_EQ(j["scans"].size(), 3u);
  for (const auto& scan : j["scans"]) EXPECT_TRUE(scan["placed"].get<bool>()) << scan.dump();

  r = test::run_cli("align '" + (data / "bun.conf").string() + "' -o '" + (base / "b").string() +
                    "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("10 of 10 scans placed"), std::string::npos) << r.output;
  std::ifstream in2(base / "b" / "scan_alignment.json");
  const nlohmann::json k = nlohmann::json::parse(in2);
  ASSERT_EQ(k["scans"].size(), 10u);
  for (const auto& scan : k["scans"]) {
    EXPECT_LE(scan["error_deg"].get<double>(), 1.0) << scan.dump();
    EXPECT_LE(scan["error_m"].get<double>(), 0.003) << scan.dump();
  }
  // aligned.conf is a Stanford .conf again: ten bmesh lines.
  std::ifstream conf(base / "b" / "aligned.conf");
  const std::string text((std::istreambuf_iterator<char>(conf)), {});
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 10) << text;

  // Fewer than two scans: exit 2 naming the folder.
  const fs::path one = base / "one";
  fs::create_directories(one);
  fs::copy_file(data / "bun000.ply", one / "bun000.ply");
  r = test::run_cli("align '" + one.string() + "' -o '" + (base / "c").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
}

TEST(AlignCli, BadInputExitsTwo) {
  const fs::path empty = test::scratch_dir();
  auto r = test::run_cli("align '" + empty.string() + "' -o '" + (empty / "o").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = test::run_cli("align /no/such/folder -o /tmp/x");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("/no/such/folder"), std::string::npos) << r.output;
  r = test::run_cli("eval-trajectory /no/such/gt.txt /no/such/est.txt");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  const fs::path gt = test::shared_data() / "tum-fr1-xyz-metadata" / "groundtruth.txt";
  r = test::run_cli("eval-trajectory '" + gt.string() + "' '" + gt.string() +
                    "' --delta-unit weeks");
  EXPECT_EQ(r.exit_code, 2) << r.output;
}

TEST(AlignCli, EvalTrajectoryOfGroundTruthAgainstItselfIsZero) {
  const fs::path gt = test::shared_data() / "tum-fr1-xyz-metadata" / "groundtruth.txt";
  const auto r = test::run_cli("eval-trajectory '" + gt.string() + "' '" + gt.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("absolute_translational_error.rmse 0.000000 m"), std::string::npos)
      << r.output;
}

}  // namespace
}  // namespace locard
