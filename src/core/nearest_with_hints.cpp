#include <locard/core/nearest_with_hints.hpp>

#include <algorithm>
#include <cmath>

namespace locard {

NearestWithHints::NearestWithHints(const KdTree& tree)
    : tree_(&tree), half_spacing_sq_(new std::atomic<float>[tree.size()]) {
  for (std::size_t j = 0; j < tree.size(); ++j) half_spacing_sq_[j].store(-1.f, std::memory_order_relaxed);
}

float NearestWithHints::half_spacing_sq(std::uint32_t j, std::vector<Neighbor>& scratch) const {
  float v = half_spacing_sq_[j].load(std::memory_order_relaxed);
  if (v >= 0.f) return v;
  v = tree_->knn(tree_->points()[j], 2, scratch) == 2 ? 0.25f * scratch[1].squared_distance : 0.f;
  half_spacing_sq_[j].store(v, std::memory_order_relaxed);
  return v;
}

bool NearestWithHints::nearest(const Eigen::Vector3f& query, float max_distance,
                               std::uint32_t& hint, Neighbor& out,
                               std::vector<Neighbor>& scratch) const {
  float bound = max_distance;
  if (hint != kNoHint) {
    const float d2 = (query - tree_->points()[hint]).squaredNorm();
    if (d2 <= max_distance * max_distance && d2 < 0.999f * half_spacing_sq(hint, scratch)) {
      out = Neighbor{hint, d2};
      return true;
    }
    bound = std::min(bound, std::sqrt(d2) * (1.f + 1e-5f) + 1e-9f);
  }
  if (!tree_->nearest(query, out, bound)) {
    hint = kNoHint;
    return false;
  }
  hint = out.index;
  return true;
}

}  // namespace locard
