#pragma once
// Union-find over the indices 0..n-1 (connected pieces of a pose graph, of a mesh, of a set of
// scans): path halving, and the larger root joins the smaller, so every set's root is its
// lowest index whatever order the unions come in.

#include <algorithm>
#include <cstddef>
#include <numeric>
#include <vector>

namespace locard {

class DisjointSets {
 public:
  explicit DisjointSets(std::size_t n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), 0); }

  std::size_t size() const { return parent_.size(); }

  // The root (lowest index) of x's set.
  std::size_t find(std::size_t x) {
    while (parent_[x] != x) x = parent_[x] = parent_[parent_[x]];
    return x;
  }

  void unite(std::size_t a, std::size_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent_[std::max(a, b)] = std::min(a, b);
  }

 private:
  std::vector<std::size_t> parent_;
};

}  // namespace locard
