// Closed-form Kabsch/Umeyama: exact recovery of known motions (tiny, large, exactly 180
// degrees), far from the origin, with weights, mirrored and degenerate inputs.
#include <locard/registration/rigid_transform.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <stdexcept>
#include <vector>

namespace locard {
namespace {

MATCHER(IsRotation, "is an orthonormal matrix with determinant +1") {
  const Eigen::Matrix3d R = arg;
  const double err = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  *result_listener << "|R^T R - I| = " << err << ", det = " << R.determinant();
  return err < 1e-12 && std::abs(R.determinant() - 1.0) < 1e-12;
}

MATCHER_P3(IsNearPose, expected, max_deg, max_m,
           "is within " + ::testing::PrintToString(max_deg) + " deg and " +
               ::testing::PrintToString(max_m) + " m of the expected pose") {
  const double dr = rotation_difference_deg(expected, arg);
  const double dt = translation_difference_m(expected, arg);
  *result_listener << "rotation error " << dr << " deg, translation error " << dt << " m";
  return dr <= max_deg && dt <= max_m;
}

Isometry3d motion(double angle_rad, const Eigen::Vector3d& axis, const Eigen::Vector3d& t) {
  Isometry3d T = Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle_rad, axis.normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

std::vector<Eigen::Vector3d> random_points(std::mt19937& rng, std::size_t n, double spread,
                                           const Eigen::Vector3d& offset = Eigen::Vector3d::Zero()) {
  std::uniform_real_distribution<double> u(-spread, spread);
  std::vector<Eigen::Vector3d> pts;
  for (std::size_t i = 0; i < n; ++i) pts.push_back(offset + Eigen::Vector3d(u(rng), u(rng), u(rng)));
  return pts;
}

std::vector<Eigen::Vector3d> apply(const Isometry3d& T, const std::vector<Eigen::Vector3d>& pts) {
  std::vector<Eigen::Vector3d> out;
  for (const auto& p : pts) out.push_back(T * p);
  return out;
}

TEST(RigidTransform, RecoversExactMotionsFromTinyToHalfTurn) {
  std::mt19937 rng(1);
  const auto src = random_points(rng, 50, 1.0);
  const Eigen::Vector3d axis(0.3, -0.5, 0.8);
  for (const double angle : {0.0, 1e-9, 1e-6, 0.1, 1.0, 3.0, double(EIGEN_PI) - 1e-7, double(EIGEN_PI)}) {
    const Isometry3d truth = motion(angle, axis, Eigen::Vector3d(0.5, -2.0, 3.0));
    const auto T = estimate_rigid_transform(src, apply(truth, src));
    ASSERT_TRUE(T.has_value()) << angle;
    EXPECT_THAT(T->linear(), IsRotation());
    EXPECT_THAT(*T, IsNearPose(truth, 1e-5, 1e-9)) << "angle " << angle;
    EXPECT_LT((T->matrix() - truth.matrix()).cwiseAbs().maxCoeff(), 1e-12) << angle;
  }
}

TEST(RigidTransform, InverseIsRecoveredBySwappingRoles) {
  std::mt19937 rng(2);
  const auto src = random_points(rng, 20, 0.5);
  const Isometry3d truth = motion(2.5, Eigen::Vector3d(1, 1, 0), Eigen::Vector3d(0.1, 0.2, 0.3));
  const auto dst = apply(truth, src);
  const auto forward = estimate_rigid_transform(src, dst);
  const auto inverse = estimate_rigid_transform(dst, src);
  ASSERT_TRUE(forward && inverse);
  EXPECT_LT((forward->matrix() * inverse->matrix() - Eigen::Matrix4d::Identity())
                .cwiseAbs()
                .maxCoeff(),
            1e-12);
}

// Two passes keep full precision 1000 km from the origin (survey coordinates).
TEST(RigidTransform, FarFromOriginKeepsPrecision) {
  std::mt19937 rng(3);
  const Eigen::Vector3d offset(1e6, -2e6, 5e5);
  const auto src = random_points(rng, 100, 2.0, offset);
  const Isometry3d truth = motion(0.3, Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1.0, 2.0, 0.5));
  const auto T = estimate_rigid_transform(src, apply(truth, src));
  ASSERT_TRUE(T.has_value());
  // Judged where the points are: coordinates of 1e6 m carry 1e-10 m of rounding, and a
  // 1e-11 rad rotation difference reads as 2e-5 m of translation at the origin, 2e6 m away.
  double worst = 0.0;
  for (const auto& p : src) worst = std::max(worst, (*T * p - truth * p).norm());
  EXPECT_LT(worst, 1e-8);
  EXPECT_THAT(T->linear(), IsRotation());
}

TEST(RigidTransform, NoisyPointsGiveTheLeastSquaresMotion) {
  std::mt19937 rng(4);
  std::normal_distribution<double> noise(0.0, 0.001);
  const auto src = random_points(rng, 2000, 1.0);
  const Isometry3d truth = motion(0.7, Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(0.3, 0, -1));
  auto dst = apply(truth, src);
  for (auto& p : dst) p += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  const auto T = estimate_rigid_transform(src, dst);
  ASSERT_TRUE(T.has_value());
  // 1 mm noise over 2000 points: the estimate is good to a few hundredths of a millimetre.
  EXPECT_THAT(*T, IsNearPose(truth, 0.005, 1e-4));
}

TEST(RigidTransform, ZeroWeightsIgnoreOutliers) {
  std::mt19937 rng(5);
  const auto src = random_points(rng, 40, 1.0);
  const Isometry3d truth = motion(1.2, Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(3, 2, 1));
  auto dst = apply(truth, src);
  std::vector<double> w(src.size(), 1.0);
  for (std::size_t i = 0; i < src.size(); i += 4) {
    dst[i] += Eigen::Vector3d(5, -5, 5);  // gross outlier...
    w[i] = 0.0;                           // ...given no weight
  }
  const auto T = estimate_rigid_transform(src, dst, w);
  ASSERT_TRUE(T.has_value());
  EXPECT_THAT(*T, IsNearPose(truth, 1e-5, 1e-9));
}

// A mirrored point set has a best fit with det = -1; Umeyama's S matrix keeps it a rotation.
TEST(RigidTransform, MirroredInputStillGivesARotation) {
  std::mt19937 rng(6);
  const auto src = random_points(rng, 30, 1.0);
  std::vector<Eigen::Vector3d> mirrored;
  for (const auto& p : src) mirrored.emplace_back(-p.x(), p.y(), p.z());
  const auto T = estimate_rigid_transform(src, mirrored);
  ASSERT_TRUE(T.has_value());
  EXPECT_THAT(T->linear(), IsRotation());
}

TEST(RigidTransform, DegenerateInputHasNoSolution) {
  // Fewer than three pairs.
  const std::vector<Eigen::Vector3d> two{{0, 0, 0}, {1, 0, 0}};
  EXPECT_FALSE(estimate_rigid_transform(two, two).has_value());
  // Collinear points: the rotation about the line is free.
  std::vector<Eigen::Vector3d> line;
  for (int i = 0; i < 10; ++i) line.emplace_back(0.1 * i, 0.2 * i, -0.1 * i);
  EXPECT_FALSE(estimate_rigid_transform(line, line).has_value());
  // Identical points.
  const std::vector<Eigen::Vector3d> same(5, Eigen::Vector3d(1, 2, 3));
  EXPECT_FALSE(estimate_rigid_transform(same, same).has_value());
  // All weights zero.
  std::mt19937 rng(7);
  const auto src = random_points(rng, 5, 1.0);
  const std::vector<double> zero(5, 0.0);
  EXPECT_FALSE(estimate_rigid_transform(src, src, zero).has_value());
  // Three non-collinear points are enough.
  const std::vector<Eigen::Vector3d> tri{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_TRUE(estimate_rigid_transform(tri, tri).has_value());
}

TEST(RigidTransform, MismatchedSizesThrow) {
  const std::vector<Eigen::Vector3d> a(4, Eigen::Vector3d::Zero()), b(3, Eigen::Vector3d::Zero());
  EXPECT_THROW(estimate_rigid_transform(a, b), std::invalid_argument);
  const std::vector<double> w(2, 1.0);
  EXPECT_THROW(estimate_rigid_transform(a, a, w), std::invalid_argument);
}

TEST(RigidTransform, AccumulatorMatchesTwoPassAndMerges) {
  std::mt19937 rng(8);
  const auto src = random_points(rng, 200, 1.0);
  const Isometry3d truth = motion(0.4, Eigen::Vector3d(1, 0, 1), Eigen::Vector3d(0.2, 0.1, 0));
  std::normal_distribution<double> noise(0.0, 0.01);
  auto dst = apply(truth, src);
  for (auto& p : dst) p += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  std::vector<double> w;
  std::uniform_real_distribution<double> u(0.1, 2.0);
  for (std::size_t i = 0; i < src.size(); ++i) w.push_back(u(rng));

  RigidTransformAccumulator all, first, second;
  for (std::size_t i = 0; i < src.size(); ++i) {
    all.add(src[i], dst[i], w[i]);
    (i < 77 ? first : second).add(src[i], dst[i], w[i]);
  }
  first.merge(second);
  EXPECT_EQ(all.count(), src.size());
  EXPECT_EQ(first.count(), src.size());
  const auto two_pass = estimate_rigid_transform(src, dst, w);
  const auto one_pass = all.solve();
  const auto merged = first.solve();
  ASSERT_TRUE(two_pass && one_pass && merged);
  EXPECT_LT((two_pass->matrix() - one_pass->matrix()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((two_pass->matrix() - merged->matrix()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_FALSE(RigidTransformAccumulator().solve().has_value());
}

}  // namespace
}  // namespace locard
