// RANSAC over correspondences on synthetic matches with a known answer: most matches wrong,
// large rotations, far from the origin; identical results for identical seeds whatever the
// thread count; clear failures and errors for bad input.
#include <locard/core/error.hpp>
#include <locard/registration/ransac.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <limits>
#include <random>

namespace locard {
namespace {

using ::testing::HasSubstr;

MATCHER_P3(IsNearPose, expected, max_deg, max_m,
           "is within " + ::testing::PrintToString(max_deg) + " deg and " +
               ::testing::PrintToString(max_m) + " m of the expected pose") {
  const double dr = rotation_difference_deg(expected, arg);
  const double dt = translation_difference_m(expected, arg);
  *result_listener << "rotation error " << dr << " deg, translation error " << dt << " m";
  return dr <= max_deg && dt <= max_m;
}

struct Problem {
  PointCloud source, target;
  std::vector<Correspondence> matches;
  Isometry3d T_target_source = Isometry3d::Identity();
};

// `n` source points in a 1 m cube around `centre`; the target is T * source plus 1 mm noise;
// a fraction `inliers` of the matches pair a point with its image, the rest with a random
// target point (as wrong descriptor matches do).
Problem make_problem(std::uint32_t seed, std::size_t n, double inliers, const Isometry3d& T,
                     const Eigen::Vector3d& centre = Eigen::Vector3d::Zero()) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.5, 0.5), coin(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.001);
  std::uniform_int_distribution<std::uint32_t> pick(0, static_cast<std::uint32_t>(n - 1));
  Problem p;
  p.T_target_source = T;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d s = centre + Eigen::Vector3d(u(rng), u(rng), u(rng));
    p.source.positions.push_back(s.cast<float>());
    p.target.positions.push_back(
        (T * s + Eigen::Vector3d(noise(rng), noise(rng), noise(rng))).cast<float>());
  }
  for (std::uint32_t i = 0; i < n; ++i)
    p.matches.push_back({i, coin(rng) < inliers ? i : pick(rng), 0.f});
  return p;
}

Isometry3d motion(double deg, const Eigen::Vector3d& axis, const Eigen::Vector3d& t) {
  Isometry3d T = Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(deg * EIGEN_PI / 180.0, axis.normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

RansacOptions options(std::uint64_t seed = 0) {
  RansacOptions o;
  o.max_correspondence_distance = 0.01;
  o.seed = seed;
  return o;
}

TEST(Ransac, RecoversTheMotionWithMostMatchesWrong) {
  for (const double inliers : {0.5, 0.2, 0.1}) {
    const Problem p = make_problem(1, 1000, inliers,
                                   motion(40, Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(0.3, -0.2, 1)));
    const RansacResult r = ransac_registration(p.source, p.target, p.matches, options());
    EXPECT_TRUE(r.success) << r.reason;
    EXPECT_THAT(r.T_target_source, IsNearPose(p.T_target_source, 0.1, 0.001)) << inliers;
    EXPECT_NEAR(r.inlier_ratio, inliers, 0.05);
    EXPECT_EQ(r.correspondences, 1000u);
    // Cloud fitness: every source point has its image in the target.
    EXPECT_GT(r.fitness, 0.99);
    EXPECT_LT(r.inlier_rmse, 0.003);
    // Early termination: far fewer hypotheses than the 100000 allowed, more for harder input.
    EXPECT_LT(r.hypotheses, 100000u);
    EXPECT_GE(r.hypotheses, kRansacFirstBlock);
    EXPECT_LE(r.hypotheses_checked, r.hypotheses);
  }
}

// Large rotations (180 degrees included) 10 km from the origin: centred double arithmetic.
TEST(Ransac, LargeRotationsFarFromTheOrigin) {
  const Eigen::Vector3d far(1e4, -5e3, 200.0);
  for (const double deg : {90.0, 179.0, 180.0}) {
    // A rotation about the cloud's own centre, as a scanner turned on the spot.
    Isometry3d local = motion(deg, Eigen::Vector3d(0.2, 1, -0.3), Eigen::Vector3d(0.5, 0, 0));
    Isometry3d at = Isometry3d::Identity();
    at.translation() = far;
    const Isometry3d T = at * local * at.inverse();
    const Problem p = make_problem(2, 800, 0.3, T, far);
    const RansacResult r = ransac_registration(p.source, p.target, p.matches, options());
    EXPECT_TRUE(r.success) << r.reason;
    // Compared at the cloud (the world origin is 11 km away, a lever that turns 1e-6 rad into
    // a centimetre): float positions there are good to about 1 mm.
    EXPECT_THAT(at.inverse() * r.T_target_source * at, IsNearPose(local, 0.2, 0.003)) << deg;
  }
}

// Same seed, same result bit for bit: repeated, and with 1, 2 or 8 threads.
TEST(Ransac, IdenticalForIdenticalSeedsAndAnyThreadCount) {
  const Problem p = make_problem(3, 2000, 0.15,
                                 motion(70, Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1, 0, 0)));
  const auto run = [&](std::uint64_t seed, int threads) {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    return ransac_registration(p.source, p.target, p.matches, options(seed));
  };
  const RansacResult reference = run(42, 1);
  ASSERT_TRUE(reference.success) << reference.reason;
  for (const int threads : {1, 2, 8}) {
    const RansacResult r = run(42, threads);
    EXPECT_EQ(r.T_target_source.matrix(), reference.T_target_source.matrix()) << threads;
    EXPECT_EQ(r.hypotheses, reference.hypotheses);
    EXPECT_EQ(r.hypotheses_checked, reference.hypotheses_checked);
    EXPECT_EQ(r.best_hypothesis, reference.best_hypothesis);
    EXPECT_EQ(r.inlier_correspondences, reference.inlier_correspondences);
    EXPECT_EQ(r.fitness, reference.fitness);
    EXPECT_EQ(r.seed, 42u);
  }
  // Another seed draws other samples but finds the same answer.
  const RansacResult other = run(7, 2);
  EXPECT_TRUE(other.success);
  EXPECT_NE(other.best_hypothesis, reference.best_hypothesis);
  EXPECT_THAT(other.T_target_source, IsNearPose(p.T_target_source, 0.1, 0.001));
}

TEST(Ransac, ConsistentMatchesAreNeededForSuccess) {
  // Every match random: RANSAC fails with a reason instead of returning some transform.
  const Problem noise = make_problem(4, 500, 0.0, motion(30, Eigen::Vector3d(1, 0, 0),
                                                         Eigen::Vector3d::Zero()));
  RansacOptions o = options();
  o.max_iterations = 5000;
  o.min_inliers = 20;
  const RansacResult r = ransac_registration(noise.source, noise.target, noise.matches, o);
  EXPECT_FALSE(r.success);
  EXPECT_THAT(r.reason, HasSubstr("consistent"));
  EXPECT_EQ(r.hypotheses, 5000u);

  // Two matches cannot define a motion.
  const Problem p = make_problem(5, 100, 1.0, Isometry3d::Identity());
  const std::vector<Correspondence> two(p.matches.begin(), p.matches.begin() + 2);
  const RansacResult few = ransac_registration(p.source, p.target, two, options());
  EXPECT_FALSE(few.success);
  EXPECT_THAT(few.reason, HasSubstr("at least 3"));
  const RansacResult none = ransac_registration(p.source, p.target, {}, options());
  EXPECT_FALSE(none.success);

  // Matches that agree but leave the cloud unexplained: min_fitness rejects them.
  RansacOptions strict = options();
  strict.min_fitness = 0.6;
  Problem half = make_problem(6, 400, 1.0, Isometry3d::Identity());
  for (std::size_t i = 0; i < half.target.size(); i += 2)
    half.target.positions[i] += Eigen::Vector3f(0.0f, 0.0f, 5.0f);  // half the scene changed
  std::vector<Correspondence> kept;
  for (const auto& m : half.matches)
    if (m.source % 2 == 1) kept.push_back(m);
  const RansacResult partial = ransac_registration(half.source, half.target, kept, strict);
  EXPECT_FALSE(partial.success);
  EXPECT_THAT(partial.reason, HasSubstr("below min_fitness"));
  EXPECT_NEAR(partial.fitness, 0.5, 0.05);
}

TEST(Ransac, NonFinitePointsAreDroppedAndCounted) {
  Problem p = make_problem(7, 600, 0.4, motion(20, Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(0, 0, 1)));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  p.source.positions[0] = Eigen::Vector3f(nan, 0, 0);
  p.source.positions[1] = Eigen::Vector3f(0, std::numeric_limits<float>::infinity(), 0);
  p.target.positions[5] = Eigen::Vector3f(0, 0, nan);
  std::size_t touching = 0;
  for (const auto& m : p.matches) touching += m.source <= 1 || m.target == 5;
  const RansacResult r = ransac_registration(p.source, p.target, p.matches, options());
  EXPECT_TRUE(r.success) << r.reason;
  EXPECT_EQ(r.source_non_finite, 2u);
  EXPECT_EQ(r.target_non_finite, 1u);
  EXPECT_EQ(r.dropped_correspondences, touching);
  EXPECT_EQ(r.correspondences, p.matches.size() - touching);
  EXPECT_THAT(r.T_target_source, IsNearPose(p.T_target_source, 0.1, 0.001));
}

TEST(Ransac, BadInputIsAnError) {
  const Problem p = make_problem(8, 50, 1.0, Isometry3d::Identity());
  std::vector<Correspondence> bad = p.matches;
  bad[3].target = 50;  // one past the end
  try {
    ransac_registration(p.source, p.target, bad, options());
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("correspondence 3"));
  }
  PointCloud tiny;
  tiny.positions = {{0, 0, 0}, {1, 0, 0}};
  EXPECT_THROW(ransac_registration(tiny, p.target, {}, options()), InputError);
  EXPECT_THROW(ransac_registration(p.source, PointCloud{}, {}, options()), InputError);
  RansacOptions o = options();
  o.max_correspondence_distance = 0.0;
  EXPECT_THROW(ransac_registration(p.source, p.target, p.matches, o), InputError);
  o = options();
  o.edge_length_ratio = 1.5;
  EXPECT_THROW(ransac_registration(p.source, p.target, p.matches, o), InputError);
  o = options();
  o.confidence = 0.0;
  EXPECT_THROW(ransac_registration(p.source, p.target, p.matches, o), InputError);
}

}  // namespace
}  // namespace locard
