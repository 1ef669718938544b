#pragma once
// Nearest-neighbour queries that move a little between calls - ICP's iterations, a joint
// refinement's Gauss-Newton steps - answered from each query's previous answer where that is
// provably the same (the point is exactly KdTree::nearest's; its squared distance may differ
// in the last bit where the short cut computed it):
//  - the previous answer j, at distance d from the query now, is still the nearest when
//    d < R_j / 2, R_j being j's distance to its nearest other point (any other point k lies
//    at least R_j - d > d away): no search;
//  - otherwise the nearest lies within d, so a search bounded by min(d, max_distance) finds
//    the same point as one bounded by max_distance, and prunes most of the tree.
// Margins (1e-3 relative on the first test, 1e-5 on the bound) absorb float rounding.

#include <locard/core/kdtree.hpp>

#include <atomic>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

namespace locard {

class NearestWithHints {
 public:
  // A query without a previous answer (or whose last search found nothing).
  static constexpr std::uint32_t kNoHint = std::numeric_limits<std::uint32_t>::max();

  // `tree` must outlive this object. Each point's R_j is computed on first use (a 2-NN query).
  explicit NearestWithHints(const KdTree& tree);

  // The nearest point within max_distance (metres, not squared), as KdTree::nearest; `hint` is
  // the query's previous answer and becomes this one (kNoHint when none is found). `scratch`
  // is the caller's, one per thread. Safe to call concurrently for different hints.
  bool nearest(const Eigen::Vector3f& query, float max_distance, std::uint32_t& hint,
               Neighbor& out, std::vector<Neighbor>& scratch) const;

 private:
  float half_spacing_sq(std::uint32_t j, std::vector<Neighbor>& scratch) const;

  const KdTree* tree_;
  // (R_j / 2)^2 per point, negative until known. Threads may race to fill the same entry;
  // they write the same value.
  std::unique_ptr<std::atomic<float>[]> half_spacing_sq_;
};

}  // namespace locard
