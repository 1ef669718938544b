// The tripod fit against rotations made by a tripod of known pan axis and pitch rings, with
// tracking noise and a few views given the errors tracking makes (roll about a wall's normal,
// a tilt): the axis comes back, the good views lie on their rings, the wrong ones stand off by
// their error. Hand-held rotations are no tripod.
#include "alignment/tripod_fit.hpp"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <random>
#include <set>

namespace locard::alignment_detail {
namespace {

constexpr double kDeg = M_PI / 180.0;

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) / kDeg;
}

Eigen::Matrix3d rot(const Eigen::Vector3d& axis, double deg) {
  return Eigen::AngleAxisd(deg * kDeg, axis.normalized()).toRotationMatrix();
}

struct Tripod {
  Eigen::Vector3d axis = Eigen::Vector3d(0.05, -0.03, 1.0).normalized();  // not levelled
  std::vector<Eigen::Matrix3d> R;
  std::vector<int> ring;
};

// Camera: z forward, y down; at pan 0 and pitch 0 it looks along world x with y = -axis.
Tripod make_tripod(const std::vector<double>& pitches, int views, double noise_deg,
                   std::mt19937& rng) {
  Tripod t;
  const Eigen::Vector3d side = t.axis.cross(Eigen::Vector3d::UnitX()).normalized();
  const Eigen::Vector3d ahead = side.cross(t.axis);
  Eigen::Matrix3d base;
  base.col(2) = ahead;
  base.col(1) = -t.axis;
  base.col(0) = base.col(1).cross(base.col(2));
  std::normal_distribution<double> n(0.0, noise_deg), pan_jitter(0.0, 1.5);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (std::size_t r = 0; r < pitches.size(); ++r)
    for (int k = 0; k < views; ++k) {
      const double pan = 360.0 * k / views + pan_jitter(rng);
      // Pitch about the camera's own x axis (tilting the head), then pan about the axis.
      Eigen::Matrix3d R = rot(t.axis, pan) * base * rot(Eigen::Vector3d::UnitX(), -pitches[r]);
      const Eigen::Vector3d noise_axis(unit(rng), unit(rng), unit(rng) + 2.0);
      R = rot(noise_axis, std::abs(n(rng))) * R;  // tracking noise
      t.R.push_back(R);
      t.ring.push_back(static_cast<int>(r));
    }
  return t;
}

TEST(TripodFit, FindsThePanAxisAndTheViewsTrackedOffIt) {
  std::mt19937 rng(7);
  Tripod t = make_tripod({-20.0, 12.0, 40.0}, 36, 0.03, rng);
  // Wrong views: rolled about their optical axis (a wall faced square on) by 2-4 degrees, and
  // tilted about their horizontal axis by 1.5 degrees.
  const std::set<std::size_t> rolled{9, 10, 11, 12, 50}, tilted{70, 100};
  for (std::size_t i : rolled) t.R[i] = t.R[i] * rot(Eigen::Vector3d::UnitZ(), 2.0 + 0.4 * (i % 5));
  for (std::size_t i : tilted) t.R[i] = t.R[i] * rot(Eigen::Vector3d::UnitX(), 1.5);
  const auto fit = fit_tripod(t.R);
  ASSERT_TRUE(fit);
  EXPECT_LT(angle_deg(fit->axis, t.axis), 0.05);
  ASSERT_EQ(fit->ring_axes.size(), 3u);
  for (std::size_t i = 0; i < t.R.size(); ++i) {
    if (rolled.count(i) || tilted.count(i)) {
      EXPECT_GT(fit->off_axis_deg[i], 1.3) << "view " << i;
    } else {
      EXPECT_LT(fit->off_axis_deg[i], 0.2) << "view " << i;
    }
  }
  // Views of one true ring share one fitted ring, and rings differ.
  for (std::size_t i = 1; i < t.R.size(); ++i)
    if (t.ring[i] == t.ring[i - 1] && !rolled.count(i) && !rolled.count(i - 1)) {
      EXPECT_EQ(fit->ring[i], fit->ring[i - 1]) << "view " << i;
    }
  EXPECT_NE(fit->ring[0], fit->ring[36]);
  EXPECT_NE(fit->ring[36], fit->ring[72]);
}

TEST(TripodFit, ProjectingOntoTheRingLeavesOnlyATurnAboutThePanAxis) {
  std::mt19937 rng(3);
  const Tripod t = make_tripod({-15.0}, 30, 0.0, rng);
  const auto fit = fit_tripod(t.R);
  ASSERT_TRUE(fit);
  const Eigen::Matrix3d wrong = t.R[5] * rot(Eigen::Vector3d::UnitZ(), 3.0);
  const Eigen::Matrix3d back = onto_ring(wrong, fit->axis, fit->ring_axes[0]);
  // What is left is a turn about the pan axis (the roll's share along it, 3 sin 15 deg): the
  // pan that registration then fixes.
  const Eigen::AngleAxisd left(t.R[5] * back.transpose());
  EXPECT_NEAR(left.angle() / kDeg, 3.0 * std::sin(15.0 * kDeg), 0.05);
  EXPECT_LT(angle_deg(left.axis(), left.axis().dot(t.axis) > 0 ? t.axis : -t.axis), 0.5);
  EXPECT_LT(angle_deg(back.transpose() * fit->axis, fit->ring_axes[0]), 1e-6);
}

TEST(TripodFit, HandHeldRotationsAreNoTripod) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<Eigen::Matrix3d> R{Eigen::Matrix3d::Identity()};
  for (int i = 1; i < 60; ++i) {
    const Eigen::Vector3d w(6.0 * unit(rng), 6.0 * unit(rng), 6.0 * unit(rng) + 0.1);
    R.push_back(rot(w, w.norm()) * R.back());
  }
  EXPECT_FALSE(fit_tripod(R));
}

// Camera centres on a head with a nodal offset, some wandering off it (a view slid along a
// wall): the model comes back from the rest and the wanderers stand off it by their slide.
TEST(TripodFit, NodalModelFindsTheCentresThatLeftTheHead) {
  std::mt19937 rng(5);
  const Tripod t = make_tripod({-20.0, 15.0}, 30, 0.02, rng);
  const Eigen::Vector3d pivot(0.4, -1.1, 1.3), offset(0.03, -0.02, 0.07);
  std::normal_distribution<double> play(0.0, 0.002);
  std::vector<Eigen::Isometry3d> T;
  for (const Eigen::Matrix3d& R : t.R) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = R;
    pose.translation() = pivot + R * offset + Eigen::Vector3d(play(rng), play(rng), play(rng));
    T.push_back(pose);
  }
  const std::set<std::size_t> slid{4, 5, 6, 40};
  for (std::size_t i : slid) T[i].translation() += Eigen::Vector3d(0.06, 0.03, 0.0);
  const NodalFit nodal = fit_nodal(T);
  for (std::size_t i = 0; i < T.size(); ++i) {
    if (slid.count(i)) {
      EXPECT_GT(nodal.residual_m[i], 0.05) << "view " << i;
    } else {
      EXPECT_LT(nodal.residual_m[i], 0.01) << "view " << i;
    }
  }
  // Off the pan axis the pivot is fixed; along it only the centre's height is.
  const Eigen::Vector3d across = (nodal.pivot - pivot) - (nodal.pivot - pivot).dot(t.axis) * t.axis;
  EXPECT_LT(across.norm(), 0.005);
  const auto off = views_off_tripod(T, 0.5, 0.02);
  ASSERT_TRUE(off);
  EXPECT_EQ(*off, slid.size());
  const auto which = which_views_off_tripod(T, 0.5, 0.02);
  ASSERT_TRUE(which);
  for (std::size_t i = 0; i < T.size(); ++i) EXPECT_EQ((*which)[i], slid.count(i)) << "view " << i;
}

// A turn whose tracking left two arcs elsewhere, 0.5 and 0.7 m off, the true centre holding
// fewer than half the views: the views that stand together are the largest arc, exactly.
TEST(TripodFit, DensestCentresAreTheLargestArcWithoutAMajority) {
  std::mt19937 rng(8);
  const Tripod t = make_tripod({0.0}, 40, 0.02, rng);
  const Eigen::Vector3d pivot(1.0, 2.0, 1.4), offset(0.0, 0.0, 0.08);
  std::vector<Eigen::Isometry3d> T;
  for (std::size_t i = 0; i < t.R.size(); ++i) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = t.R[i];
    pose.translation() = pivot + t.R[i] * offset;
    if (i >= 16 && i < 28) pose.translation() += Eigen::Vector3d(0.5, 0.0, 0.0);
    if (i >= 28) pose.translation() += Eigen::Vector3d(0.0, 0.7, 0.0);
    T.push_back(pose);
  }
  std::vector<std::size_t> largest(16);
  std::iota(largest.begin(), largest.end(), 0);
  EXPECT_EQ(densest_centres(T, 0.25), largest);
  EXPECT_EQ(densest_centres(T, 2.0).size(), T.size());  // one turn at a radius that takes all
}

TEST(TripodFit, NoTurnNoFit) {
  std::vector<Eigen::Matrix3d> R(20, Eigen::Matrix3d::Identity());
  EXPECT_FALSE(fit_tripod(R));
}

}  // namespace
}  // namespace locard::alignment_detail
