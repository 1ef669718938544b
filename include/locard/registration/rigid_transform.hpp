#pragma once
// Closed-form rigid alignment of paired points (Kabsch 1976; Umeyama 1991, "Least-squares
// estimation of transformation parameters between two point patterns", eq. 34-42 with scale
// fixed to 1).
//
// Given pairs (s_i, t_i) with weights w_i >= 0, find R in SO(3) and t minimising
//   E(R, t) = sum_i w_i |R s_i + t - t_i|^2.
// With W = sum w_i, the weighted means mu_s = sum w_i s_i / W, mu_t = sum w_i t_i / W and the
// cross-covariance
//   Sigma = 1/W sum_i w_i (t_i - mu_t)(s_i - mu_s)^T = U D V^T   (SVD),
// the minimiser is
//   R = U S V^T,  S = diag(1, 1, det(U) det(V))   (S keeps R a rotation, not a reflection),
//   t = mu_t - R mu_s.
// The solution is unique when Sigma has rank >= 2 (the source points are not all on one
// line); with rank < 2 (d_1 <= 1e-9 d_0) there is none to report and we return nullopt.

#include <locard/core/pose.hpp>

#include <Eigen/Core>

#include <cstddef>
#include <optional>
#include <span>

namespace locard {

// Two passes (means, then centred sums), so far-from-origin points lose nothing to
// cancellation. `weights` empty means all 1; otherwise one per pair, >= 0. Returns nullopt
// when there are fewer than 3 pairs, the weights sum to 0, or the points are degenerate.
// Throws std::invalid_argument when the spans differ in size.
std::optional<Isometry3d> estimate_rigid_transform(std::span<const Eigen::Vector3d> source,
                                                   std::span<const Eigen::Vector3d> target,
                                                   std::span<const double> weights = {});

// One-pass form for parallel reductions (ICP's point-to-point step): sums
//   W, sum w s, sum w t, sum w t s^T
// and recovers Sigma = sum w t s^T / W - mu_t mu_s^T. Feed coordinates that are already
// centred near the origin (ICP works in a locally centred frame); far from the origin the
// subtraction cancels digits.
class RigidTransformAccumulator {
 public:
  void add(const Eigen::Vector3d& source, const Eigen::Vector3d& target, double weight = 1.0) {
    weight_ += weight;
    sum_source_ += weight * source;
    sum_target_ += weight * target;
    sum_target_source_.noalias() += (weight * target) * source.transpose();
    ++count_;
  }
  void merge(const RigidTransformAccumulator& other) {
    weight_ += other.weight_;
    sum_source_ += other.sum_source_;
    sum_target_ += other.sum_target_;
    sum_target_source_ += other.sum_target_source_;
    count_ += other.count_;
  }
  std::size_t count() const { return count_; }
  double weight_sum() const { return weight_; }
  // Same conditions as estimate_rigid_transform.
  std::optional<Isometry3d> solve() const;

 private:
  double weight_ = 0.0;
  Eigen::Vector3d sum_source_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d sum_target_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d sum_target_source_ = Eigen::Matrix3d::Zero();
  std::size_t count_ = 0;
};

// The rotation and translation of the minimiser for given means and cross-covariance (the
// shared last step of the two functions above); nullopt when Sigma has rank < 2.
std::optional<Isometry3d> rigid_transform_from_moments(const Eigen::Vector3d& mean_source,
                                                       const Eigen::Vector3d& mean_target,
                                                       const Eigen::Matrix3d& cross_covariance);

}  // namespace locard
