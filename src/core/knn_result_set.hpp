#pragma once
// nanoflann result sets with Locard's semantics (private to the library):
//  - neighbours are ranked by (squared distance, index), so ties between duplicate points go
//    to the smaller index and the result does not depend on the tree's shape;
//  - the radius bound is inclusive (|q - p| <= r).
// nanoflann only offers a point to a result set when dist < worstDist() (strict), so both sets
// report their bound one ulp higher and decide exactly in addPoint().

#include <locard/core/kdtree.hpp>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace locard::detail {

inline float ulp_above(float x) {
  return std::nextafter(x, std::numeric_limits<float>::infinity());
}

inline bool ranks_before(float distance, std::uint32_t index, const Neighbor& other) {
  return distance < other.squared_distance ||
         (distance == other.squared_distance && index < other.index);
}

// The at most `capacity` best neighbours with squared distance <= max_distance_sq, kept sorted
// in a caller-provided array (insertion sort: k is small).
class BoundedKnnSet {
 public:
  BoundedKnnSet(Neighbor* out, std::size_t capacity, float max_distance_sq)
      : out_(out), capacity_(capacity), bound_(max_distance_sq),
        worst_(ulp_above(max_distance_sq)) {}

  std::size_t size() const { return count_; }
  bool full() const { return count_ == capacity_; }
  float worstDist() const { return worst_; }

  bool addPoint(float distance, std::uint32_t index) {
    if (capacity_ == 0 || distance > bound_) return true;
    if (count_ == capacity_ && !ranks_before(distance, index, out_[count_ - 1])) return true;
    std::size_t i = count_ < capacity_ ? count_++ : count_ - 1;
    for (; i > 0 && ranks_before(distance, index, out_[i - 1]); --i) out_[i] = out_[i - 1];
    out_[i] = Neighbor{index, distance};
    if (count_ == capacity_) worst_ = ulp_above(out_[count_ - 1].squared_distance);
    return true;
  }

 private:
  Neighbor* out_;
  std::size_t capacity_;
  std::size_t count_ = 0;
  float bound_;
  float worst_;
};

// Every neighbour with squared distance <= max_distance_sq, appended unsorted.
class InclusiveRadiusSet {
 public:
  InclusiveRadiusSet(float max_distance_sq, std::vector<Neighbor>& out)
      : bound_(max_distance_sq), worst_(ulp_above(max_distance_sq)), out_(out) {}

  std::size_t size() const { return out_.size(); }
  bool full() const { return true; }
  float worstDist() const { return worst_; }
  bool addPoint(float distance, std::uint32_t index) {
    if (distance <= bound_) out_.push_back(Neighbor{index, distance});
    return true;
  }

 private:
  float bound_;
  float worst_;
  std::vector<Neighbor>& out_;
};

// Ranking order as a function object (inlined by std::sort, unlike a function pointer).
struct NeighborLess {
  bool operator()(const Neighbor& a, const Neighbor& b) const {
    return ranks_before(a.squared_distance, a.index, b);
  }
};

}  // namespace locard::detail
