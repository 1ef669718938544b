// Descriptor matching against a brute-force oracle; mutual filter and ratio test; a real
// bunny scan pair matched under its ground-truth pose.

#include <locard/core/error.hpp>
#include <locard/features/descriptor_matching.hpp>
#include <locard/features/iss_keypoints.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/stanford_conf.hpp>
#include <locard/preprocess/normals.hpp>
#include <locard/preprocess/voxel_grid.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cstdio>
#include <numeric>
#include <random>

namespace locard {
namespace {

std::vector<Fpfh> random_descriptors(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.f, 100.f);
  std::vector<Fpfh> d(n);
  for (auto& f : d) {
    for (int i = 0; i < 33; ++i) f[i] = u(rng);
  }
  return d;
}

// Two best (squared distance, index) of `query` among `set`, ties to the smaller index.
std::vector<std::pair<float, std::uint32_t>> brute_two_best(const Fpfh& query,
                                                            const std::vector<Fpfh>& set) {
  std::vector<std::pair<float, std::uint32_t>> all;
  for (std::size_t j = 0; j < set.size(); ++j) {
    float d2 = 0.f;  // nanoflann's L2 accumulation order
    for (int k = 0; k < 33; ++k) {
      const float diff = query[k] - set[j][k];
      d2 += diff * diff;
    }
    all.emplace_back(d2, static_cast<std::uint32_t>(j));
  }
  std::partial_sort(all.begin(), all.begin() + std::min<std::size_t>(2, all.size()), all.end());
  all.resize(std::min<std::size_t>(2, all.size()));
  return all;
}

std::vector<Correspondence> brute_force_matches(const std::vector<Fpfh>& source,
                                                const std::vector<Fpfh>& target,
                                                const MatchOptions& options) {
  std::vector<Correspondence> out;
  for (std::size_t s = 0; s < source.size(); ++s) {
    const auto best = brute_two_best(source[s], target);
    if (options.ratio < 1.f && best.size() == 2 &&
        !(best[0].first < options.ratio * options.ratio * best[1].first)) {
      continue;
    }
    if (options.mutual && brute_two_best(target[best[0].second], source)[0].second != s) continue;
    out.push_back({static_cast<std::uint32_t>(s), best[0].second, std::sqrt(best[0].first)});
  }
  return out;
}

// Same pairs; distances equal up to float summation order (nanoflann's L2 sums in fours).
void expect_same_matches(const std::vector<Correspondence>& actual,
                         const std::vector<Correspondence>& expected) {
  ASSERT_EQ(actual.size(), expected.size());
  for (std::size_t i = 0; i < actual.size(); ++i) {
    ASSERT_EQ(actual[i].source, expected[i].source) << i;
    ASSERT_EQ(actual[i].target, expected[i].target) << i;
    ASSERT_NEAR(actual[i].distance, expected[i].distance, 1e-5f * expected[i].distance) << i;
  }
}

// Makes target[stride * i] a noisy copy (sigma 3) of source[i] for i < count.
void plant_noisy_copies(const std::vector<Fpfh>& source, std::vector<Fpfh>& target,
                        std::size_t count, std::size_t stride, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.f, 3.f);
  for (std::size_t i = 0; i < count; ++i) {
    target[stride * i] = source[i];
    for (int k = 0; k < 33; ++k) target[stride * i][k] += noise(rng);
  }
}

TEST(DescriptorMatching, EqualsBruteForce) {
  const auto source = random_descriptors(400, 1);
  auto target = random_descriptors(500, 2);
  plant_noisy_copies(source, target, 200, 2, 3);  // so that mutual pairs exist
  for (bool mutual : {false, true}) {
    for (float ratio : {1.f, 0.9f, 0.6f}) {
      const MatchOptions options{mutual, ratio};
      SCOPED_TRACE(::testing::Message() << "mutual " << mutual << " ratio " << ratio);
      expect_same_matches(match_descriptors(source, target, options),
                          brute_force_matches(source, target, options));
    }
  }
  const auto plain = match_descriptors(source, target, MatchOptions{false, 1.f});
  EXPECT_EQ(plain.size(), source.size());  // every source gets its nearest target
  const auto mutual = match_descriptors(source, target, MatchOptions{true, 1.f});
  std::size_t planted = 0;
  for (const auto& m : mutual) planted += m.target == 2 * m.source;
  EXPECT_GE(planted, 195u);
  tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
  EXPECT_EQ(match_descriptors(source, target, MatchOptions{true, 1.f}), mutual);
}

TEST(DescriptorMatching, LargeSetsTakeTheTreeAndStillEqualBruteForce) {
  // 4200 x 4100 pairs: above the brute-force threshold (2^24 pairs), so the kd-tree path runs.
  const auto source = random_descriptors(4200, 11);
  auto target = random_descriptors(4100, 12);
  plant_noisy_copies(source, target, 1000, 4, 13);
  const MatchOptions options{true, 0.9f};
  const auto matches = match_descriptors(source, target, options);
  expect_same_matches(matches, brute_force_matches(source, target, options));
  EXPECT_GT(matches.size(), 900u);
}

TEST(DescriptorMatching, TiesEmptyAndSingleTarget) {
  const auto source = random_descriptors(10, 4);
  std::vector<Fpfh> target(5, source[3]);  // five identical targets
  const auto matches = match_descriptors(source, target, MatchOptions{false, 1.f});
  ASSERT_EQ(matches.size(), 10u);
  for (const auto& m : matches) EXPECT_EQ(m.target, 0u);  // ties go to the smaller index
  const auto mutual = match_descriptors(source, target, MatchOptions{true, 1.f});
  ASSERT_EQ(mutual.size(), 1u);
  EXPECT_EQ(mutual[0], (Correspondence{3, 0, 0.f}));
  // The ratio test rejects a perfect but ambiguous match.
  EXPECT_TRUE(match_descriptors(source, target, MatchOptions{false, 0.9f}).empty());
  // A lone target has no second neighbour: the ratio test passes.
  EXPECT_EQ(match_descriptors(source, {source[7]}, MatchOptions{true, 0.8f}).size(), 1u);
  EXPECT_TRUE(match_descriptors({}, target).empty());
  EXPECT_TRUE(match_descriptors(source, {}).empty());
  EXPECT_THROW(match_descriptors(source, target, MatchOptions{true, 0.f}), InputError);
  auto bad = source;
  bad[2][5] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(match_descriptors(bad, target), InputError);
}

// bun000 vs bun045 (45 degrees apart) with the bun.conf ground truth. A correspondence is
// true when the ground truth maps its source point within 2 voxels of its target point.
class BunnyPair : public ::testing::Test {
 protected:
  static constexpr float kVoxel = 0.002f;

  void SetUp() override {
    const auto folder = test::shared_data() / "stanford-bunny/bunny/data";
    const StanfordConf conf = read_stanford_conf(folder / "bun.conf");
    const auto find = [&](const std::string& name) {
      return *std::find_if(conf.scans.begin(), conf.scans.end(),
                           [&](const RangeScan& s) { return s.name == name; });
    };
    const RangeScan a = find("bun000.ply"), b = find("bun045.ply");
    const auto prepare = [&](const RangeScan& scan) {
      PointCloud cloud = voxel_down_sample(read_ply(scan.file), kVoxel).cloud;
      estimate_normals(cloud, NormalOptions{2 * kVoxel, 30});
      return cloud;
    };
    source = prepare(a);
    target = prepare(b);
    T_target_source = b.T_world_scan.inverse() * a.T_world_scan;
  }

  std::size_t true_matches(const std::vector<Correspondence>& matches,
                           const std::vector<std::uint32_t>& source_points,
                           const std::vector<std::uint32_t>& target_points) const {
    std::size_t count = 0;
    for (const auto& m : matches) {
      const Eigen::Vector3d p =
          T_target_source * source.positions[source_points[m.source]].cast<double>();
      count += (p - target.positions[target_points[m.target]].cast<double>()).norm() < 2 * kVoxel;
    }
    return count;
  }

  PointCloud source, target;
  Isometry3d T_target_source;
};

TEST_F(BunnyPair, IssKeypointMatchesAreMostlyTrue) {
  IssOptions iss;
  iss.salient_radius = 6 * kVoxel;
  iss.non_max_radius = 4 * kVoxel;
  const auto source_keys = iss_keypoints(source, iss);
  const auto target_keys = iss_keypoints(target, iss);
  const FpfhOptions fpfh{5 * kVoxel, 100};
  const auto matches = match_descriptors(compute_fpfh(source, source_keys, fpfh),
                                         compute_fpfh(target, target_keys, fpfh));
  const std::size_t inliers = true_matches(matches, source_keys, target_keys);
  std::printf("bunny 000->045, ISS: %zu / %zu keypoints, %zu mutual matches, %zu true\n",
              source_keys.size(), target_keys.size(), matches.size(), inliers);
  EXPECT_GE(inliers, 4u);  // RANSAC needs 3
  EXPECT_GE(static_cast<double>(inliers) / matches.size(), 0.25);
}

TEST_F(BunnyPair, AllPointMatchesHaveARansacFriendlyInlierRate) {
  std::vector<std::uint32_t> all_source(source.size()), all_target(target.size());
  std::iota(all_source.begin(), all_source.end(), 0u);
  std::iota(all_target.begin(), all_target.end(), 0u);
  const FpfhOptions fpfh{5 * kVoxel, 100};
  const auto matches = match_descriptors(compute_fpfh(source, fpfh), compute_fpfh(target, fpfh));
  const std::size_t inliers = true_matches(matches, all_source, all_target);
  std::printf("bunny 000->045, all points: %zu / %zu points, %zu mutual matches, %zu true\n",
              source.size(), target.size(), matches.size(), inliers);
  EXPECT_GE(inliers, 500u);
  EXPECT_GE(static_cast<double>(inliers) / matches.size(), 0.3);
}

}  // namespace
}  // namespace locard
