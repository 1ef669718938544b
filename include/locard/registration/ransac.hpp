#pragma once
// Global (initial) alignment by RANSAC over putative correspondences (Fischler & Bolles 1981),
// with the cheap pre-checks of Open3D's registration_ransac_based_on_feature_matching and
// Buch et al. 2013 ("Pose estimation using local structure-specific shape and appearance
// context"), followed by the closed-form Kabsch/Umeyama fit on the inliers.
//
// Hypothesis h (h = 0, 1, 2, ...):
//  1. draws ransac_n = 3 distinct correspondences (s_a, t_a), (s_b, t_b), (s_c, t_c) with a
//     counter-based generator seeded by (seed, h): the draw does not depend on which thread
//     runs h, or on anything drawn before;
//  2. edge-length check: for every pair of the three, with l_s = |s_a - s_b| and
//     l_t = |t_a - t_b|, require min(l_s, l_t) >= edge_length_ratio * max(l_s, l_t) (a rigid
//     motion keeps lengths); this costs nothing next to an SVD, so it runs first;
//  3. T_h = Kabsch on the three pairs (rigid_transform.hpp); degenerate (collinear) samples
//     are dropped;
//  4. distance check: |T_h s - t| <= max_correspondence_distance for the three sampled pairs;
//  5. score: inliers = #{ i : |T_h s_i - t_i| <= max_correspondence_distance } over all
//     correspondences, and their RMSE.
// Hypotheses are compared by (more inliers, then lower RMSE, then smaller h): a total order,
// so the winner does not depend on the order in which threads finish.
//
// Hypotheses run in parallel, in fixed blocks: kRansacFirstBlock hypotheses, then doubling up
// to kRansacBlock (64, 128, ..., 1024, 1024, ...). After each block, the number of
// hypotheses needed for `confidence` is updated from the best inlier ratio w,
//   N = log(1 - confidence) / log(1 - w^3),
// and the search stops at the first block boundary at or beyond min(N, max_iterations). Block
// boundaries, and so the result, are the same for any thread count: the same seed and input
// give the same transform bit for bit.
//
// The winner is polished: Kabsch on its inlier correspondences, inliers re-selected, repeated
// (at most refine_iterations times, or until the inlier set stops changing). Finally the
// fitness and inlier RMSE of the whole source cloud against the target cloud (nearest
// neighbour within max_correspondence_distance, as Open3D's RegistrationResult) are reported.
//
// All arithmetic is in double in frames centred at each cloud's centroid.

#include <locard/core/point_cloud.hpp>
#include <locard/core/pose.hpp>
#include <locard/features/descriptor_matching.hpp>

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

namespace locard {

inline constexpr std::size_t kRansacFirstBlock = 64;
inline constexpr std::size_t kRansacBlock = 1024;

struct RansacOptions {
  double max_correspondence_distance = 0.0075;  // metres (not squared): the inlier threshold
  double edge_length_ratio = 0.9;               // 0 disables the check
  std::size_t max_iterations = 100000;          // hypotheses at most
  double confidence = 0.999;                    // 1 disables early termination
  std::uint64_t seed = 0;
  int refine_iterations = 3;
  // success needs at least this many inlier correspondences (and >= 3) ...
  std::size_t min_inliers = 6;
  // ... and at least this cloud fitness.
  double min_fitness = 0.0;
};

struct RansacResult {
  bool success = false;
  std::string reason;  // why it failed; empty on success
  Isometry3d T_target_source = Isometry3d::Identity();
  std::size_t correspondences = 0;         // usable correspondences given (finite points)
  std::size_t inlier_correspondences = 0;  // at the polished estimate
  double inlier_ratio = 0.0;               // inlier_correspondences / correspondences
  double fitness = 0.0;                    // whole source cloud vs target cloud
  double inlier_rmse = 0.0;                // metres, over those cloud correspondences
  std::size_t cloud_correspondences = 0;
  std::size_t hypotheses = 0;              // drawn
  std::size_t hypotheses_checked = 0;      // that passed the checks and were scored
  std::size_t best_hypothesis = 0;         // index h of the winner
  std::uint64_t seed = 0;
  std::size_t dropped_correspondences = 0;  // on a non-finite point
  std::size_t source_non_finite = 0;        // points dropped from the clouds
  std::size_t target_non_finite = 0;
};

// `correspondences` index source.positions and target.positions (e.g. the output of
// match_descriptors on features computed for these clouds). Correspondences on a point with a
// NaN/Inf coordinate are dropped and counted. Throws InputError when a cloud has fewer than 3
// finite points, a correspondence index is out of range, or an option is out of range. Fewer than 3 usable
// correspondences, or no hypothesis passing the checks, is a failed result, not an error.
RansacResult ransac_registration(const PointCloud& source, const PointCloud& target,
                                 std::span<const Correspondence> correspondences,
                                 const RansacOptions& options);

}  // namespace locard
