// `locard register`: the printed T_target_source against bun.conf, the files it writes, and
// its exit status for bad input (2) and failed registrations (3).
#include <locard/io/ply.hpp>
#include <locard/io/point_cloud_io.hpp>
#include <locard/io/stanford_conf.hpp>
#include <locard/preprocess/voxel_grid.hpp>

#include "test_support.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <limits>

namespace locard {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

fs::path bunny_data() { return test::shared_data() / "stanford-bunny" / "bunny" / "data"; }

std::string q(const fs::path& p) { return "'" + p.string() + "'"; }

Isometry3d scan_pose(const std::string& name) {
  for (const RangeScan& s : read_stanford_conf(bunny_data() / "bun.conf").scans)
    if (s.name == name) return s.T_world_scan;
  ADD_FAILURE() << "no scan " << name;
  return Isometry3d::Identity();
}

// bun045 and bun000 thinned to 1 mm (the CLI run stays short under ASan), in `dir`.
std::pair<fs::path, fs::path> bunny_pair(const fs::path& dir) {
  const fs::path source = dir / "bun045.ply", target = dir / "bun000.ply";
  write_ply(source, voxel_down_sample(read_point_cloud(bunny_data() / "bun045.ply"), 0.001f).cloud);
  write_ply(target, voxel_down_sample(read_point_cloud(bunny_data() / "bun000.ply"), 0.001f).cloud);
  return {source, target};
}

Isometry3d from_json(const nlohmann::json& rows) {
  Isometry3d T = Isometry3d::Identity();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) T.matrix()(r, c) = rows.at(r).at(c).get<double>();
  return T;
}

nlohmann::json parse_json(const std::string& output) {
  // stderr is merged into the output; the JSON object is the part from the first '{'.
  return nlohmann::json::parse(output.substr(output.find('{')), nullptr, false);
}

TEST(RegisterCommand, BunnyPairFromIdentityMatchesBunConf) {
  const fs::path dir = test::scratch_dir();
  const auto [source, target] = bunny_pair(dir);
  const Isometry3d truth = scan_pose("bun000.ply").inverse() * scan_pose("bun045.ply");

  const auto json_run = test::run_cli("register " + q(source) + " " + q(target) + " --json");
  ASSERT_EQ(json_run.exit_code, 0) << json_run.output;
  const nlohmann::json j = parse_json(json_run.output);
  ASSERT_FALSE(j.is_discarded()) << json_run.output;
  EXPECT_TRUE(j["success"].get<bool>());
  const Isometry3d T = from_json(j["T_target_source"]);
  EXPECT_LE(rotation_difference_deg(truth, T), 2.0);
  EXPECT_LE(translation_difference_m(truth, T), 0.005);
  EXPECT_GT(j["fitness"].get<double>(), 0.8);
  EXPECT_EQ(j["initial"]["kind"], "global");
  EXPECT_EQ(j["initial"]["seed"], 0);
  EXPECT_EQ(j["levels"].size(), 3u);
  EXPECT_EQ(j["information"].size(), 6u);

  const auto text = test::run_cli("register " + q(source) + " " + q(target) + " --seed 5");
  ASSERT_EQ(text.exit_code, 0) << text.output;
  EXPECT_THAT(text.output, HasSubstr("T_target_source"));
  EXPECT_THAT(text.output, HasSubstr("fitness:"));
  EXPECT_THAT(text.output, HasSubstr("inlier RMSE:"));
  EXPECT_THAT(text.output, HasSubstr("RANSAC seed 5"));
}

TEST(RegisterCommand, WritesTheAlignedCloudAndATransformThatInitReadsBack) {
  const fs::path dir = test::scratch_dir();
  const auto [source, target] = bunny_pair(dir);
  const fs::path aligned = dir / "aligned.ply", matrix = dir / "T.txt";
  const auto run = test::run_cli("register " + q(source) + " " + q(target) + " -o " +
                                 q(aligned) + " --transform-out " + q(matrix) + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const Isometry3d T = from_json(parse_json(run.output)["T_target_source"]);
  const PointCloud in = read_point_cloud(source), out = read_point_cloud(aligned);
  ASSERT_EQ(in.size(), out.size());
  for (std::size_t i = 0; i < in.size(); i += 97)
    EXPECT_LT((T.cast<float>() * in.positions[i] - out.positions[i]).norm(), 1e-6f);

  // The written matrix, fed back as --init with one ICP level, is already the answer.
  const auto again = test::run_cli("register " + q(source) + " " + q(target) + " --init " +
                                   q(matrix) + " --levels 1 --json");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  const nlohmann::json j = parse_json(again.output);
  EXPECT_EQ(j["initial"]["kind"], "file");
  const Isometry3d T2 = from_json(j["T_target_source"]);
  EXPECT_LE(rotation_difference_deg(T, T2), 0.05);
  EXPECT_LE(translation_difference_m(T, T2), 0.0005);

  // Existing outputs are not overwritten without --force.
  const auto refused = test::run_cli("register " + q(source) + " " + q(target) + " -o " +
                                     q(aligned) + " --init identity");
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_THAT(refused.output, HasSubstr("--force"));
}

TEST(RegisterCommand, BadInputExitsWithTwoAndSaysWhy) {
  const fs::path dir = test::scratch_dir();
  const auto [source, target] = bunny_pair(dir);
  const auto expect_error = [&](const std::string& args, const std::string& message) {
    const auto r = test::run_cli("register " + args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
    EXPECT_THAT(r.output, HasSubstr(message)) << args;
  };
  expect_error(q(dir / "missing.ply") + " " + q(target), "no such file");
  expect_error(q(source) + " " + q(target) + " --method gicp", "--method must be");
  expect_error(q(source) + " " + q(target) + " --kernel cauchy", "--kernel must be");

  const fs::path skewed = dir / "skewed.txt";
  std::ofstream(skewed) << "1 0 0 0\n0 2 0 0\n0 0 1 0\n0 0 0 1\n";
  expect_error(q(source) + " " + q(target) + " --init " + q(skewed), "not a rotation");
  const fs::path short_matrix = dir / "short.txt";
  std::ofstream(short_matrix) << "1 0 0\n0 1 0\n";
  expect_error(q(source) + " " + q(target) + " --init " + q(short_matrix), "found 6 numbers");
  const fs::path words = dir / "words.txt";
  std::ofstream(words) << "1 0 0 0\n0 1 zero 0\n";
  expect_error(q(source) + " " + q(target) + " --init " + q(words), "words.txt:2");

  const fs::path empty = dir / "empty.ply";
  write_ply(empty, PointCloud{});
  expect_error(q(empty) + " " + q(target), "no points");
  // Only NaN points: nothing usable, named as such.
  PointCloud nans;
  nans.positions.assign(20, Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  const fs::path nan_file = dir / "nan.ply";
  write_ply(nan_file, nans);
  expect_error(q(nan_file) + " " + q(target) + " --init identity", "NaN/Inf");
}

// No overlap at the given pose: exit 3, the failure and its fitness are printed, and no
// aligned cloud is written.
TEST(RegisterCommand, FailedRegistrationExitsWithThreeAndWritesNothing) {
  const fs::path dir = test::scratch_dir();
  const auto [source, target] = bunny_pair(dir);
  const fs::path away = dir / "away.txt", aligned = dir / "aligned.ply";
  std::ofstream(away) << "1 0 0 10\n0 1 0 0\n0 0 1 0\n0 0 0 1\n";
  const auto r = test::run_cli("register " + q(source) + " " + q(target) + " --init " + q(away) +
                               " --levels 1 -o " + q(aligned));
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_THAT(r.output, HasSubstr("registration failed"));
  EXPECT_THAT(r.output, HasSubstr("do not overlap"));
  EXPECT_THAT(r.output, HasSubstr("fitness:       0.000000"));
  EXPECT_FALSE(fs::exists(aligned));
  EXPECT_THAT(test::list_folder(dir), Not(HasSubstr("aligned")));
}

}  // namespace
}  // namespace locard
