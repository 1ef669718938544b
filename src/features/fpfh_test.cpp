// FPFH: agreement with Open3D's compute_fpfh_feature on a real scan (same cloud, normals,
// radius), invariance to rigid motion, subsets equal to the full computation.

#include <locard/core/error.hpp>
#include <locard/core/pose.hpp>
#include <locard/features/fpfh.hpp>
#include <locard/io/ply.hpp>
#include <locard/preprocess/normals.hpp>
#include <locard/preprocess/voxel_grid.hpp>

#include "features/fast_atan2.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cstdio>
#include <fstream>
#include <numeric>

namespace locard {
namespace {

constexpr float kVoxel = 0.003f;             // bunny scans are in metres, ~0.15 m across
constexpr float kFpfhRadius = 5 * kVoxel;

// bun000 down-sampled with normals towards the scanner (origin of the scan frame).
PointCloud bunny_with_normals() {
  const PointCloud scan = read_ply(test::shared_data() / "stanford-bunny/bunny/data/bun000.ply");
  PointCloud cloud = voxel_down_sample(scan, kVoxel).cloud;
  NormalOptions options;
  options.radius = 2 * kVoxel;
  options.max_neighbors = 30;
  estimate_normals(cloud, options);
  return cloud;
}

double correlation(const float* a, const float* b, std::size_t n) {
  double ma = 0, mb = 0;
  for (std::size_t i = 0; i < n; ++i) ma += a[i], mb += b[i];
  ma /= n;
  mb /= n;
  double sab = 0, saa = 0, sbb = 0;
  for (std::size_t i = 0; i < n; ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  return sab / std::sqrt(saa * sbb);
}

// Runs bench/peers/open3d_features.py on the cloud; empty when Open3D cannot be run.
std::vector<Fpfh> open3d_fpfh(const PointCloud& cloud, float radius, int max_nn) {
  const auto dir = test::scratch_dir();
  const auto xyzn = dir / "cloud.xyzn";
  const auto out = dir / "fpfh.f32";
  {
    std::ofstream file(xyzn);
    file.precision(9);  // float round trip
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const auto& p = cloud.positions[i];
      const auto& n = cloud.normals[i];
      file << p.x() << ' ' << p.y() << ' ' << p.z() << ' ' << n.x() << ' ' << n.y() << ' '
           << n.z() << '\n';
    }
  }
  const std::string command = std::string("/usr/bin/python3 '") + LOCARD_SOURCE_DIR +
                              "/bench/peers/open3d_features.py' fpfh '" + xyzn.string() + "' " +
                              std::to_string(radius) + " " + std::to_string(max_nn) + " '" +
                              out.string() + "' > /dev/null 2>&1";
  if (std::system(command.c_str()) != 0) return {};
  std::vector<Fpfh> descriptors(cloud.size());
  std::ifstream in(out, std::ios::binary);
  in.read(reinterpret_cast<char*>(descriptors.data()),
          static_cast<std::streamsize>(descriptors.size() * sizeof(Fpfh)));
  if (!in) return {};
  return descriptors;
}

TEST(Fpfh, AgreesWithOpen3d) {
  const PointCloud cloud = bunny_with_normals();
  ASSERT_GT(cloud.size(), 2000u);
  const std::vector<Fpfh> ours = compute_fpfh(cloud, FpfhOptions{kFpfhRadius, 100});
  const std::vector<Fpfh> theirs = open3d_fpfh(cloud, kFpfhRadius, 100);
  if (theirs.empty()) GTEST_SKIP() << "Open3D (/usr/bin/python3 -c 'import open3d') unavailable";
  ASSERT_EQ(ours.size(), theirs.size());
  // Overall correlation of every value, and per descriptor.
  const double overall =
      correlation(ours[0].data(), theirs[0].data(), ours.size() * static_cast<std::size_t>(33));
  EXPECT_GT(overall, 0.9999);
  std::vector<double> per_point(ours.size());
  for (std::size_t i = 0; i < ours.size(); ++i) {
    per_point[i] = correlation(ours[i].data(), theirs[i].data(), 33);
  }
  const double mean = std::accumulate(per_point.begin(), per_point.end(), 0.0) / per_point.size();
  EXPECT_GT(mean, 0.999);
  const auto good = std::count_if(per_point.begin(), per_point.end(), [](double c) { return c > 0.99; });
  EXPECT_GT(static_cast<double>(good) / per_point.size(), 0.99);
  RecordProperty("overall_correlation", std::to_string(overall));
  RecordProperty("mean_per_point_correlation", std::to_string(mean));
  std::printf("correlation with Open3D: overall %.6f, mean per point %.6f, %.2f%% of points > 0.99\n",
              overall, mean, 100.0 * good / per_point.size());
}

TEST(Fpfh, InvariantToRigidMotion) {
  const PointCloud cloud = bunny_with_normals();
  PointCloud moved = cloud;
  Isometry3d T_moved_cloud = Isometry3d::Identity();
  T_moved_cloud.translate(Eigen::Vector3d(0.3, -1.2, 2.0));
  T_moved_cloud.rotate(Eigen::AngleAxisd(2.5, Eigen::Vector3d(0.2, 1.0, -0.4).normalized()));
  const Eigen::Matrix3f R = T_moved_cloud.linear().cast<float>();
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    moved.positions[i] = (T_moved_cloud * cloud.positions[i].cast<double>()).cast<float>();
    moved.normals[i] = R * cloud.normals[i];
  }
  const auto a = compute_fpfh(cloud, FpfhOptions{kFpfhRadius, 100});
  const auto b = compute_fpfh(moved, FpfhOptions{kFpfhRadius, 100});
  EXPECT_GT(correlation(a[0].data(), b[0].data(), a.size() * std::size_t{33}), 0.999);
}

TEST(Fpfh, SubsetEqualsFullComputationAndBinsSumTo200) {
  const PointCloud cloud = bunny_with_normals();
  const auto all = compute_fpfh(cloud, FpfhOptions{kFpfhRadius, 100});
  std::vector<std::uint32_t> subset;
  for (std::uint32_t i = 5; i < cloud.size(); i += 37) subset.push_back(i);
  subset.push_back(subset.front());  // a repeated index is fine
  const auto some = compute_fpfh(cloud, subset, FpfhOptions{kFpfhRadius, 100});
  ASSERT_EQ(some.size(), subset.size());
  for (std::size_t k = 0; k < subset.size(); ++k) EXPECT_EQ(some[k], all[subset[k]]) << k;
  // Each 11-bin block: SPFH totals 100 and the normalised weighted sum totals 100.
  for (std::size_t i = 0; i < all.size(); i += 101) {
    if (all[i].isZero()) continue;
    for (int block = 0; block < 3; ++block) {
      EXPECT_NEAR(all[i].segment<11>(11 * block).sum(), 200.f, 1e-3f);
    }
  }
  tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
  EXPECT_EQ(compute_fpfh(cloud, FpfhOptions{kFpfhRadius, 100}), all);
}

TEST(Fpfh, FastAtan2MatchesStdAtan2) {
  double worst = 0.0;
  for (int i = 0; i < 200000; ++i) {
    const double a = -M_PI + 2 * M_PI * i / 200000.0;
    for (float r : {1e-3f, 1.f, 7.f}) {
      const float y = r * static_cast<float>(std::sin(a)), x = r * static_cast<float>(std::cos(a));
      worst = std::max(worst, std::abs(detail::fast_atan2(y, x) - std::atan2(double{y}, double{x})));
    }
  }
  EXPECT_LT(worst, 3e-7);
  for (float y : {0.f, -0.f, 1.f, -1.f}) {
    for (float x : {0.f, -0.f, 1.f, -1.f}) {
      EXPECT_NEAR(detail::fast_atan2(y, x), std::atan2(y, x), 1e-7f) << y << " " << x;
    }
  }
}

TEST(Fpfh, IsolatedPointsGetZerosAndBadInputIsRejected) {
  PointCloud cloud;
  cloud.positions = {Eigen::Vector3f::Zero(), Eigen::Vector3f(10, 0, 0)};
  cloud.normals = {Eigen::Vector3f::UnitZ(), Eigen::Vector3f::UnitZ()};
  const auto d = compute_fpfh(cloud, FpfhOptions{0.1f, 10});
  EXPECT_TRUE(d[0].isZero());
  EXPECT_TRUE(d[1].isZero());
  EXPECT_TRUE(compute_fpfh(PointCloud{}, FpfhOptions{}).empty());
  PointCloud no_normals;
  no_normals.positions = cloud.positions;
  EXPECT_THROW(compute_fpfh(no_normals, FpfhOptions{}), InputError);
  EXPECT_THROW(compute_fpfh(cloud, FpfhOptions{0.f, 10}), InputError);
  const std::vector<std::uint32_t> out_of_range{5};
  EXPECT_THROW(compute_fpfh(cloud, out_of_range, FpfhOptions{}), InputError);
}

}  // namespace
}  // namespace locard
