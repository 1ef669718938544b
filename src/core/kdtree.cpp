#include <locard/core/kdtree.hpp>

#include "core/knn_result_set.hpp"

#include <nanoflann.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <stdexcept>

namespace locard {

namespace {

// nanoflann's dataset interface over the owned positions.
struct PointsAdaptor {
  const std::vector<Eigen::Vector3f>* points = nullptr;
  std::size_t kdtree_get_point_count() const { return points->size(); }
  float kdtree_get_pt(std::uint32_t i, std::size_t dim) const { return (*points)[i][dim]; }
  template <typename Box>
  bool kdtree_get_bbox(Box&) const { return false; }
};

using NanoTree = nanoflann::KDTreeSingleIndexAdaptor<
    nanoflann::L2_Simple_Adaptor<float, PointsAdaptor, float, std::uint32_t>, PointsAdaptor, 3,
    std::uint32_t>;

float squared(float radius) { return radius * radius; }

// Runs `query(q, scratch)` (which fills `scratch` with the neighbours of query q) for every
// query in parallel and packs the results in compressed rows. Queries are processed in fixed
// blocks whose results are concatenated in query order, so the output does not depend on the
// scheduling.
template <typename Query>
NeighborLists run_batch(std::size_t query_count, const Query& query) {
  constexpr std::size_t kBlock = 256;
  const std::size_t blocks = (query_count + kBlock - 1) / kBlock;
  std::vector<std::vector<Neighbor>> block_results(blocks);
  NeighborLists lists;
  lists.offsets.assign(query_count + 1, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks), [&](const auto& range) {
    std::vector<Neighbor> scratch;
    for (std::size_t b = range.begin(); b != range.end(); ++b) {
      std::vector<Neighbor>& out = block_results[b];
      const std::size_t end = std::min(query_count, (b + 1) * kBlock);
      for (std::size_t q = b * kBlock; q < end; ++q) {
        query(q, scratch);
        lists.offsets[q + 1] = scratch.size();
        out.insert(out.end(), scratch.begin(), scratch.end());
      }
    }
  });
  for (std::size_t q = 0; q < query_count; ++q) lists.offsets[q + 1] += lists.offsets[q];
  lists.neighbors.resize(lists.offsets[query_count]);
  tbb::parallel_for(std::size_t{0}, blocks, [&](std::size_t b) {
    std::copy(block_results[b].begin(), block_results[b].end(),
              lists.neighbors.begin() + static_cast<std::ptrdiff_t>(lists.offsets[b * kBlock]));
  });
  return lists;
}

}  // namespace

struct KdTree::Impl {
  std::vector<Eigen::Vector3f> points;
  PointsAdaptor adaptor;
  std::unique_ptr<NanoTree> tree;  // null when empty

  Impl(std::vector<Eigen::Vector3f> pts, int max_leaf_size) : points(std::move(pts)) {
    adaptor.points = &points;
    if (points.size() > std::numeric_limits<std::uint32_t>::max() - 1) {
      throw std::length_error("KdTree: more than 2^32 - 2 points");
    }
    if (!points.empty()) {
      tree = std::make_unique<NanoTree>(
          3, adaptor,
          nanoflann::KDTreeSingleIndexAdaptorParams(
              static_cast<std::size_t>(std::max(1, max_leaf_size))));
    }
  }

  // The at most k best neighbours within max_distance_sq (inclusive), sorted.
  std::size_t bounded_knn(const Eigen::Vector3f& query, std::size_t k, float max_distance_sq,
                          std::vector<Neighbor>& out) const {
    out.clear();
    if (!tree || k == 0) return 0;
    out.resize(std::min(k, points.size()));
    detail::BoundedKnnSet set(out.data(), out.size(), max_distance_sq);
    tree->findNeighbors(set, query.data(), nanoflann::SearchParams());
    out.resize(set.size());
    return out.size();
  }

  std::size_t radius(const Eigen::Vector3f& query, float max_distance_sq,
                     std::vector<Neighbor>& out) const {
    out.clear();
    if (!tree) return 0;
    detail::InclusiveRadiusSet set(max_distance_sq, out);
    tree->findNeighbors(set, query.data(), nanoflann::SearchParams());
    std::sort(out.begin(), out.end(), detail::NeighborLess{});
    return out.size();
  }
};

KdTree::KdTree() : impl_(std::make_unique<Impl>(std::vector<Eigen::Vector3f>{}, 12)) {}
KdTree::KdTree(std::vector<Eigen::Vector3f> points, int max_leaf_size)
    : impl_(std::make_unique<Impl>(std::move(points), max_leaf_size)) {}
KdTree::~KdTree() = default;
KdTree::KdTree(KdTree&&) noexcept = default;
KdTree& KdTree::operator=(KdTree&&) noexcept = default;

std::size_t KdTree::size() const { return impl_ ? impl_->points.size() : 0; }

const std::vector<Eigen::Vector3f>& KdTree::points() const {
  static const std::vector<Eigen::Vector3f> kEmpty;
  return impl_ ? impl_->points : kEmpty;
}

std::size_t KdTree::knn(const Eigen::Vector3f& query, int k, std::vector<Neighbor>& out) const {
  out.clear();
  if (!impl_ || k <= 0) return 0;
  return impl_->bounded_knn(query, static_cast<std::size_t>(k),
                            std::numeric_limits<float>::infinity(), out);
}

std::size_t KdTree::radius(const Eigen::Vector3f& query, float radius,
                           std::vector<Neighbor>& out) const {
  out.clear();
  if (!impl_ || !(radius >= 0.f)) return 0;
  return impl_->radius(query, squared(radius), out);  // nanoflann's L2 works in squared units
}

std::size_t KdTree::hybrid(const Eigen::Vector3f& query, float radius, int max_k,
                           std::vector<Neighbor>& out) const {
  out.clear();
  if (!impl_ || max_k <= 0 || !(radius >= 0.f)) return 0;
  return impl_->bounded_knn(query, static_cast<std::size_t>(max_k), squared(radius), out);
}

bool KdTree::nearest(const Eigen::Vector3f& query, Neighbor& out, float max_distance) const {
  if (!impl_ || !impl_->tree || !(max_distance >= 0.f)) return false;
  Neighbor best;
  detail::BoundedKnnSet set(&best, 1, squared(max_distance));
  impl_->tree->findNeighbors(set, query.data(), nanoflann::SearchParams());
  if (set.size() == 0) return false;
  out = best;
  return true;
}

NeighborLists KdTree::knn_batch(std::span<const Eigen::Vector3f> queries, int k) const {
  return run_batch(queries.size(), [&](std::size_t q, std::vector<Neighbor>& out) {
    knn(queries[q], k, out);
  });
}

NeighborLists KdTree::radius_batch(std::span<const Eigen::Vector3f> queries,
                                   float radius_m) const {
  return run_batch(queries.size(), [&](std::size_t q, std::vector<Neighbor>& out) {
    radius(queries[q], radius_m, out);
  });
}

NeighborLists KdTree::hybrid_batch(std::span<const Eigen::Vector3f> queries, float radius_m,
                                   int max_k) const {
  return run_batch(queries.size(), [&](std::size_t q, std::vector<Neighbor>& out) {
    hybrid(queries[q], radius_m, max_k, out);
  });
}

std::vector<Neighbor> KdTree::nearest_batch(std::span<const Eigen::Vector3f> queries,
                                            float max_distance) const {
  std::vector<Neighbor> result(queries.size(),
                               Neighbor{std::numeric_limits<std::uint32_t>::max(),
                                        std::numeric_limits<float>::infinity()});
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, queries.size(), 512),
                    [&](const auto& range) {
                      for (std::size_t q = range.begin(); q != range.end(); ++q) {
                        nearest(queries[q], result[q], max_distance);
                      }
                    });
  return result;
}

}  // namespace locard
