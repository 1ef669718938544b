#pragma once
// Kd-tree over 3D float points (nanoflann underneath, hidden behind a pimpl so that users of
// Locard do not need nanoflann's header).
//
// Conventions, the same for every query:
//  - `radius` arguments are plain distances in metres, NOT squared. (nanoflann itself takes a
//    squared radius for the L2 metric; the conversion happens once, inside kdtree.cpp.)
//  - Results are Neighbor{index, squared_distance}: the distance IS squared.
//  - Results are sorted by (squared_distance, index): ties between duplicate points are
//    broken by the smaller index, so the output does not depend on the thread count.
//  - A query point that is itself in the tree is returned as its own neighbour (distance 0).
// Thread safety: every const member may be called concurrently from many threads.

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <vector>

namespace locard {

struct Neighbor {
  std::uint32_t index = 0;       // index into KdTree::points()
  float squared_distance = 0.f;  // |query - points()[index]|^2, metres^2
  bool operator==(const Neighbor&) const = default;
};

// Neighbour lists of a batch query in compressed-row form: the neighbours of query q are
// neighbors[offsets[q] .. offsets[q + 1]), sorted as above.
struct NeighborLists {
  std::vector<std::size_t> offsets{0};  // size = number of queries + 1
  std::vector<Neighbor> neighbors;

  std::size_t query_count() const { return offsets.size() - 1; }
  std::span<const Neighbor> operator[](std::size_t q) const {
    return {neighbors.data() + offsets[q], offsets[q + 1] - offsets[q]};
  }
};

class KdTree {
 public:
  // An empty tree: every query returns nothing.
  KdTree();
  // Copies the points (the tree owns them, so it cannot dangle). Non-finite points must have
  // been removed beforehand (see preprocess/point_selection.hpp); they would poison the
  // bounding boxes. `max_leaf_size` trades build time against query time (nanoflann's leaf).
  explicit KdTree(std::vector<Eigen::Vector3f> points, int max_leaf_size = 12);
  ~KdTree();
  KdTree(KdTree&&) noexcept;
  KdTree& operator=(KdTree&&) noexcept;
  KdTree(const KdTree&) = delete;
  KdTree& operator=(const KdTree&) = delete;

  std::size_t size() const;
  bool empty() const { return size() == 0; }
  const std::vector<Eigen::Vector3f>& points() const;

  // --- single queries: fill `out` (cleared first) and return its size ----------------------
  // The k nearest points (fewer when the tree has fewer than k points).
  std::size_t knn(const Eigen::Vector3f& query, int k, std::vector<Neighbor>& out) const;
  // Every point with |query - p| <= radius (radius in metres, not squared).
  std::size_t radius(const Eigen::Vector3f& query, float radius,
                     std::vector<Neighbor>& out) const;
  // Hybrid (Open3D's KDTreeSearchParamHybrid): the at most `max_k` nearest points among
  // those with |query - p| <= radius (radius in metres, not squared).
  std::size_t hybrid(const Eigen::Vector3f& query, float radius, int max_k,
                     std::vector<Neighbor>& out) const;
  // The nearest point, if one lies within `max_distance` (metres, not squared); the fast path
  // for ICP correspondences. Returns false when the tree is empty or nothing is that close.
  bool nearest(const Eigen::Vector3f& query, Neighbor& out,
               float max_distance = std::numeric_limits<float>::infinity()) const;

  // --- parallel batch queries (oneTBB); results identical to calling the single queries ----
  NeighborLists knn_batch(std::span<const Eigen::Vector3f> queries, int k) const;
  NeighborLists radius_batch(std::span<const Eigen::Vector3f> queries, float radius) const;
  NeighborLists hybrid_batch(std::span<const Eigen::Vector3f> queries, float radius,
                             int max_k) const;
  // One nearest neighbour per query; index = UINT32_MAX and squared_distance = +inf where
  // nothing lies within `max_distance` (metres, not squared).
  std::vector<Neighbor> nearest_batch(
      std::span<const Eigen::Vector3f> queries,
      float max_distance = std::numeric_limits<float>::infinity()) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace locard
