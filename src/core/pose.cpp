#include <locard/core/pose.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace locard {

Isometry3d isometry_from_translation_quaternion(const Eigen::Vector3d& t, double qx, double qy,
                                                double qz, double qw) {
  Isometry3d T = Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(qw, qx, qy, qz).normalized().toRotationMatrix();
  T.translation() = t;
  return T;
}

double rotation_difference_deg(const Isometry3d& A, const Isometry3d& B) {
  const Eigen::Matrix3d R = A.linear().transpose() * B.linear();
  // Clamp: round-off can push the cosine a hair outside [-1, 1] for identical rotations.
  const double c = std::clamp((R.trace() - 1.0) * 0.5, -1.0, 1.0);
  return std::acos(c) * 180.0 / std::numbers::pi;
}

double translation_difference_m(const Isometry3d& A, const Isometry3d& B) {
  return (A.inverse() * B).translation().norm();
}

}  // namespace locard
