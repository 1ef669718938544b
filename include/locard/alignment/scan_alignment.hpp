#pragma once
// Multiway registration of a set of range scans (e.g. the Stanford bunny's 10 scans), each in
// its own sensor frame, from no initial poses at all (Choi, Zhou, Koltun 2015 applied to views
// instead of fragments; Open3D's multiway-registration tutorial is the same scheme):
//
//  1. Every scan is thinned to a voxel grid of `voxel_size` with normals towards its sensor
//     (the origin of its frame).
//  2. Every pair (i, j), i < j, is registered: FPFH + RANSAC at feature_voxel_size
//     (global_registration.hpp, seeded by seed and the pair), then point-to-plane ICP coarse to
//     fine with gates icp_gates (narrow gates matter: with half a scan outside the overlap, a
//     wide gate pulls the optimum off by degrees). Pair (i, j) measures T_i_j.
//     The smaller scan of the pair is the ICP source, so fitness is the share of the smaller
//     scan's points with a partner within the last gate. The pair is verified when ICP
//     succeeds with fitness >= min_fitness and inlier RMSE <= max_inlier_rmse.
//  3. Initial poses: a maximum spanning tree over the verified pairs, weighted by fitness,
//     rooted at scan 0 (which keeps the identity: the model lives in scan 0's frame). Scans the
//     tree cannot reach are reported as unplaced, never given a guessed pose.
//  4. Pose graph (pose_graph.hpp): tree pairs are certain edges, the other verified pairs
//     uncertain ones (line process, pruning and post-check reject inconsistent pairs).
//  5. Multi-view refinement: `refine_rounds` rounds in which every placed scan but scan 0 is
//     registered by point-to-plane ICP (the last two gates) against the union of all other
//     placed scans at their current poses (Gauss-Seidel order), so each scan settles against
//     all its neighbours at once instead of one pair at a time.
// Randomness is seeded; the same scans and options give the same poses.

#include <locard/alignment/pose_graph.hpp>
#include <locard/core/point_cloud.hpp>
#include <locard/core/pose.hpp>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace locard {

struct ScanAlignmentOptions {
  double voxel_size = 0.002;          // scans thinned to this grid (metres)
  double feature_voxel_size = 0.005;  // FPFH + RANSAC resolution
  std::vector<double> icp_gates = {0.008, 0.003, 0.0015};  // coarse to fine (metres)
  double min_fitness = 0.25;
  double max_inlier_rmse = 0.001;     // metres, at the last gate
  int refine_rounds = 3;
  std::uint64_t seed = 0;
  PoseGraphOptions pose_graph{.max_correspondence_distance = 0.003};
};

struct ScanPair {
  std::size_t source = 0;  // j
  std::size_t target = 0;  // i
  bool verified = false;   // passed the ICP check
  bool in_tree = false;    // used for the initial poses
  bool kept = false;       // survived the pose graph
  std::string reason;      // why not verified / not kept
  double fitness = 0.0;
  double inlier_rmse = 0.0;
  Isometry3d T_target_source = Isometry3d::Identity();
};

struct ScanAlignmentResult {
  std::vector<Isometry3d> T_world_scan;  // world = scan 0's frame
  std::vector<char> placed;              // 0: not connected to scan 0 (pose is identity)
  std::vector<ScanPair> pairs;
  PoseGraphResult pose_graph;            // the last solve
  double seconds = 0.0;
};

// Throws InputError for fewer than two scans, an empty scan or unusable options.
ScanAlignmentResult align_scans(const std::vector<PointCloud>& scans,
                                const ScanAlignmentOptions& options = {});

}  // namespace locard
