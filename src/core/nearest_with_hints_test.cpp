// NearestWithHints against a brute-force oracle: queries that drift a little between rounds (the
// previous answer short-cuts most of them), jump now and then (the hint is then far off), leave
// the search radius and come back, over a cloud with duplicate points (R_j = 0: no short cut).

#include <locard/core/nearest_with_hints.hpp>

#include <gtest/gtest.h>

#include <random>

namespace locard {
namespace {

// The nearest point within max_distance by (squared distance, index), or none.
bool brute_nearest(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3f& q,
                   float max_distance, std::uint32_t& index) {
  bool found = false;
  float best = 0.f;
  for (std::uint32_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f d = q - points[i];
    const float d2 = d.x() * d.x() + d.y() * d.y() + d.z() * d.z();
    if (d2 > max_distance * max_distance) continue;
    if (!found || d2 < best) {
      found = true;
      best = d2;
      index = i;
    }
  }
  return found;
}

TEST(NearestWithHints, AnswersAsTheTreeWhileQueriesDriftJumpAndLeave) {
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0.f, 0.001f);
  std::vector<Eigen::Vector3f> points;
  for (int u = 0; u < 60; ++u)
    for (int v = 0; v < 60; ++v) points.emplace_back(0.005f * u, 0.005f * v, noise(rng));
  for (int i = 0; i < 50; ++i) points.push_back(points[static_cast<std::size_t>(i * 37)]);  // duplicates
  const KdTree tree(points);
  const NearestWithHints hinted(tree);
  const float max_distance = 0.01f;

  std::uniform_real_distribution<float> anywhere(-0.02f, 0.32f);
  std::vector<Eigen::Vector3f> queries(400);
  for (auto& q : queries) q = Eigen::Vector3f(anywhere(rng), anywhere(rng), 0.004f);
  std::vector<std::uint32_t> hints(queries.size(), NearestWithHints::kNoHint);
  std::vector<Neighbor> scratch;
  std::size_t kept = 0, answered = 0;
  for (int round = 0; round < 30; ++round) {
    for (std::size_t i = 0; i < queries.size(); ++i) {
      Eigen::Vector3f& q = queries[i];
      if (round % 10 == 9 && i % 3 == 0)
        q = Eigen::Vector3f(anywhere(rng), anywhere(rng), 0.004f);  // a jump
      else
        q += Eigen::Vector3f(noise(rng), noise(rng), 0.f) * 0.2f;  // a drift of 0.2 mm
      const std::uint32_t before = hints[i];
      Neighbor got;
      const bool found = hinted.nearest(q, max_distance, hints[i], got, scratch);
      std::uint32_t expected = 0;
      ASSERT_EQ(found, brute_nearest(points, q, max_distance, expected)) << "round " << round << " query " << i;
      if (!found) {
        EXPECT_EQ(hints[i], NearestWithHints::kNoHint);
        continue;
      }
      ++answered;
      kept += got.index == before;
      EXPECT_EQ(got.index, expected) << "round " << round << " query " << i;
      EXPECT_EQ(hints[i], got.index);
      EXPECT_NEAR(got.squared_distance, (q - points[expected]).squaredNorm(), 1e-9f);
    }
  }
  // The drift keeps most answers: the short cut was taken or tried, not just the plain search.
  EXPECT_GT(kept, answered / 2);
}

TEST(NearestWithHints, AnEmptyTreeFindsNothing) {
  const KdTree tree;
  const NearestWithHints hinted(tree);
  std::uint32_t hint = NearestWithHints::kNoHint;
  Neighbor out;
  std::vector<Neighbor> scratch;
  EXPECT_FALSE(hinted.nearest(Eigen::Vector3f::Zero(), 1.f, hint, out, scratch));
  EXPECT_EQ(hint, NearestWithHints::kNoHint);
}

}  // namespace
}  // namespace locard
