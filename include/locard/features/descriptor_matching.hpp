#pragma once
// Correspondences in descriptor space (33-D FPFH) by nearest neighbour in Euclidean distance,
// through a kd-tree over the descriptors (nanoflann), parallel over queries (oneTBB).
//  - mutual: keep (s, t) only when t is the nearest target of s AND s the nearest source of t
//    (the "mutual filter" of FGR, Zhou et al. 2016).
//  - ratio test (Lowe 2004, eq. in section 7.1): keep (s, t) only when
//    d(s, t) < ratio * d(s, t2), t2 being the second-nearest target; ratio >= 1 disables it.
// Output is sorted by source index, and deterministic.

#include <locard/features/fpfh.hpp>

#include <cstdint>
#include <vector>

namespace locard {

// Indices are positions in the descriptor arrays passed to match_descriptors (with keypoints:
// map them back through the keypoint index arrays).
struct Correspondence {
  std::uint32_t source = 0;
  std::uint32_t target = 0;
  float distance = 0.f;  // descriptor distance (not squared)
  bool operator==(const Correspondence&) const = default;
};

struct MatchOptions {
  bool mutual = true;
  float ratio = 1.0f;  // Lowe's ratio; < 1 enables the test (0.8-0.9 are usual)
};

std::vector<Correspondence> match_descriptors(const std::vector<Fpfh>& source,
                                              const std::vector<Fpfh>& target,
                                              const MatchOptions& options = {});

}  // namespace locard
