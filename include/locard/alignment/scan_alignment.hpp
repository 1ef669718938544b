#pragma once
// Multiway registration of a set of range scans (e.g. the Stanford bunny's 10 scans), each in
// its own sensor frame, from no initial poses at all (Choi, Zhou, Koltun 2015 applied to views
// instead of fragments; Open3D's multiway-registration tutorial is the same scheme):
//
//  1. Every scan is thinned to a voxel grid of `voxel_size` with normals towards its sensor
//     (the origin of its frame).
//  2. Every pair (i, j), i < j, is registered: from the input's poses when both scans have one
//     (T_i^-1 T_j; pairs whose thinned clouds' boxes, grown by the first gate, do not meet are
//     skipped as not overlapping), otherwise FPFH + RANSAC at feature_voxel_size
//     (global_registration.hpp, seeded by seed and the pair); then point-to-plane ICP coarse to
//     fine with gates icp_gates (narrow gates matter: with half a scan outside the overlap, a
//     wide gate pulls the optimum off by degrees). Pair (i, j) measures T_i_j.
//     The smaller scan of the pair is the ICP source, so fitness is the share of the smaller
//     scan's points with a partner within the last gate. The pair is verified when ICP
//     succeeds with fitness >= min_fitness and inlier RMSE <= max_inlier_rmse.
//  3. Initial poses: a maximum spanning tree over the verified pairs, weighted by fitness,
//     rooted at the root scan: the lowest index of the largest set of scans the verified pairs
//     connect (scan 0 unless it connects to nothing). The root keeps the identity, or its input
//     pose when every scan has one (then the model lives in the input's frame). Scans the tree
//     cannot reach are reported as unplaced, never given a guessed pose.
//  4. Pose graph (pose_graph.hpp): tree pairs are certain edges, the other verified pairs
//     uncertain ones (line process, pruning and post-check reject inconsistent pairs).
//  5. Multi-view refinement: `refine_rounds` rounds in which every placed scan but the root is
//     registered by point-to-plane ICP (the last two gates) against the union of all other
//     placed scans at their current poses (Gauss-Seidel order), so each scan settles against
//     all its neighbours at once instead of one pair at a time.
//  6. Per-scan confidence: each placed scan's fitness and inlier RMSE at the last gate against
//     all the other placed scans at their final poses.
// Randomness is seeded; the same scans and options give the same poses.

#include <locard/alignment/pose_graph.hpp>
#include <locard/core/point_cloud.hpp>
#include <locard/core/pose.hpp>

#include <cstddef>
#include <cstdint>
#include <optional>
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

// The options above scaled to the data: `spacing` is the scans' typical point spacing
// (median nearest-neighbour distance, metres). The defaults are these at 0.6 mm (the bunny).
ScanAlignmentOptions scan_alignment_options_for_spacing(double spacing);
// Median distance from a point to its nearest neighbour, over an even sample of every scan's
// points (at most `samples` per scan); 0 when no scan has two points.
double median_point_spacing(const std::vector<PointCloud>& scans, std::size_t samples = 2000);

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

struct ScanFit {
  double fitness = 0.0;      // share of the scan's thinned points with a partner in the others
  double inlier_rmse = 0.0;  // metres
};

struct ScanAlignmentResult {
  std::vector<Isometry3d> T_world_scan;  // world: the root's frame (or the input's, see 3.)
  std::vector<char> placed;              // 0: not connected to the root (pose is identity)
  std::size_t root = 0;
  std::vector<ScanFit> fit;              // per scan (zero when not placed)
  std::vector<ScanPair> pairs;
  PoseGraph graph;                       // nodes at the solved poses, before refinement
  std::vector<std::size_t> graph_scans;  // the scan of each graph node
  PoseGraphResult pose_graph;            // the last solve
  double seconds = 0.0;
};

// `initial` (empty, or one per scan): the input's poses T_world_scan where known.
// Throws InputError for fewer than two scans, an empty scan or unusable options.
ScanAlignmentResult align_scans(const std::vector<PointCloud>& scans,
                                const ScanAlignmentOptions& options = {},
                                const std::vector<std::optional<Isometry3d>>& initial = {});

}  // namespace locard
