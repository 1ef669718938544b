// Which inputs are range-scan sets, of which typed kind, with which poses and sensor side.
#include <locard/core/error.hpp>
#include <locard/io/e57.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/range_scans.hpp>
#include <locard/io/rgbd_sequence.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>

namespace locard {
namespace {

namespace fs = std::filesystem;

PointCloud line_cloud(float offset) {
  PointCloud c;
  for (int i = 0; i < 10; ++i) c.positions.emplace_back(0.01f * i + offset, 0.002f * i, 1.0f);
  return c;
}

TEST(RangeScans, StanfordConfGivesItsScansPosesAndTheFarZViewpoint) {
  const fs::path data = test::shared_data() / "stanford-bunny" / "bunny" / "data";
  for (const fs::path& input : {data / "bun.conf", data}) {
    const auto set = find_range_scans(input);
    ASSERT_TRUE(set) << input;
    EXPECT_EQ(set->source, RangeScanSource::StanfordConf);
    EXPECT_EQ(set->viewpoint, ScanViewpoint::FarAlongZ);
    ASSERT_EQ(set->scans.size(), 10u);
    EXPECT_TRUE(set->all_posed());
    EXPECT_EQ(set->scans[1].name, "bun045.ply");
    EXPECT_EQ(set->files.size(), 11u);  // the .conf and its 10 scans
  }
}

TEST(RangeScans, AFolderOfScansHasNoPosesAndOneScanIsNotASet) {
  const fs::path dir = test::scratch_dir();
  write_ply(dir / "b.ply", line_cloud(0.0f));
  EXPECT_FALSE(find_range_scans(dir));  // one scan: a cloud, not a set
  write_ply(dir / "a.ply", line_cloud(1.0f));
  const auto set = find_range_scans(dir);
  ASSERT_TRUE(set);
  EXPECT_EQ(detect_format(dir), DatasetFormat::RangeScanFolder);
  EXPECT_EQ(set->source, RangeScanSource::ScanFolder);
  EXPECT_EQ(set->viewpoint, ScanViewpoint::Origin);
  ASSERT_EQ(set->scans.size(), 2u);
  EXPECT_EQ(set->scans[0].name, "a.ply");  // sorted by name
  EXPECT_FALSE(set->any_posed());
  const std::vector<PointCloud> clouds = load_range_scans(*set);
  EXPECT_FLOAT_EQ(clouds[0].positions[0].x(), 1.0f);
}

TEST(RangeScans, AnE57OfSeveralScansKeepsTheGivenPosesOnly) {
  const fs::path dir = test::scratch_dir();
  std::vector<E57Scan> scans(2);
  scans[0].name = "north";
  scans[0].cloud = line_cloud(0.0f);
  scans[0].has_pose = true;
  scans[0].T_file_scan.translation() = Eigen::Vector3d(1.0, 2.0, 3.0);
  scans[1].name = "south";
  scans[1].cloud = line_cloud(0.5f);
  write_e57(dir / "two.e57", scans);
  const auto set = find_range_scans(dir / "two.e57");
  ASSERT_TRUE(set);
  EXPECT_EQ(set->source, RangeScanSource::E57);
  ASSERT_EQ(set->scans.size(), 2u);
  EXPECT_EQ(set->scans[1].name, "south");
  ASSERT_TRUE(set->scans[0].T_world_scan);
  EXPECT_EQ(set->scans[0].T_world_scan->translation(), Eigen::Vector3d(1.0, 2.0, 3.0));
  EXPECT_FALSE(set->scans[1].T_world_scan);
  const std::vector<PointCloud> clouds = load_range_scans(*set);
  EXPECT_EQ(clouds[1].size(), 10u);
  scans.pop_back();
  write_e57(dir / "one.e57", scans);
  EXPECT_FALSE(find_range_scans(dir / "one.e57"));
}

TEST(RangeScans, FarAlongZSensorSitsAboveTheScan) {
  const Eigen::Vector3f s = sensor_position(ScanViewpoint::FarAlongZ, line_cloud(0.0f));
  EXPECT_GT(s.z(), 1000.0f);
  EXPECT_EQ(sensor_position(ScanViewpoint::Origin, line_cloud(0.0f)), Eigen::Vector3f::Zero());
}

}  // namespace
}  // namespace locard
