// Multiway registration of the Stanford bunny's 10 range scans from identity, with bun.conf as
// ground truth (../shared/data/stanford-bunny/SOURCE.md: T_world_scan = [R(q)^T | t]).
// Every scan must land within 1 degree and 3 mm of bun.conf, once the whole set is expressed in
// bun.conf's frame through scan 0 (bun.conf's first scan, bun000, is the identity there).
#include <locard/alignment/scan_alignment.hpp>
#include <locard/core/error.hpp>
#include <locard/io/point_cloud_io.hpp>
#include <locard/io/stanford_conf.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cstdio>

namespace locard {
namespace {

constexpr double kMaxRotationDeg = 1.0;  // the bound for the whole set
constexpr double kMaxTranslationM = 0.003;

TEST(ScanAlignment, BunnyTenScansFromIdentityWithinOneDegreeAndThreeMillimetres) {
  const StanfordConf conf = read_stanford_conf(test::shared_data() / "stanford-bunny" / "bunny" /
                                               "data" / "bun.conf");
  ASSERT_EQ(conf.scans.size(), 10u);
  std::vector<PointCloud> scans;
  for (const RangeScan& s : conf.scans) scans.push_back(read_point_cloud(s.file));
  const ScanAlignmentResult r = align_scans(scans);
  ASSERT_EQ(r.T_world_scan.size(), scans.size());
  // The estimate lives in scan 0's frame; bun.conf's in its own: map through scan 0.
  const Isometry3d T_conf_world = conf.scans[0].T_world_scan;
  double worst_deg = 0.0, worst_m = 0.0;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    ASSERT_TRUE(r.placed[i]) << conf.scans[i].name << " was not connected to the others";
    const Isometry3d estimate = T_conf_world * r.T_world_scan[i];
    const double dr = rotation_difference_deg(conf.scans[i].T_world_scan, estimate);
    const double dt = translation_difference_m(conf.scans[i].T_world_scan, estimate);
    std::printf("  %-12s %.3f deg  %.3f mm\n", conf.scans[i].name.c_str(), dr, 1000.0 * dt);
    EXPECT_LE(dr, kMaxRotationDeg) << conf.scans[i].name;
    EXPECT_LE(dt, kMaxTranslationM) << conf.scans[i].name;
    worst_deg = std::max(worst_deg, dr);
    worst_m = std::max(worst_m, dt);
  }
  std::size_t verified = 0, kept = 0;
  for (const ScanPair& p : r.pairs) {
    verified += p.verified;
    kept += p.kept;
  }
  std::printf("  worst %.3f deg, %.3f mm; %zu of %zu pairs verified, %zu kept; %.1f s\n",
              worst_deg, 1000.0 * worst_m, verified, r.pairs.size(), kept, r.seconds);
}

TEST(ScanAlignment, SameSeedSamePoses) {
  const StanfordConf conf = read_stanford_conf(test::shared_data() / "stanford-bunny" / "bunny" /
                                               "data" / "bun.conf");
  std::vector<PointCloud> scans;
  for (std::size_t i = 0; i < 3; ++i) scans.push_back(read_point_cloud(conf.scans[i].file));
  ScanAlignmentOptions o;
  o.voxel_size = 0.004;
  o.refine_rounds = 1;
  const ScanAlignmentResult a = align_scans(scans, o);
  const ScanAlignmentResult b = align_scans(scans, o);
  for (std::size_t i = 0; i < scans.size(); ++i)
    EXPECT_TRUE(a.T_world_scan[i].matrix() == b.T_world_scan[i].matrix()) << "scan " << i;
}

// From the .conf's poses, each disturbed by about 2 degrees and 3 mm, with a junk scan first:
// the junk is left unplaced (the root moves to the next scan), the others return to bun.conf
// within 0.5 degree and 1.5 mm of each other. Every scan has an input pose, so the model stays
// in the input's frame: the root keeps its input pose.
TEST(ScanAlignment, FromDisturbedInputPosesWithAJunkScanFirst) {
  const StanfordConf conf = read_stanford_conf(test::shared_data() / "stanford-bunny" / "bunny" /
                                               "data" / "bun.conf");
  PointCloud junk;
  for (int i = 0; i < 2000; ++i)
    junk.positions.emplace_back(3.0f + 0.001f * static_cast<float>(i % 37),
                                0.002f * static_cast<float>((i * 7) % 41), 0.0003f * static_cast<float>(i % 13));
  std::vector<PointCloud> scans = {junk};
  std::vector<std::optional<Isometry3d>> initial = {Isometry3d::Identity()};
  std::vector<Isometry3d> truth = {Isometry3d::Identity()};
  for (std::size_t i : {0u, 1u, 7u}) {  // bun000, bun045, bun315
    scans.push_back(read_point_cloud(conf.scans[i].file));
    truth.push_back(conf.scans[i].T_world_scan);
    Isometry3d disturbed = conf.scans[i].T_world_scan;
    disturbed.linear() = disturbed.linear() *
                         Eigen::AngleAxisd(0.035, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    disturbed.translation() += Eigen::Vector3d(0.002, -0.002, 0.001);
    initial.push_back(disturbed);
  }
  const ScanAlignmentResult r = align_scans(scans, ScanAlignmentOptions{}, initial);
  EXPECT_FALSE(r.placed[0]);
  EXPECT_EQ(r.root, 1u);
  EXPECT_EQ(r.fit[0].fitness, 0.0);
  // The root keeps its (disturbed) input pose: compare the others relative to it.
  const Isometry3d T_truth_est = truth[1] * r.T_world_scan[1].inverse();
  for (std::size_t i = 1; i < scans.size(); ++i) {
    ASSERT_TRUE(r.placed[i]) << i;
    EXPECT_GT(r.fit[i].fitness, 0.3) << i;
    const Isometry3d estimate = T_truth_est * r.T_world_scan[i];
    EXPECT_LE(rotation_difference_deg(truth[i], estimate), 0.5) << i;
    EXPECT_LE(translation_difference_m(truth[i], estimate), 0.0015) << i;
  }
  EXPECT_TRUE(r.T_world_scan[1].isApprox(*initial[1], 1e-12));
}

TEST(ScanAlignment, OptionsScaleWithThePointSpacing) {
  const ScanAlignmentOptions a = scan_alignment_options_for_spacing(0.0006);
  const ScanAlignmentOptions b = scan_alignment_options_for_spacing(0.006);
  EXPECT_NEAR(a.voxel_size, ScanAlignmentOptions{}.voxel_size, 1e-12);
  EXPECT_NEAR(b.voxel_size, 10.0 * a.voxel_size, 1e-12);
  EXPECT_NEAR(b.icp_gates.back(), 10.0 * a.icp_gates.back(), 1e-12);
  PointCloud grid;
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 20; ++j) grid.positions.emplace_back(0.003f * i, 0.003f * j, 0.0f);
  EXPECT_NEAR(median_point_spacing({grid}), 0.003, 1e-6);
}

TEST(ScanAlignment, RejectsFewerThanTwoScans) {
  PointCloud one;
  for (int i = 0; i < 10; ++i) one.positions.emplace_back(0.01f * i, 0.0f, 0.0f);
  EXPECT_THROW(align_scans({one}), InputError);
  EXPECT_THROW(align_scans({one, PointCloud{}}), InputError);
}

}  // namespace
}  // namespace locard
