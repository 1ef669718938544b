#include <locard/features/descriptor_matching.hpp>

#include <locard/core/error.hpp>

#include "core/knn_result_set.hpp"

#include <nanoflann.hpp>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

namespace locard {

namespace {

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

struct DescriptorAdaptor {
  const std::vector<Fpfh>* descriptors = nullptr;
  std::size_t kdtree_get_point_count() const { return descriptors->size(); }
  float kdtree_get_pt(std::uint32_t i, std::size_t dim) const {
    return (*descriptors)[i][static_cast<Eigen::Index>(dim)];
  }
  template <typename Box>
  bool kdtree_get_bbox(Box&) const { return false; }
};

using DescriptorTree = nanoflann::KDTreeSingleIndexAdaptor<
    nanoflann::L2_Adaptor<float, DescriptorAdaptor, float, std::uint32_t>, DescriptorAdaptor, 33,
    std::uint32_t>;

// A kd-tree over 33-D descriptors; k-NN ranked by (squared distance, index).
class DescriptorIndex {
 public:
  explicit DescriptorIndex(const std::vector<Fpfh>& descriptors) {
    adaptor_.descriptors = &descriptors;
    tree_ = std::make_unique<DescriptorTree>(33, adaptor_,
                                             nanoflann::KDTreeSingleIndexAdaptorParams(16));
  }
  DescriptorIndex(const DescriptorIndex&) = delete;
  DescriptorIndex& operator=(const DescriptorIndex&) = delete;
  // Fills out[0..k) and returns how many were found.
  std::size_t knn(const Fpfh& query, std::size_t k, Neighbor* out) const {
    detail::BoundedKnnSet set(out, std::min(k, adaptor_.kdtree_get_point_count()),
                              std::numeric_limits<float>::infinity());
    tree_->findNeighbors(set, query.data(), nanoflann::SearchParams());
    return set.size();
  }

 private:
  DescriptorAdaptor adaptor_;
  std::unique_ptr<DescriptorTree> tree_;
};

// Small sets (a few thousand keypoints a side, the usual case for global registration): exact
// brute force beats a kd-tree, which in 33 dimensions visits most leaves anyway. One pass over
// all pairs gives both directions: the best two targets of each source (row minima) and the
// best source of each target (column minima, for the mutual filter). Targets are stored
// dimension-major in blocks of kLanes so that the distance of one source to kLanes targets is
// one vector loop, each pair still summed in dimension order (the kd-tree oracle's order).
constexpr std::size_t kLanes = 8;
constexpr std::size_t kBruteForcePairs = std::size_t{1} << 24;

struct BlockedDescriptors {
  std::size_t count = 0;
  std::vector<float> values;  // block b, dimension d, lane l at (b * 33 + d) * kLanes + l
  explicit BlockedDescriptors(const std::vector<Fpfh>& d) : count(d.size()) {
    const std::size_t blocks = (count + kLanes - 1) / kLanes;
    // Padding lanes sit at an overflowing distance (+inf), never a best match.
    values.assign(blocks * 33 * kLanes, 1e30f);
    for (std::size_t i = 0; i < count; ++i)
      for (int k = 0; k < 33; ++k) values[((i / kLanes) * 33 + k) * kLanes + i % kLanes] = d[i][k];
  }
};

struct BruteForceResult {
  std::vector<Neighbor> best, second;  // per source (index kNone when absent)
  std::vector<Neighbor> column;        // per target: its nearest source
};

inline bool before(float d, std::uint32_t i, const Neighbor& n) {
  return d < n.squared_distance || (d == n.squared_distance && i < n.index);
}

BruteForceResult brute_force(const std::vector<Fpfh>& source, const std::vector<Fpfh>& target) {
  const BlockedDescriptors blocked(target);
  const std::size_t blocks = (target.size() + kLanes - 1) / kLanes;
  const Neighbor none{kNone, std::numeric_limits<float>::infinity()};
  BruteForceResult r;
  r.best.assign(source.size(), none);
  r.second.assign(source.size(), none);
  tbb::enumerable_thread_specific<std::vector<Neighbor>> columns(
      [&] { return std::vector<Neighbor>(target.size(), none); });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, source.size(), 16), [&](const auto& range) {
    std::vector<Neighbor>& column = columns.local();
    for (std::size_t s = range.begin(); s != range.end(); ++s) {
      const float* q = source[s].data();
      Neighbor b0 = none, b1 = none;
      for (std::size_t b = 0; b < blocks; ++b) {
        const float* t = blocked.values.data() + b * 33 * kLanes;
        float acc[kLanes] = {};
        for (int k = 0; k < 33; ++k)
          for (std::size_t l = 0; l < kLanes; ++l) {
            const float diff = q[k] - t[k * kLanes + l];
            acc[l] += diff * diff;
          }
        const std::size_t lanes = std::min(kLanes, target.size() - b * kLanes);
        for (std::size_t l = 0; l < lanes; ++l) {
          const auto j = static_cast<std::uint32_t>(b * kLanes + l);
          const float d = acc[l];
          // Targets come in increasing index: a strict test keeps ties on the smaller one.
          if (d < b0.squared_distance) {
            b1 = b0;
            b0 = Neighbor{j, d};
          } else if (d < b1.squared_distance) {
            b1 = Neighbor{j, d};
          }
          if (before(d, static_cast<std::uint32_t>(s), column[j]))
            column[j] = Neighbor{static_cast<std::uint32_t>(s), d};
        }
      }
      r.best[s] = b0;
      r.second[s] = b1;
    }
  });
  r.column.assign(target.size(), none);
  for (const auto& column : columns)
    for (std::size_t j = 0; j < column.size(); ++j)
      if (before(column[j].squared_distance, column[j].index, r.column[j])) r.column[j] = column[j];
  return r;
}

void check_finite(const std::vector<Fpfh>& descriptors, const char* which) {
  for (std::size_t i = 0; i < descriptors.size(); ++i) {
    if (!descriptors[i].allFinite()) {
      throw InputError(fmt::format("descriptor matching: {} descriptor {} is not finite", which, i));
    }
  }
}

}  // namespace

std::vector<Correspondence> match_descriptors(const std::vector<Fpfh>& source,
                                              const std::vector<Fpfh>& target,
                                              const MatchOptions& options) {
  if (source.empty() || target.empty()) return {};
  check_finite(source, "source");
  check_finite(target, "target");
  const bool ratio_test = options.ratio < 1.0f;
  if (ratio_test && !(options.ratio > 0.0f)) {
    throw InputError(fmt::format("descriptor matching: the ratio must be in (0, 1], got {}",
                                 options.ratio));
  }

  if (source.size() * target.size() <= kBruteForcePairs) {
    const BruteForceResult r = brute_force(source, target);
    std::vector<Correspondence> matches;
    for (std::size_t s = 0; s < source.size(); ++s) {
      const Neighbor& f = r.best[s];
      if (f.index == kNone) continue;
      // Lowe 2004, as below; a lone target has no second neighbour and passes.
      if (ratio_test && r.second[s].index != kNone &&
          !(f.squared_distance < options.ratio * options.ratio * r.second[s].squared_distance))
        continue;
      if (options.mutual && r.column[f.index].index != s) continue;
      matches.push_back(Correspondence{static_cast<std::uint32_t>(s), f.index,
                                       std::sqrt(f.squared_distance)});
    }
    return matches;
  }

  // Forward: nearest (and second-nearest for the ratio test) target of every source.
  const DescriptorIndex target_index(target);
  std::vector<Neighbor> forward(source.size(), Neighbor{kNone, 0.f});
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, source.size(), 64), [&](const auto& range) {
    Neighbor best[2];
    for (std::size_t s = range.begin(); s != range.end(); ++s) {
      const std::size_t found = target_index.knn(source[s], ratio_test ? 2 : 1, best);
      // Lowe 2004: keep when d1 < ratio * d2 (squared: d1^2 < ratio^2 d2^2). A lone target
      // has no second neighbour and passes.
      if (ratio_test && found == 2 &&
          !(best[0].squared_distance <
            options.ratio * options.ratio * best[1].squared_distance)) {
        continue;
      }
      forward[s] = best[0];
    }
  });

  // Backward (mutual filter): nearest source of every target that some source picked.
  std::vector<std::uint32_t> backward(target.size(), kNone);
  if (options.mutual) {
    std::vector<std::uint8_t> picked(target.size(), 0);
    for (const Neighbor& f : forward) {
      if (f.index != kNone) picked[f.index] = 1;
    }
    const DescriptorIndex source_index(source);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, target.size(), 64),
                      [&](const auto& range) {
                        Neighbor best;
                        for (std::size_t t = range.begin(); t != range.end(); ++t) {
                          if (picked[t] && source_index.knn(target[t], 1, &best) == 1) {
                            backward[t] = best.index;
                          }
                        }
                      });
  }

  std::vector<Correspondence> matches;
  for (std::size_t s = 0; s < source.size(); ++s) {
    const Neighbor& f = forward[s];
    if (f.index == kNone) continue;
    if (options.mutual && backward[f.index] != s) continue;
    matches.push_back(Correspondence{static_cast<std::uint32_t>(s), f.index,
                                     std::sqrt(f.squared_distance)});
  }
  return matches;
}

}  // namespace locard
