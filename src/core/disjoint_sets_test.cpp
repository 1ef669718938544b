// Union-find against a brute-force oracle: connected components by breadth-first search over
// the same random edges, and the documented root (each set's lowest index) whatever the order
// of the unions.
#include <locard/core/disjoint_sets.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <queue>
#include <random>
#include <utility>
#include <vector>

namespace locard {
namespace {

// Component label of every node: the lowest index reachable from it.
std::vector<std::size_t> components_by_search(std::size_t n,
                                              const std::vector<std::pair<std::size_t, std::size_t>>& edges) {
  std::vector<std::vector<std::size_t>> adjacent(n);
  for (const auto& [a, b] : edges) {
    adjacent[a].push_back(b);
    adjacent[b].push_back(a);
  }
  std::vector<std::size_t> label(n, n);
  for (std::size_t start = 0; start < n; ++start) {
    if (label[start] != n) continue;
    std::queue<std::size_t> queue;
    queue.push(start);
    label[start] = start;  // visited in increasing order: the first node is the lowest
    while (!queue.empty()) {
      const std::size_t x = queue.front();
      queue.pop();
      for (std::size_t y : adjacent[x])
        if (label[y] == n) {
          label[y] = start;
          queue.push(y);
        }
    }
  }
  return label;
}

TEST(DisjointSets, AgreesWithBreadthFirstSearchAndRootsAtTheLowestIndex) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 50; ++trial) {
    const std::size_t n = 1 + rng() % 300;
    std::vector<std::pair<std::size_t, std::size_t>> edges;
    const std::size_t m = rng() % (n + n / 2 + 1);
    for (std::size_t e = 0; e < m; ++e) edges.emplace_back(rng() % n, rng() % n);
    const std::vector<std::size_t> expected = components_by_search(n, edges);
    for (int order = 0; order < 2; ++order) {  // as drawn, then shuffled
      if (order == 1) std::shuffle(edges.begin(), edges.end(), rng);
      DisjointSets sets(n);
      ASSERT_EQ(sets.size(), n);
      for (const auto& [a, b] : edges) sets.unite(a, b);
      for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(sets.find(i), expected[i]) << "node " << i;
    }
  }
}

TEST(DisjointSets, UnitingTwiceOrWithItselfChangesNothing) {
  DisjointSets sets(4);
  sets.unite(2, 2);
  EXPECT_EQ(sets.find(2), 2u);
  sets.unite(3, 1);
  sets.unite(1, 3);
  EXPECT_EQ(sets.find(3), 1u);
  EXPECT_EQ(sets.find(0), 0u);
}

}  // namespace
}  // namespace locard
