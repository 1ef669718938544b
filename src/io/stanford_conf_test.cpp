#include <locard/core/error.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/stanford_conf.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>
#include <nanoflann.hpp>

#include <fstream>
#include <limits>
#include <string>

namespace locard {
namespace {

namespace fs = std::filesystem;
using test::scratch_dir;
using test::shared_data;

fs::path bunny_data() { return shared_data() / "stanford-bunny" / "bunny" / "data"; }

// nanoflann's dataset adaptor over a vector of points.
struct Points {
  const std::vector<Eigen::Vector3f>& pts;
  std::size_t kdtree_get_point_count() const { return pts.size(); }
  float kdtree_get_pt(std::size_t i, std::size_t dim) const { return pts[i][dim]; }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const { return false; }
};
using KdTree =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Points>, Points, 3, std::size_t>;

std::vector<Eigen::Vector3f> transformed(const std::vector<Eigen::Vector3f>& pts, const Isometry3d& T) {
  const Eigen::Isometry3f Tf = T.cast<float>();
  std::vector<Eigen::Vector3f> out;
  out.reserve(pts.size());
  for (const auto& p : pts) out.push_back(Tf * p);
  return out;
}

// Fraction of `query` points within `radius` of `target`; a brute-force pass checks the tree
// on every 401st query.
double overlap_fraction(const std::vector<Eigen::Vector3f>& target,
                        const std::vector<Eigen::Vector3f>& query, float radius) {
  const Points adaptor{target};
  KdTree tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  tree.buildIndex();
  std::size_t close = 0;
  for (std::size_t i = 0; i < query.size(); ++i) {
    std::size_t index = 0;
    float dist_sq = 0.0f;  // nanoflann reports squared distances
    tree.knnSearch(query[i].data(), 1, &index, &dist_sq);
    if (dist_sq <= radius * radius) ++close;
    if (i % 401 == 0) {
      float best = std::numeric_limits<float>::max();
      for (const auto& t : target) best = std::min(best, (t - query[i]).squaredNorm());
      EXPECT_FLOAT_EQ(dist_sq, best) << "kd-tree disagrees with brute force at query " << i;
    }
  }
  return static_cast<double>(close) / static_cast<double>(query.size());
}

TEST(StanfordConf, ReadsBunnyAlignment) {
  const StanfordConf conf = read_stanford_conf(bunny_data() / "bun.conf");
  ASSERT_EQ(conf.scans.size(), 10u);
  ASSERT_TRUE(conf.camera.has_value());
  EXPECT_NEAR(conf.camera->translation().z(), -0.734, 1e-12);
  EXPECT_EQ(conf.scans[0].name, "bun000.ply");
  EXPECT_TRUE(conf.scans[0].T_world_scan.isApprox(Isometry3d::Identity(), 1e-15));
  EXPECT_EQ(conf.scans[9].name, "ear_back.ply");
  for (const auto& scan : conf.scans) {
    EXPECT_EQ(scan.file, bunny_data() / scan.name);
    EXPECT_TRUE(fs::exists(scan.file)) << scan.file;
    EXPECT_TRUE(scan.T_world_scan.linear().isUnitary(1e-9));
  }
  // bun045: t as written, rotation = R(q)^T with q = (x, y, z, w) as written.
  const RangeScan& b45 = conf.scans[1];
  EXPECT_EQ(b45.name, "bun045.ply");
  EXPECT_TRUE(b45.T_world_scan.translation().isApprox(
      Eigen::Vector3d(-0.0520211, -0.000383981, -0.0109223), 1e-15));
  const Eigen::Matrix3d R =
      Eigen::Quaterniond(0.955586, 0.00548449, -0.294635, -0.0038555).normalized().toRotationMatrix();
  EXPECT_TRUE(b45.T_world_scan.linear().isApprox(R.transpose(), 1e-12));
  // A turntable scan at 45 degrees: the rotation is ~34 degrees about y (as registered).
  EXPECT_NEAR(rotation_difference_deg(Isometry3d::Identity(), b45.T_world_scan), 34.3, 0.5);
}

TEST(StanfordConf, TransposedQuaternionAlignsScans) {
  const StanfordConf conf = read_stanford_conf(bunny_data() / "bun.conf");
  const RangeScan& s000 = conf.scans[0];
  const RangeScan& s045 = conf.scans[1];
  const auto world000 = transformed(read_ply(s000.file).positions, s000.T_world_scan);
  const auto raw045 = read_ply(s045.file).positions;
  ASSERT_EQ(raw045.size(), 40097u);

  const double aligned = overlap_fraction(world000, transformed(raw045, s045.T_world_scan), 0.0005f);
  EXPECT_GT(aligned, 0.75) << "SOURCE.md measured 83 %";
  EXPECT_LT(aligned, 0.90);

  // The other reading of the quaternion, R(q) instead of R(q)^T, must not align the scans.
  Isometry3d wrong = s045.T_world_scan;
  wrong.linear() = wrong.linear().transpose().eval();
  const double misaligned = overlap_fraction(world000, transformed(raw045, wrong), 0.0005f);
  EXPECT_LT(misaligned, 0.05);
}

TEST(StanfordConf, BadLinesNameFileAndLine) {
  const fs::path dir = scratch_dir();
  const fs::path f = dir / "scan.conf";
  const std::string good = "camera 0 0 0 0 0 0 1\nbmesh a.ply 1 2 3 0 0 0 1\n";
  struct Case {
    std::string text;
    std::string expect;
  };
  const std::vector<Case> cases = {
      {good + "mesh_offset b.ply 0 0 0 0 0 0 1\n", ":3: unknown keyword 'mesh_offset'"},
      {good + "bmesh b.ply 0 0 0 0 0 1\n", ":3: expected 7 numbers (tx ty tz qx qy qz qw), found 6"},
      {"\nbmesh b.ply 0 0 0 0 0 0 1 9\n", ":2: expected 7 numbers"},
      {good + "bmesh b.ply 0 0 x 0 0 0 1\n", ":3: 'x' is not a number"},
      {good + "bmesh b.ply 0 0 0 0 0 0 0\n", ":3: quaternion has zero length"},
      {"bmesh\n", ":1: 'bmesh' needs a file name"},
      {good + "camera 0 0 0 0 0 0 1\n", ":3: second 'camera' line"},
  };
  for (const auto& c : cases) {
    std::ofstream(f) << c.text;
    try {
      read_stanford_conf(f);
      ADD_FAILURE() << "no error for: " << c.text;
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(f.string() + c.expect, 0), 0u) << e.what();
    }
  }
  std::ofstream(f) << "# comment\n\n" << good;
  const StanfordConf conf = read_stanford_conf(f);
  ASSERT_EQ(conf.scans.size(), 1u);
  EXPECT_EQ(conf.scans[0].file, dir / "a.ply");
  EXPECT_EQ(conf.scans[0].T_world_scan.translation(), Eigen::Vector3d(1, 2, 3));
  EXPECT_THROW(read_stanford_conf(dir / "none.conf"), InputError);
}

}  // namespace
}  // namespace locard
