// Kd-tree queries against a brute-force oracle (nanoflann's own test approach): random,
// empty, single-point and duplicate-point clouds; batch queries equal single ones for any
// thread count.

#include <locard/core/kdtree.hpp>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <random>

namespace locard {
namespace {

// Same arithmetic as nanoflann's L2_Simple_Adaptor: ((dx^2) + dy^2) + dz^2 in float.
float squared_distance(const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
  const float dx = a.x() - b.x(), dy = a.y() - b.y(), dz = a.z() - b.z();
  return dx * dx + dy * dy + dz * dz;
}

// Every point ranked by (squared distance, index).
std::vector<Neighbor> brute_force_all(const std::vector<Eigen::Vector3f>& points,
                                      const Eigen::Vector3f& query) {
  std::vector<Neighbor> all;
  for (std::size_t i = 0; i < points.size(); ++i) {
    all.push_back(Neighbor{static_cast<std::uint32_t>(i), squared_distance(query, points[i])});
  }
  std::sort(all.begin(), all.end(), [](const Neighbor& a, const Neighbor& b) {
    return a.squared_distance < b.squared_distance ||
           (a.squared_distance == b.squared_distance && a.index < b.index);
  });
  return all;
}

std::vector<Neighbor> brute_knn(const std::vector<Eigen::Vector3f>& points,
                                const Eigen::Vector3f& query, std::size_t k) {
  auto all = brute_force_all(points, query);
  all.resize(std::min(k, all.size()));
  return all;
}

// radius in metres; the oracle compares squared distances with radius * radius, inclusive.
std::vector<Neighbor> brute_radius(const std::vector<Eigen::Vector3f>& points,
                                   const Eigen::Vector3f& query, float radius, std::size_t max_k) {
  auto all = brute_force_all(points, query);
  std::vector<Neighbor> within;
  for (const Neighbor& nb : all) {
    if (nb.squared_distance <= radius * radius && within.size() < max_k) within.push_back(nb);
  }
  return within;
}

std::vector<Eigen::Vector3f> random_points(std::size_t n, std::uint32_t seed, float extent = 1.f) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-extent, extent);
  std::vector<Eigen::Vector3f> points(n);
  for (auto& p : points) p = Eigen::Vector3f(u(rng), u(rng), u(rng));
  return points;
}

void expect_all_queries_match(const std::vector<Eigen::Vector3f>& points,
                              const std::vector<Eigen::Vector3f>& queries) {
  const KdTree tree(points, 4);
  ASSERT_EQ(tree.size(), points.size());
  std::vector<Neighbor> found;
  for (const Eigen::Vector3f& q : queries) {
    for (int k : {1, 2, 7, 30}) {
      tree.knn(q, k, found);
      EXPECT_EQ(found, brute_knn(points, q, static_cast<std::size_t>(k))) << "k = " << k;
    }
    for (float r : {0.f, 0.05f, 0.2f, 0.6f}) {
      tree.radius(q, r, found);
      EXPECT_EQ(found, brute_radius(points, q, r, points.size())) << "r = " << r;
      for (int max_k : {1, 5, 40}) {
        tree.hybrid(q, r, max_k, found);
        EXPECT_EQ(found, brute_radius(points, q, r, static_cast<std::size_t>(max_k)))
            << "r = " << r << ", max_k = " << max_k;
      }
    }
    Neighbor nearest;
    const auto expected = brute_knn(points, q, 1);
    ASSERT_EQ(tree.nearest(q, nearest), !expected.empty());
    if (!expected.empty()) {
      EXPECT_EQ(nearest, expected[0]);
      const float just_below = std::sqrt(expected[0].squared_distance) * 0.999f;
      if (expected[0].squared_distance > 0.f) {
        EXPECT_FALSE(tree.nearest(q, nearest, just_below));
      }
    }
  }
}

TEST(KdTree, RandomCloudEqualsBruteForce) {
  const auto points = random_points(2000, 1);
  auto queries = random_points(60, 2, 1.3f);  // some outside the cloud's box
  queries.insert(queries.end(), points.begin(), points.begin() + 20);  // queries on points
  expect_all_queries_match(points, queries);
}

TEST(KdTree, EmptyCloudReturnsNothing) {
  const KdTree tree(std::vector<Eigen::Vector3f>{});
  EXPECT_TRUE(tree.empty());
  std::vector<Neighbor> found{Neighbor{3, 1.f}};
  const Eigen::Vector3f q(0.f, 0.f, 0.f);
  EXPECT_EQ(tree.knn(q, 5, found), 0u);
  EXPECT_TRUE(found.empty());
  EXPECT_EQ(tree.radius(q, 10.f, found), 0u);
  EXPECT_EQ(tree.hybrid(q, 10.f, 3, found), 0u);
  Neighbor nearest;
  EXPECT_FALSE(tree.nearest(q, nearest));
  const std::vector<Eigen::Vector3f> queries(3, q);
  const NeighborLists lists = tree.knn_batch(queries, 4);
  ASSERT_EQ(lists.query_count(), 3u);
  EXPECT_TRUE(lists.neighbors.empty());
  const auto nearest_all = tree.nearest_batch(queries);
  ASSERT_EQ(nearest_all.size(), 3u);
  EXPECT_EQ(nearest_all[0].index, std::numeric_limits<std::uint32_t>::max());
  EXPECT_EQ(KdTree().size(), 0u);
}

TEST(KdTree, SinglePoint) {
  const std::vector<Eigen::Vector3f> points{Eigen::Vector3f(1.f, 2.f, 3.f)};
  expect_all_queries_match(points, random_points(20, 3, 4.f));
  const KdTree tree(points);
  std::vector<Neighbor> found;
  EXPECT_EQ(tree.knn(points[0], 10, found), 1u);
  EXPECT_EQ(found[0], (Neighbor{0, 0.f}));
}

TEST(KdTree, DuplicatePointsTieToSmallerIndex) {
  // 40 copies of one point interleaved with random points, plus a second duplicated spot.
  auto points = random_points(300, 4);
  const Eigen::Vector3f spot(0.1f, 0.2f, 0.3f), other_spot(-0.5f, 0.5f, 0.f);
  for (int i = 0; i < 40; ++i) points.insert(points.begin() + 7 * i, spot);
  for (int i = 0; i < 5; ++i) points.push_back(other_spot);
  expect_all_queries_match(points, {spot, other_spot, Eigen::Vector3f(0.1f, 0.2f, 0.31f)});

  const KdTree tree(points, 2);
  std::vector<Neighbor> found;
  tree.knn(spot, 10, found);
  for (int i = 0; i < 10; ++i) {
    EXPECT_EQ(found[i].index, static_cast<std::uint32_t>(7 * i));  // the 10 smallest indices
    EXPECT_EQ(found[i].squared_distance, 0.f);
  }
  tree.radius(spot, 0.f, found);  // radius 0 is inclusive: exactly the copies
  EXPECT_EQ(found.size(), 40u);
}

TEST(KdTree, AllPointsIdentical) {
  const std::vector<Eigen::Vector3f> points(100, Eigen::Vector3f(2.f, 2.f, 2.f));
  expect_all_queries_match(points, {Eigen::Vector3f(2.f, 2.f, 2.f), Eigen::Vector3f::Zero()});
}

TEST(KdTree, RadiusBoundaryIsInclusive) {
  // Distances exactly representable: 0.5 along each axis.
  const std::vector<Eigen::Vector3f> points{Eigen::Vector3f(0.5f, 0.f, 0.f),
                                            Eigen::Vector3f(0.f, -0.5f, 0.f),
                                            Eigen::Vector3f(0.f, 0.f, 0.75f)};
  const KdTree tree(points);
  std::vector<Neighbor> found;
  tree.radius(Eigen::Vector3f::Zero(), 0.5f, found);  // 0.5 m, not squared
  ASSERT_EQ(found.size(), 2u);
  EXPECT_EQ(found[0], (Neighbor{0, 0.25f}));  // squared distance
  EXPECT_EQ(found[1], (Neighbor{1, 0.25f}));
  tree.radius(Eigen::Vector3f::Zero(), 0.4999f, found);
  EXPECT_TRUE(found.empty());
}

TEST(KdTree, BatchQueriesEqualSingleQueriesForAnyThreadCount) {
  const auto points = random_points(5000, 5);
  const auto queries = random_points(1500, 6, 1.1f);
  const KdTree tree(points);
  const NeighborLists knn = tree.knn_batch(queries, 8);
  const NeighborLists radius = tree.radius_batch(queries, 0.1f);
  const NeighborLists hybrid = tree.hybrid_batch(queries, 0.1f, 5);
  const std::vector<Neighbor> nearest = tree.nearest_batch(queries, 0.05f);
  ASSERT_EQ(knn.query_count(), queries.size());
  std::vector<Neighbor> found;
  for (std::size_t q = 0; q < queries.size(); ++q) {
    tree.knn(queries[q], 8, found);
    ASSERT_TRUE(std::equal(found.begin(), found.end(), knn[q].begin(), knn[q].end()));
    tree.radius(queries[q], 0.1f, found);
    ASSERT_TRUE(std::equal(found.begin(), found.end(), radius[q].begin(), radius[q].end()));
    tree.hybrid(queries[q], 0.1f, 5, found);
    ASSERT_TRUE(std::equal(found.begin(), found.end(), hybrid[q].begin(), hybrid[q].end()));
    Neighbor one;
    if (tree.nearest(queries[q], one, 0.05f)) {
      EXPECT_EQ(nearest[q], one);
    } else {
      EXPECT_EQ(nearest[q].index, std::numeric_limits<std::uint32_t>::max());
    }
  }
  // One thread gives the same bits.
  tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
  EXPECT_EQ(tree.radius_batch(queries, 0.1f).neighbors, radius.neighbors);
  EXPECT_EQ(tree.radius_batch(queries, 0.1f).offsets, radius.offsets);
  EXPECT_EQ(tree.knn_batch(queries, 8).neighbors, knn.neighbors);
}

TEST(KdTree, MovedTreeKeepsItsPoints) {
  auto points = random_points(100, 7);
  KdTree a(points);
  KdTree b(std::move(a));
  EXPECT_EQ(b.size(), 100u);
  std::vector<Neighbor> found;
  b.knn(points[3], 1, found);
  EXPECT_EQ(found[0].index, 3u);
  EXPECT_EQ(a.size(), 0u);  // NOLINT(bugprone-use-after-move): moved-from is empty, not broken
  EXPECT_EQ(a.knn(points[3], 1, found), 0u);
}

}  // namespace
}  // namespace locard
