// Radius and statistical outlier removal against brute-force O(n^2) oracles.

#include <locard/core/error.hpp>
#include <locard/preprocess/outlier_removal.hpp>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace locard {
namespace {

// A noisy plane patch plus a sparse cloud of outliers around it.
PointCloud plane_with_outliers(std::size_t plane_points, std::size_t outliers, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::normal_distribution<float> noise(0.f, 0.002f);
  std::uniform_real_distribution<float> far(-3.f, 3.f);
  PointCloud cloud;
  for (std::size_t i = 0; i < plane_points; ++i) cloud.positions.emplace_back(u(rng), u(rng), noise(rng));
  for (std::size_t i = 0; i < outliers; ++i) cloud.positions.emplace_back(far(rng), far(rng), far(rng));
  std::shuffle(cloud.positions.begin(), cloud.positions.end(), rng);
  return cloud;
}

std::vector<std::uint32_t> brute_radius_inliers(const PointCloud& cloud, float radius, int min_nb) {
  std::vector<std::uint32_t> kept;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!cloud.positions[i].allFinite()) continue;
    int others = 0;
    for (std::size_t j = 0; j < cloud.size(); ++j) {
      if (j != i && cloud.positions[j].allFinite() &&
          (cloud.positions[i] - cloud.positions[j]).squaredNorm() <= radius * radius) {
        ++others;
      }
    }
    if (others >= min_nb) kept.push_back(static_cast<std::uint32_t>(i));
  }
  return kept;
}

std::vector<std::uint32_t> brute_statistical_inliers(const PointCloud& cloud, int k, double ratio) {
  std::vector<std::uint32_t> finite;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.positions[i].allFinite()) finite.push_back(static_cast<std::uint32_t>(i));
  }
  std::vector<double> mean(finite.size());
  for (std::size_t a = 0; a < finite.size(); ++a) {
    std::vector<double> d;
    for (std::size_t b = 0; b < finite.size(); ++b) {
      if (a != b) d.push_back((cloud.positions[finite[a]] - cloud.positions[finite[b]]).norm());
    }
    std::partial_sort(d.begin(), d.begin() + k, d.end());
    double sum = 0.0;
    for (int j = 0; j < k; ++j) sum += d[j];
    mean[a] = sum / k;
  }
  double mu = 0.0;
  for (double m : mean) mu += m;
  mu /= mean.size();
  double var = 0.0;
  for (double m : mean) var += (m - mu) * (m - mu);
  const double threshold = mu + ratio * std::sqrt(var / (mean.size() - 1));
  std::vector<std::uint32_t> kept;
  for (std::size_t a = 0; a < finite.size(); ++a) {
    if (mean[a] <= threshold) kept.push_back(finite[a]);
  }
  return kept;
}

TEST(RadiusOutlierRemoval, EqualsBruteForceAndRemovesIsolatedPoints) {
  PointCloud cloud = plane_with_outliers(3000, 60, 1);
  cloud.positions[11].x() = std::numeric_limits<float>::quiet_NaN();
  const RadiusOutlierOptions options{0.05f, 4};
  const FilterResult r = remove_radius_outliers(cloud, options);
  // The oracle uses exact squared-norm arithmetic; nothing in this random cloud sits within
  // an ulp of the radius, so the sets agree exactly.
  EXPECT_EQ(r.indices, brute_radius_inliers(cloud, 0.05f, 4));
  EXPECT_EQ(r.report.non_finite, 1u);
  EXPECT_GE(r.report.rejected, 55u);  // (nearly) every far outlier
  EXPECT_LE(r.report.rejected, 80u);
  EXPECT_EQ(r.cloud.size() + r.report.rejected + r.report.non_finite, cloud.size());
}

TEST(RadiusOutlierRemoval, DuplicatesCountAsNeighbours) {
  PointCloud cloud;
  cloud.positions.assign(3, Eigen::Vector3f(1.f, 1.f, 1.f));
  cloud.positions.emplace_back(5.f, 5.f, 5.f);
  EXPECT_EQ(remove_radius_outliers(cloud, {0.01f, 2}).indices, (std::vector<std::uint32_t>{0, 1, 2}));
  EXPECT_TRUE(remove_radius_outliers(cloud, {0.01f, 3}).indices.empty());
  EXPECT_EQ(remove_radius_outliers(cloud, {0.01f, 0}).indices.size(), 4u);
}

TEST(StatisticalOutlierRemoval, EqualsBruteForce) {
  PointCloud cloud = plane_with_outliers(1500, 40, 2);
  cloud.positions[3].z() = std::numeric_limits<float>::infinity();
  for (int k : {1, 8, 20}) {
    for (double ratio : {0.5, 2.0}) {
      const FilterResult r = remove_statistical_outliers(cloud, {k, ratio});
      SCOPED_TRACE(::testing::Message() << "k " << k << " ratio " << ratio);
      EXPECT_EQ(r.indices, brute_statistical_inliers(cloud, k, ratio));
      EXPECT_EQ(r.report.non_finite, 1u);
    }
  }
  const FilterResult r = remove_statistical_outliers(cloud, {20, 2.0});
  EXPECT_GE(r.report.rejected, 35u);
  tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
  EXPECT_EQ(remove_statistical_outliers(cloud, {20, 2.0}).indices, r.indices);
}

TEST(StatisticalOutlierRemoval, TinyCloudsAreKept) {
  PointCloud cloud;
  cloud.positions = {Eigen::Vector3f::Zero(), Eigen::Vector3f::Ones(), Eigen::Vector3f(9, 9, 9)};
  const FilterResult r = remove_statistical_outliers(cloud, {3, 1.0});
  EXPECT_EQ(r.cloud.size(), 3u);
  EXPECT_EQ(r.report.rejected, 0u);
  EXPECT_TRUE(remove_statistical_outliers(PointCloud{}, {3, 1.0}).cloud.empty());
}

TEST(OutlierRemoval, RejectsBadParameters) {
  const PointCloud cloud = plane_with_outliers(10, 0, 3);
  EXPECT_THROW(remove_radius_outliers(cloud, {0.f, 3}), InputError);
  EXPECT_THROW(remove_radius_outliers(cloud, {0.1f, -1}), InputError);
  EXPECT_THROW(remove_statistical_outliers(cloud, {0, 1.0}), InputError);
  EXPECT_THROW(remove_statistical_outliers(cloud, {5, -1.0}), InputError);
}

}  // namespace
}  // namespace locard
