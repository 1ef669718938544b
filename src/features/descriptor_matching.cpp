#include <locard/features/descriptor_matching.hpp>

#include <locard/core/error.hpp>

#include "core/knn_result_set.hpp"

#include <nanoflann.hpp>
#include <tbb/blocked_range.h>
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
// brute force beats a kd-tree, which in 33 dimensions visits most leaves anyway. Descriptors
// are stored dimension-major in blocks of kLanes so that the distance of one query to kLanes
// descriptors is one vector loop, each pair still summed in dimension order (the kd-tree
// oracle's order, so the distances are the same bits).
//
// Partial distance elimination: a squared distance only grows as dimensions are added, so a
// block is dropped as soon as every lane's partial sum exceeds the distance that still matters
// (the second-best so far for the ratio test, else the best). Lanes that survive are summed in
// full, so the result is exactly the full search's. The mutual filter is one more such search
// per candidate: from its target over all sources, dropped at the candidate's own distance.
constexpr std::size_t kLanes = 8;
constexpr std::size_t kBruteForcePairs = std::size_t{1} << 24;

struct BlockedDescriptors {
  std::size_t count = 0;
  std::size_t blocks = 0;
  std::vector<float> values;  // block b, dimension d, lane l at (b * 33 + d) * kLanes + l
  explicit BlockedDescriptors(const std::vector<Fpfh>& d)
      : count(d.size()), blocks((d.size() + kLanes - 1) / kLanes) {
    // Padding lanes sit at an overflowing distance (+inf), never a match.
    values.assign(blocks * 33 * kLanes, 1e30f);
    for (std::size_t i = 0; i < count; ++i)
      for (int k = 0; k < 33; ++k) values[((i / kLanes) * 33 + k) * kLanes + i % kLanes] = d[i][k];
  }
  const float* block(std::size_t b) const { return values.data() + b * 33 * kLanes; }
  std::size_t lanes(std::size_t b) const { return std::min(kLanes, count - b * kLanes); }
};

// Squared distances from q to the kLanes descriptors of a block, in dimension order, as one
// vector of kLanes floats (GCC vector extensions: two SSE registers on the baseline, one AVX2
// register in the AVX2 clone; lane-wise IEEE arithmetic either way). Returns false as soon as
// every lane's partial sum exceeds `limit` (then acc is partial).
using Lanes = float __attribute__((vector_size(kLanes * sizeof(float))));
using UnalignedLanes = float __attribute__((vector_size(kLanes * sizeof(float)), aligned(4)));

[[gnu::always_inline]] inline bool all_over(const Lanes& acc, float limit) {
  for (std::size_t l = 0; l < kLanes; ++l)
    if (!(acc[l] > limit)) return false;
  return true;
}

[[gnu::always_inline]] inline bool block_distances(const float* q, const float* t, float limit,
                                                   Lanes& acc) {
  const auto* tv = reinterpret_cast<const UnalignedLanes*>(t);
  acc = Lanes{};
  int k = 0;
  for (const int stop : {8, 16, 24}) {
    for (; k < stop; ++k) {
      const Lanes diff = q[k] - Lanes(tv[k]);
      acc += diff * diff;
    }
    if (all_over(acc, limit)) return false;
  }
  for (; k < 33; ++k) {
    const Lanes diff = q[k] - Lanes(tv[k]);
    acc += diff * diff;
  }
  return true;
}

// Best and second-best target of every source (index kNone when absent); ties keep the
// smaller index.
struct RowResult {
  std::vector<Neighbor> best, second;
};

// The kernels below are compiled twice, for AVX2 (one block of kLanes floats is one ymm
// register) and for the x86-64 baseline, and the loader picks one per machine. Neither uses FMA
// (ISO C++ mode contracts nothing, and fp-contract is off here), so both give the same bits.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__SANITIZE_ADDRESS__)
#define LOCARD_MATCH_KERNEL [[gnu::target_clones("avx2", "default"), gnu::optimize("fp-contract=off")]]
#else
#define LOCARD_MATCH_KERNEL
#endif

LOCARD_MATCH_KERNEL void nearest_targets_range(const Fpfh* source, std::size_t begin,
                                               std::size_t end, const BlockedDescriptors& target,
                                               bool need_second, Neighbor* best,
                                               Neighbor* second) {
  const Neighbor none{kNone, std::numeric_limits<float>::infinity()};
  Lanes acc;
  for (std::size_t s = begin; s != end; ++s) {
    const float* q = source[s].data();
    Neighbor b0 = none, b1 = none;
    for (std::size_t b = 0; b < target.blocks; ++b) {
      const float limit = need_second ? b1.squared_distance : b0.squared_distance;
      if (!block_distances(q, target.block(b), limit, acc)) continue;
      const std::size_t lanes = target.lanes(b);
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
      }
    }
    best[s] = b0;
    second[s] = b1;
  }
}

RowResult nearest_targets(const std::vector<Fpfh>& source, const BlockedDescriptors& target,
                          bool need_second) {
  const Neighbor none{kNone, std::numeric_limits<float>::infinity()};
  RowResult r;
  r.best.assign(source.size(), none);
  r.second.assign(source.size(), none);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, source.size(), 16), [&](const auto& range) {
    nearest_targets_range(source.data(), range.begin(), range.end(), target, need_second,
                          r.best.data(), r.second.data());
  });
  return r;
}

// Whether source s is the nearest source of target t (ties to the smaller index), d being
// their squared distance.
LOCARD_MATCH_KERNEL bool nearest_source_is(const Fpfh& t, std::uint32_t s, float d,
                                           const BlockedDescriptors& source) {
  Lanes acc;
  for (std::size_t b = 0; b < source.blocks; ++b) {
    if (!block_distances(t.data(), source.block(b), d, acc)) continue;
    const std::size_t lanes = source.lanes(b);
    for (std::size_t l = 0; l < lanes; ++l) {
      const auto other = static_cast<std::uint32_t>(b * kLanes + l);
      if (other != s && (acc[l] < d || (acc[l] == d && other < s))) return false;
    }
  }
  return true;
}

// Lowe 2004: keep when d1 < ratio * d2 (squared: d1^2 < ratio^2 d2^2). A lone target has no
// second neighbour and passes.
bool passes_ratio(const Neighbor& best, const Neighbor& second, bool ratio_test, float ratio) {
  return !ratio_test || second.index == kNone ||
         best.squared_distance < ratio * ratio * second.squared_distance;
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
    const RowResult r = nearest_targets(source, BlockedDescriptors(target), ratio_test);
    std::vector<std::uint8_t> keep(source.size(), 0);
    for (std::size_t s = 0; s < source.size(); ++s)
      keep[s] = r.best[s].index != kNone &&
                passes_ratio(r.best[s], r.second[s], ratio_test, options.ratio);
    if (options.mutual) {
      const BlockedDescriptors blocked_source(source);
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, source.size(), 16), [&](const auto& range) {
        for (std::size_t s = range.begin(); s != range.end(); ++s) {
          if (!keep[s]) continue;
          const Neighbor& f = r.best[s];
          keep[s] = nearest_source_is(target[f.index], static_cast<std::uint32_t>(s),
                                      f.squared_distance, blocked_source);
        }
      });
    }
    std::vector<Correspondence> matches;
    for (std::size_t s = 0; s < source.size(); ++s)
      if (keep[s])
        matches.push_back(Correspondence{static_cast<std::uint32_t>(s), r.best[s].index,
                                         std::sqrt(r.best[s].squared_distance)});
    return matches;
  }

  // Forward: nearest (and second-nearest for the ratio test) target of every source.
  const DescriptorIndex target_index(target);
  std::vector<Neighbor> forward(source.size(), Neighbor{kNone, 0.f});
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, source.size(), 64), [&](const auto& range) {
    Neighbor best[2];
    for (std::size_t s = range.begin(); s != range.end(); ++s) {
      const std::size_t found = target_index.knn(source[s], ratio_test ? 2 : 1, best);
      if (found == 0) continue;
      const Neighbor second = found == 2 ? best[1] : Neighbor{kNone, 0.f};
      if (!passes_ratio(best[0], second, ratio_test, options.ratio)) continue;
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
