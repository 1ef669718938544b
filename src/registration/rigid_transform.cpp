// Closed-form rigid alignment (Kabsch / Umeyama); the derivation is in rigid_transform.hpp.
#include <locard/registration/rigid_transform.hpp>

#include <Eigen/SVD>

#include <stdexcept>

namespace locard {

std::optional<Isometry3d> rigid_transform_from_moments(const Eigen::Vector3d& mean_source,
                                                       const Eigen::Vector3d& mean_target,
                                                       const Eigen::Matrix3d& cross_covariance) {
  if (!cross_covariance.allFinite() || !mean_source.allFinite() || !mean_target.allFinite())
    return std::nullopt;
  // Sigma = U D V^T; R = U S V^T (Umeyama eq. 39-40).
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cross_covariance,
                                              Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d d = svd.singularValues();  // decreasing
  if (!(d(0) > 0.0) || d(1) <= 1e-9 * d(0)) return std::nullopt;  // rank < 2: not unique
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) S(2, 2) = -1.0;
  Isometry3d T = Isometry3d::Identity();
  T.linear() = svd.matrixU() * S * svd.matrixV().transpose();
  T.translation() = mean_target - T.linear() * mean_source;  // eq. 41
  return T;
}

std::optional<Isometry3d> estimate_rigid_transform(std::span<const Eigen::Vector3d> source,
                                                   std::span<const Eigen::Vector3d> target,
                                                   std::span<const double> weights) {
  if (source.size() != target.size())
    throw std::invalid_argument("estimate_rigid_transform: source and target differ in size");
  if (!weights.empty() && weights.size() != source.size())
    throw std::invalid_argument("estimate_rigid_transform: one weight per pair is needed");
  if (source.size() < 3) return std::nullopt;
  auto w = [&](std::size_t i) { return weights.empty() ? 1.0 : weights[i]; };
  // Pass 1: weighted means.
  double W = 0.0;
  Eigen::Vector3d mu_s = Eigen::Vector3d::Zero(), mu_t = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < source.size(); ++i) {
    W += w(i);
    mu_s += w(i) * source[i];
    mu_t += w(i) * target[i];
  }
  if (!(W > 0.0)) return std::nullopt;
  mu_s /= W;
  mu_t /= W;
  // Pass 2: centred cross-covariance Sigma = 1/W sum w (t - mu_t)(s - mu_s)^T.
  Eigen::Matrix3d sigma = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < source.size(); ++i)
    sigma.noalias() += (w(i) * (target[i] - mu_t)) * (source[i] - mu_s).transpose();
  return rigid_transform_from_moments(mu_s, mu_t, sigma / W);
}

std::optional<Isometry3d> RigidTransformAccumulator::solve() const {
  if (count_ < 3 || !(weight_ > 0.0)) return std::nullopt;
  const Eigen::Vector3d mu_s = sum_source_ / weight_;
  const Eigen::Vector3d mu_t = sum_target_ / weight_;
  const Eigen::Matrix3d sigma = sum_target_source_ / weight_ - mu_t * mu_s.transpose();
  return rigid_transform_from_moments(mu_s, mu_t, sigma);
}

}  // namespace locard
