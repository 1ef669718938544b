// ATE / RPE against hand-computed values and the TUM fr1_xyz ground truth.
#include <locard/alignment/trajectory_eval.hpp>

#include <locard/core/error.hpp>
#include <locard/io/trajectory_io.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>

namespace locard {
namespace {

StampedPose at(double t, const Eigen::Vector3d& p, std::int64_t index = -1) {
  StampedPose s;
  s.timestamp = t;
  s.frame_index = index;
  s.T_world_camera.translation() = p;
  return s;
}

// Square of side 2 in the z = 0 plane; the estimate is the square scaled by 1.1 and shifted by
// 5 m. By symmetry the best rigid alignment undoes only the shift, and every corner is then
// |(0.1, 0.1)| = sqrt(0.02) m off.
TEST(TrajectoryEval, HandComputedAteOnScaledSquare) {
  const Eigen::Vector3d corners[4] = {{1, 1, 0}, {-1, 1, 0}, {-1, -1, 0}, {1, -1, 0}};
  Trajectory gt, est;
  for (int i = 0; i < 4; ++i) {
    gt.push_back(at(i, corners[i]));
    est.push_back(at(i + 0.01, 1.1 * corners[i] + Eigen::Vector3d(5, 0, 0)));
  }
  const AteResult r = absolute_trajectory_error(gt, est);
  EXPECT_EQ(r.pairs, 4u);
  EXPECT_NEAR(r.translation.rmse, std::sqrt(0.02), 1e-12);
  EXPECT_NEAR(r.translation.mean, std::sqrt(0.02), 1e-12);
  EXPECT_NEAR(r.translation.std_dev, 0.0, 1e-12);
  EXPECT_NEAR((r.T_groundtruth_estimate.translation() - Eigen::Vector3d(-5, 0, 0)).norm(), 0.0,
              1e-12);
  EXPECT_NEAR(rotation_difference_deg(r.T_groundtruth_estimate, Isometry3d::Identity()), 0.0,
              1e-9);
  // Without alignment the shift counts: corners (1,1) -> (6.1,1.1): |(5.1, 0.1)|, etc.
  const AteResult raw = absolute_trajectory_error(gt, est, {}, false);
  double sum = 0.0;
  for (int i = 0; i < 4; ++i)
    sum += (corners[i] - (1.1 * corners[i] + Eigen::Vector3d(5, 0, 0))).squaredNorm();
  EXPECT_NEAR(raw.translation.rmse, std::sqrt(sum / 4.0), 1e-12);
}

TEST(TrajectoryEval, HandComputedRpe) {
  Trajectory gt, est;
  for (int i = 0; i < 6; ++i) {
    gt.push_back(at(i, Eigen::Vector3d(i, 0, 0)));
    est.push_back(at(i, Eigen::Vector3d(1.1 * i, 0, 0)));
  }
  // Every step: est moves 1.1, gt 1.0: E = (est_k^-1 est_l)(gt_k^-1 gt_l)^-1 = 0.1 m.
  const RpeResult one = relative_pose_error(gt, est);
  EXPECT_EQ(one.pairs, 5u);
  EXPECT_NEAR(one.translation.rmse, 0.1, 1e-12);
  EXPECT_NEAR(one.rotation_deg.max, 0.0, 1e-9);
  const RpeResult two = relative_pose_error(gt, est, {}, {2.0, DeltaUnit::Frames});
  EXPECT_EQ(two.pairs, 4u);
  EXPECT_NEAR(two.translation.rmse, 0.2, 1e-12);
  const RpeResult secs = relative_pose_error(gt, est, {}, {3.0, DeltaUnit::Seconds});
  EXPECT_EQ(secs.pairs, 3u);
  EXPECT_NEAR(secs.translation.mean, 0.3, 1e-12);
  // A rotation error: the estimate turns 2 degrees more per step about z at the origin.
  Trajectory rot_est = gt;
  for (int i = 0; i < 6; ++i)
    rot_est[i].T_world_camera.linear() =
        Eigen::AngleAxisd(i * 2.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const RpeResult rr = relative_pose_error(gt, rot_est);
  EXPECT_NEAR(rr.rotation_deg.rmse, 2.0, 1e-9);
}

TEST(TrajectoryEval, AssociationIsGreedyByTimeDifference) {
  Trajectory gt{at(0.00, {0, 0, 0}), at(0.03, {1, 0, 0}), at(0.06, {2, 0, 0})};
  // 0.015 is 0.015 from gt 0.00 and 0.015 from gt 0.03; 0.031 is closer to 0.03 and takes it.
  Trajectory est{at(0.015, {0, 0, 0}), at(0.031, {1, 0, 0}), at(0.2, {9, 9, 9})};
  const auto pairs = associate_trajectories(gt, est);
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0].ground_truth, 0u);
  EXPECT_EQ(pairs[0].estimate, 0u);
  EXPECT_EQ(pairs[1].ground_truth, 1u);
  EXPECT_EQ(pairs[1].estimate, 1u);
  AssociationOptions by_index;
  by_index.match_by_frame_index = true;
  Trajectory a{at(0, {0, 0, 0}, 10), at(1, {0, 0, 0}, 20)};
  Trajectory b{at(7, {0, 0, 0}, 20), at(8, {0, 0, 0}, 30)};
  const auto ip = associate_trajectories(a, b, by_index);
  ASSERT_EQ(ip.size(), 1u);
  EXPECT_EQ(ip[0].ground_truth, 1u);
  EXPECT_EQ(ip[0].estimate, 0u);
}

// The TUM fr1_xyz ground truth against itself moved by a known rigid transform: after the
// alignment the ATE is zero (to rounding) and the alignment is the inverse of the motion.
TEST(TrajectoryEval, TumFr1XyzAgainstRigidlyMovedSelf) {
  const auto path = test::shared_data() / "tum-fr1-xyz-metadata" / "groundtruth.txt";
  const Trajectory gt = read_tum_trajectory(path);
  ASSERT_EQ(gt.size(), 3000u);
  Isometry3d S = Isometry3d::Identity();
  S.linear() = Eigen::AngleAxisd(1.2, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  S.translation() = Eigen::Vector3d(3.0, -7.5, 1.25);
  Trajectory est = gt;
  for (auto& p : est) p.T_world_camera = S * p.T_world_camera;
  const AteResult r = absolute_trajectory_error(gt, est);
  EXPECT_EQ(r.pairs, gt.size());
  EXPECT_LT(r.translation.rmse, 1e-9);
  EXPECT_LT(translation_difference_m(r.T_groundtruth_estimate, S.inverse()), 1e-9);
  EXPECT_LT(rotation_difference_deg(r.T_groundtruth_estimate, S.inverse()), 1e-5);
  const RpeResult rpe = relative_pose_error(gt, est, {}, {1.0, DeltaUnit::Seconds});
  EXPECT_GT(rpe.pairs, 2800u);  // the last second has no partner
  EXPECT_LT(rpe.translation.max, 1e-9);
  EXPECT_LT(rpe.rotation_deg.max, 1e-5);
  // A 2 mm shift of every estimate along x after the motion is absorbed by the alignment too;
  // a per-pose alternating 2 mm error is not, and shows up as exactly 2 mm.
  for (std::size_t i = 0; i < est.size(); ++i)
    est[i].T_world_camera.translation() +=
        S.linear() * Eigen::Vector3d(0, 0, i % 2 ? 0.002 : -0.002);
  const AteResult noisy = absolute_trajectory_error(gt, est);
  EXPECT_NEAR(noisy.translation.rmse, 0.002, 2e-5);
}

TEST(TrajectoryEval, TooFewPairsOrCollinearIsAnInputError) {
  Trajectory gt{at(0, {0, 0, 0}), at(1, {1, 0, 0})};
  EXPECT_THROW(absolute_trajectory_error(gt, gt), InputError);
  Trajectory line{at(0, {0, 0, 0}), at(1, {1, 0, 0}), at(2, {2, 0, 0}), at(3, {3, 0, 0})};
  EXPECT_THROW(absolute_trajectory_error(line, line), InputError);
  EXPECT_NO_THROW(absolute_trajectory_error(line, line, {}, false));
  EXPECT_THROW(relative_pose_error(line, line, {}, {10.0, DeltaUnit::Frames}), InputError);
  EXPECT_THROW(relative_pose_error(line, line, {}, {0.0, DeltaUnit::Frames}), InputError);
}

}  // namespace
}  // namespace locard
