#pragma once
// Trajectory accuracy as the TUM RGB-D benchmark defines it (Sturm et al. 2012, "A benchmark
// for the evaluation of RGB-D SLAM systems", section VI; its evaluate_ate.py / evaluate_rpe.py).
//
// Association (evaluate_ate.py `associate`): every (ground truth a, estimate b) pair with
// |t_a - t_b| < max_time_difference is a candidate; candidates are taken greedily by increasing
// time difference, each pose used at most once; pairs are then ordered by ground-truth time.
// With match_by_frame_index, poses are paired by equal frame_index instead (7-Scenes frames).
//
// ATE: the rigid motion S (rotation and translation, no scale; Horn 1987 / Kabsch) minimising
//   sum_k |gt_k.t - S est_k.t|^2
// over the associated camera positions; e_k = |gt_k.t - S est_k.t|; ATE RMSE = sqrt(mean e_k^2).
//
// RPE, fixed delta (evaluate_rpe.py --fixed_delta): for associated pairs k and l, with l the
// pair `delta` pairs later (unit frames) or the pair whose estimate time is closest to
// t_k + delta (unit seconds, l > k; only when that time difference is within
// max_time_difference, so pairs near the end are not stretched),
//   E_kl = (est_k^-1 est_l) (gt_k^-1 gt_l)^-1,
// the translational error |trans(E_kl)| and the rotational error angle(E_kl).

#include <locard/core/pose.hpp>

#include <cstddef>
#include <string>
#include <vector>

namespace locard {

struct TrajectoryAssociation {
  std::size_t ground_truth = 0;  // index into the ground-truth trajectory
  std::size_t estimate = 0;      // index into the estimated trajectory
};

struct AssociationOptions {
  double max_time_difference = 0.02;  // seconds (TUM's default)
  double time_offset = 0.0;           // added to estimate times (TUM's --offset)
  bool match_by_frame_index = false;
};

std::vector<TrajectoryAssociation> associate_trajectories(const Trajectory& ground_truth,
                                                          const Trajectory& estimate,
                                                          const AssociationOptions& options = {});

struct ErrorStatistics {
  double rmse = 0.0;
  double mean = 0.0;
  double median = 0.0;
  double std_dev = 0.0;  // population standard deviation, as numpy.std
  double min = 0.0;
  double max = 0.0;
};
ErrorStatistics error_statistics(std::vector<double> errors);

struct AteResult {
  std::size_t pairs = 0;
  Isometry3d T_groundtruth_estimate = Isometry3d::Identity();  // the alignment S
  ErrorStatistics translation;                                 // metres
  std::vector<double> errors;  // e_k per associated pair, in association order
  std::vector<TrajectoryAssociation> associations;
};

// Throws InputError when fewer than 3 pairs associate or the positions are degenerate
// (collinear) so that no unique alignment exists. align = false skips S (identity).
AteResult absolute_trajectory_error(const Trajectory& ground_truth, const Trajectory& estimate,
                                    const AssociationOptions& options = {}, bool align = true);

enum class DeltaUnit { Frames, Seconds };

struct RpeOptions {
  double delta = 1.0;
  DeltaUnit unit = DeltaUnit::Frames;
};

struct RpeResult {
  std::size_t pairs = 0;
  ErrorStatistics translation;    // metres
  ErrorStatistics rotation_deg;   // degrees
};

// Throws InputError when no pair of associated poses is delta apart.
RpeResult relative_pose_error(const Trajectory& ground_truth, const Trajectory& estimate,
                              const AssociationOptions& association = {},
                              const RpeOptions& options = {});

}  // namespace locard
