#include <locard/features/descriptor_matching.hpp>

#include <locard/core/error.hpp>

#include "core/knn_result_set.hpp"

#include <nanoflann.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <fmt/format.h>

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
