// A pitch ring corrected as a whole against the rings scanned before it (tripod_hold.cpp).
//
// A ring enters through its first view, whose tilt only the band it shares with the ring below
// fixes, and every later view follows it through the model: the whole ring can stand a degree
// off in pitch or roll - an error that is the SAME in every view's camera frame (R_i E), which
// no rigid move of the ring's cloud undoes - and be turned or shifted as a block (C). As a
// whole the ring sees the shared band all round the room, which fixes both. Unknowns: E (camera
// frame, 3), and C = (R_C, tau) about the tripod's centre c (6):
//   x_ik = R_C (R_i E p_k + t_i - c) + c + tau,   r_ik = n_k^T (x_ik - q_k)
// with q_k, n_k the nearest point of the earlier rings' model and its normal. At E = R_C = I:
//   dr/d(omega_E) = p_k x (R_i^T n_k),  dr/d(omega_C) = (x_ik - c) x n_k,  dr/d(tau) = n_k.
// E's turn about the ring's pan axis and C's turn about the tripod's are the same motion, and
// walls let the ring slide vertically: a small damping fixes the first, a prior holding tau
// to zero (as sure as the data, per point) the second. Gauss-Newton, correspondences gated at
// 2 voxels and then 1, re-found each iteration; each view's pose is then
//   R_i' = R_C R_i E,   t_i' = R_C (t_i - c) + c + tau.
#include "alignment/ring_alignment.hpp"

#include <locard/core/kdtree.hpp>
#include <locard/preprocess/voxel_grid.hpp>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include <cmath>

namespace locard::alignment_detail {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr int kIterations = 15;
constexpr double kDamping = 1e-3;  // relative to the mean diagonal

struct RingPoint {
  Eigen::Vector3d p;  // camera frame
  std::size_t view;   // position in the ring
};

Eigen::Matrix3d exp_so3(const Eigen::Vector3d& w) {
  const double a = w.norm();
  return a < 1e-12 ? Eigen::Matrix3d::Identity()
                   : Eigen::AngleAxisd(a, w / a).toRotationMatrix();
}

}  // namespace

std::optional<RingCorrection> align_ring(const AlignmentState& s,
                                         const std::vector<std::size_t>& ring,
                                         const std::vector<std::size_t>& before,
                                         const Eigen::Vector3d& centre) {
  const double v = s.options.voxel_size;
  PointCloud model_all;
  for (std::size_t f : before) model_all.append(transformed(s.prepared[f].cloud, s.tracked_pose(f)));
  const PointCloud model = voxel_down_sample(model_all, static_cast<float>(v)).cloud;
  if (model.size() < 100 || !model.has_normals()) return std::nullopt;
  const KdTree tree(model.positions);

  std::vector<RingPoint> points;
  std::vector<Isometry3d> T;
  for (std::size_t k = 0; k < ring.size(); ++k) {
    T.push_back(s.tracked_pose(ring[k]));
    for (const Eigen::Vector3f& p : s.prepared[ring[k]].coarse.positions)
      points.push_back({p.cast<double>(), k});
  }
  Eigen::Matrix3d E = Eigen::Matrix3d::Identity(), R_C = Eigen::Matrix3d::Identity();
  Eigen::Vector3d tau = Eigen::Vector3d::Zero();
  RingCorrection out;
  for (int iteration = 0; iteration < kIterations; ++iteration) {
    const double gate = (iteration < kIterations / 2 ? 2.0 : 1.0) * v;
    Eigen::Matrix<double, 9, 9> H = Eigen::Matrix<double, 9, 9>::Zero();
    Eigen::Matrix<double, 9, 1> b = Eigen::Matrix<double, 9, 1>::Zero();
    std::size_t used = 0;
    double squared = 0.0;
    for (const RingPoint& rp : points) {
      const Isometry3d& Ti = T[rp.view];
      const Eigen::Matrix3d Ri = R_C * Ti.linear() * E;
      const Eigen::Vector3d x = Ri * rp.p + R_C * (Ti.translation() - centre) + centre + tau;
      Neighbor nb;
      if (!tree.nearest(x.cast<float>(), nb, static_cast<float>(gate))) continue;
      const Eigen::Vector3d q = model.positions[nb.index].cast<double>();
      const Eigen::Vector3d n = model.normals[nb.index].cast<double>();
      const double r = n.dot(x - q);
      Eigen::Matrix<double, 9, 1> J;
      // E acts in the camera frame of the current (corrected) rotation.
      J << rp.p.cross(Ri.transpose() * n), (x - centre - tau).cross(n), n;
      H += J * J.transpose();
      b += J * r;
      squared += r * r;
      ++used;
    }
    if (used < 100) return std::nullopt;
    out.correspondences = used;
    out.rmse = std::sqrt(squared / static_cast<double>(used));
    const double mean_diagonal = H.trace() / 9.0;
    H.diagonal().array() += kDamping * mean_diagonal;
    // tau held to zero as firmly as the data, per point: (point sigma / centre sigma)^2 each.
    H.bottomRightCorner<3, 3>().diagonal().array() += static_cast<double>(used) * 0.1;
    b.tail<3>() += static_cast<double>(used) * 0.1 * tau;
    const Eigen::Matrix<double, 9, 1> step = -H.ldlt().solve(b);
    if (!step.allFinite()) return std::nullopt;
    E = E * exp_so3(step.head<3>());
    R_C = exp_so3(step.segment<3>(3)) * R_C;
    tau += step.tail<3>();
    if (step.head<6>().norm() < 1e-5 && step.tail<3>().norm() < 1e-5) break;
  }
  out.E = E;
  out.R_C = R_C;
  out.tau = tau;
  out.E_deg = Eigen::AngleAxisd(E).angle() / kDeg;
  out.C_deg = Eigen::AngleAxisd(R_C).angle() / kDeg;
  return out;
}

Isometry3d RingCorrection::apply(const Isometry3d& T, const Eigen::Vector3d& centre) const {
  Isometry3d out;
  out.linear() = R_C * T.linear() * E;
  out.translation() = R_C * (T.translation() - centre) + centre + tau;
  return out;
}

}  // namespace locard::alignment_detail
