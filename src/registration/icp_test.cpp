// ICP on synthetic surfaces with an exact ground truth (small_gicp style: two independent
// samplings of the same surface, a known motion, random perturbations, forward and inverse),
// plus robust kernels, coloured ICP on a textured plane, information matrix against brute
// force, determinism and every bad input of the issue.
#include <locard/core/error.hpp>
#include <locard/registration/icp.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace locard {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using ::testing::HasSubstr;

MATCHER_P3(IsNearPose, expected, max_deg, max_m,
           "is within " + ::testing::PrintToString(max_deg) + " deg and " +
               ::testing::PrintToString(max_m) + " m of the expected pose") {
  const double dr = rotation_difference_deg(expected, arg);
  const double dt = translation_difference_m(expected, arg);
  *result_listener << "rotation error " << dr << " deg, translation error " << dt << " m";
  return dr <= max_deg && dt <= max_m;
}

// A bumpy height field z = f(x, y) over [-0.5, 0.5]^2 m: curved enough in every direction to
// constrain all six degrees of freedom, with an intensity texture for coloured ICP.
double height(double x, double y) { return 0.08 * std::sin(3 * x) * std::cos(4 * y) + 0.1 * x * y; }
Eigen::Vector3d surface_normal(double x, double y) {
  const double fx = 0.24 * std::cos(3 * x) * std::cos(4 * y) + 0.1 * y;
  const double fy = -0.32 * std::sin(3 * x) * std::sin(4 * y) + 0.1 * x;
  return Eigen::Vector3d(-fx, -fy, 1.0).normalized();
}
std::uint8_t texture(double x, double y) {
  return static_cast<std::uint8_t>(127.5 + 100.0 * std::sin(11 * x + 7 * y));
}

// `n` points sampled uniformly over the surface (independent samplings for source and
// target, as two scans of one scene), expressed in a frame where the surface is at T * p.
PointCloud sample_surface(std::mt19937& rng, std::size_t n, const Isometry3d& T,
                          bool normals = true, bool colors = true) {
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    const double x = u(rng), y = u(rng);
    c.positions.push_back((T * Eigen::Vector3d(x, y, height(x, y))).cast<float>());
    if (normals) c.normals.push_back((T.linear() * surface_normal(x, y)).cast<float>());
    if (colors) {
      const std::uint8_t g = texture(x, y);
      c.colors.push_back({g, g, g});
    }
  }
  return c;
}

Isometry3d random_motion(std::mt19937& rng, double t, double deg) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Isometry3d T = Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(u(rng) * deg * EIGEN_PI / 180.0,
                                 Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized())
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(u(rng), u(rng), u(rng)) * t;
  return T;
}

IcpOptions options(IcpMethod method, double max_distance = 0.1) {
  IcpOptions o;
  o.method = method;
  o.max_correspondence_distance = max_distance;
  o.convergence.max_iterations = 100;
  return o;
}

// ---------------------------------------------------------------------------------------------

TEST(RobustKernel, WeightsFollowTheTable) {
  const double k = 0.02;
  for (const auto type : {RobustKernelType::None, RobustKernelType::Huber,
                          RobustKernelType::Tukey, RobustKernelType::GemanMcClure}) {
    EXPECT_DOUBLE_EQ((RobustKernel{type, k}.weight(0.0)), 1.0) << to_string(type);
    EXPECT_EQ(parse_robust_kernel(to_string(type)), type);
  }
  EXPECT_DOUBLE_EQ((RobustKernel{RobustKernelType::None, k}.weight(1.0)), 1.0);
  EXPECT_DOUBLE_EQ((RobustKernel{RobustKernelType::Huber, k}.weight(0.5 * k)), 1.0);
  EXPECT_DOUBLE_EQ((RobustKernel{RobustKernelType::Huber, k}.weight(-2 * k)), 0.5);
  EXPECT_DOUBLE_EQ((RobustKernel{RobustKernelType::Tukey, k}.weight(0.5 * k)), 0.75 * 0.75);
  EXPECT_DOUBLE_EQ((RobustKernel{RobustKernelType::Tukey, k}.weight(k)), 0.0);
  EXPECT_DOUBLE_EQ((RobustKernel{RobustKernelType::Tukey, k}.weight(-3 * k)), 0.0);
  EXPECT_DOUBLE_EQ((RobustKernel{RobustKernelType::GemanMcClure, k}.weight(k)), 0.25);
  EXPECT_EQ(parse_robust_kernel("gm"), RobustKernelType::GemanMcClure);
  EXPECT_FALSE(parse_robust_kernel("cauchy").has_value());
  EXPECT_EQ(parse_icp_method("coloured"), IcpMethod::Colored);
  EXPECT_FALSE(parse_icp_method("gicp").has_value());
}

// Every method, three random perturbations (+-5 cm, +-5 degrees: ICP's basin on this 1 m
// surface), forward and inverse.
TEST(Icp, EveryMethodRecoversRandomPerturbationsForwardAndInverse) {
  std::mt19937 rng(11);
  const PointCloud target = sample_surface(rng, 5000, Isometry3d::Identity());
  for (const auto method : {IcpMethod::PointToPoint, IcpMethod::PointToPlane, IcpMethod::Colored}) {
    // Point-to-point pulls each source point onto a target sample, not onto the surface: with
    // two independent samplings 1.4 cm apart its minimum is off by up to ~1 degree / several
    // mm (the reason point-to-plane exists). See PointToPointIsExactOnSharedSamples.
    const double max_deg = method == IcpMethod::PointToPoint ? 1.5 : 0.05;
    const double max_m = method == IcpMethod::PointToPoint ? 0.01 : 0.0005;
    for (int trial = 0; trial < 3; ++trial) {
      const Isometry3d T_target_source = random_motion(rng, 0.05, 5.0);
      const PointCloud source = sample_surface(rng, 5000, T_target_source.inverse());
      const IcpResult forward = icp(source, target, Isometry3d::Identity(), options(method));
      EXPECT_TRUE(forward.success) << forward.reason;
      EXPECT_TRUE(forward.converged);
      EXPECT_THAT(forward.T_target_source, IsNearPose(T_target_source, max_deg, max_m))
          << to_string(method) << " trial " << trial << ": " << forward.iterations
          << " iterations, converged " << forward.converged;
      EXPECT_GT(forward.fitness, 0.9);
      const IcpResult inverse = icp(target, source, Isometry3d::Identity(), options(method));
      EXPECT_TRUE(inverse.success) << inverse.reason;
      EXPECT_THAT(inverse.T_target_source, IsNearPose(T_target_source.inverse(), max_deg, max_m))
          << to_string(method) << " trial " << trial << " inverse";
    }
  }
}

// A target prepared once gives, for every method and several sources, exactly what icp()
// gives with the cloud (bit for bit: the same preparation, the same passes), and refuses a
// method it was not prepared for.
TEST(Icp, PreparedTargetGivesTheSameResultForManySources) {
  std::mt19937 rng(23);
  const PointCloud target = sample_surface(rng, 5000, Isometry3d::Identity(), false);
  for (const auto method : {IcpMethod::PointToPoint, IcpMethod::PointToPlane, IcpMethod::Colored}) {
    const IcpOptions o = options(method);
    const IcpTarget prepared(target, o);
    EXPECT_EQ(prepared.method(), method);
    EXPECT_EQ(prepared.size(), target.size());
    for (int trial = 0; trial < 3; ++trial) {
      const Isometry3d T_target_source = random_motion(rng, 0.05, 5.0);
      const PointCloud source = sample_surface(rng, 3000, T_target_source.inverse());
      const IcpResult plain = icp(source, target, Isometry3d::Identity(), o);
      const IcpResult reused = icp(source, prepared, Isometry3d::Identity(), o);
      ASSERT_TRUE(reused.success) << reused.reason;
      EXPECT_TRUE(reused.T_target_source.matrix() == plain.T_target_source.matrix())
          << to_string(method) << " trial " << trial;
      EXPECT_EQ(reused.correspondences, plain.correspondences);
      EXPECT_EQ(reused.iterations, plain.iterations);
      EXPECT_THAT(reused.T_target_source, IsNearPose(T_target_source, 1.5, 0.01));
    }
  }
  const IcpTarget plane(target, options(IcpMethod::PointToPlane));
  const PointCloud source = sample_surface(rng, 100, Isometry3d::Identity());
  EXPECT_THROW(
      {
        try {
          icp(source, plane, Isometry3d::Identity(), options(IcpMethod::Colored));
        } catch (const InputError& e) {
          EXPECT_THAT(e.what(), HasSubstr("prepared for point-to-plane"));
          throw;
        }
      },
      InputError);
  EXPECT_THROW(IcpTarget(PointCloud{}, options(IcpMethod::PointToPlane)), InputError);
}

// A flat wall leaves the slide along it and the turn about its normal free: plain
// point-to-plane ICP says its normal equations are singular; with a pose prior the slide is
// held where the prior puts the source origin (the camera centre) and the turn where the
// prior's rotation is, while the wall's own distance and tilt still come from the data. On a
// surface that fixes all six degrees of freedom a prior 5 cm and 3 degrees off moves the
// result by well under a millimetre.
TEST(Icp, PosePriorHoldsWhatTheGeometryLeavesFree) {
  std::mt19937 rng(29);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  PointCloud wall;  // z = 2 in the target frame, seen by a camera at the origin
  for (int i = 0; i < 4000; ++i) {
    wall.positions.emplace_back(static_cast<float>(u(rng)), static_cast<float>(u(rng)), 2.0f);
    wall.normals.emplace_back(0.0f, 0.0f, -1.0f);
  }
  Isometry3d truth = Isometry3d::Identity();
  truth.linear() = Eigen::AngleAxisd(0.03, Eigen::Vector3d::UnitX()).toRotationMatrix();
  truth.translation() = Eigen::Vector3d(0.0, 0.0, 0.02);
  PointCloud source;
  for (int i = 0; i < 4000; ++i) {
    const Eigen::Vector3d p(u(rng), u(rng), 2.0);
    source.positions.push_back((truth.inverse() * p).cast<float>());
  }
  Isometry3d init = Isometry3d::Identity();
  init.translation() = Eigen::Vector3d(0.04, -0.03, 0.0);  // slid along the wall
  IcpOptions o = options(IcpMethod::PointToPlane);
  const IcpResult free = icp(source, wall, init, o);
  EXPECT_FALSE(free.success);
  EXPECT_THAT(free.reason, HasSubstr("singular"));
  IcpPosePrior prior;
  prior.T_target_source = truth;
  o.pose_prior = prior;
  const IcpResult held = icp(source, wall, init, o);
  ASSERT_TRUE(held.success) << held.reason;
  // The wall fixes depth and the tilts about x and y; the prior fixes x and y.
  EXPECT_NEAR(held.T_target_source.translation().x(), 0.0, 1e-3);
  EXPECT_NEAR(held.T_target_source.translation().y(), 0.0, 1e-3);
  EXPECT_NEAR(held.T_target_source.translation().z(), 0.02, 1e-3);
  EXPECT_LT(rotation_difference_deg(held.T_target_source, truth), 0.05);

  const PointCloud target = sample_surface(rng, 5000, Isometry3d::Identity());
  const Isometry3d T = random_motion(rng, 0.03, 3.0);
  const PointCloud bumpy = sample_surface(rng, 5000, T.inverse());
  IcpOptions plain = options(IcpMethod::PointToPlane);
  const IcpResult without = icp(bumpy, target, Isometry3d::Identity(), plain);
  IcpPosePrior off;
  off.T_target_source = T;
  off.T_target_source.translation() += Eigen::Vector3d(0.05, 0.0, 0.0);
  off.T_target_source.linear() =
      Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitY()).toRotationMatrix() * T.linear();
  plain.pose_prior = off;
  const IcpResult with = icp(bumpy, target, Isometry3d::Identity(), plain);
  ASSERT_TRUE(with.success) << with.reason;
  EXPECT_LT(translation_difference_m(with.T_target_source, without.T_target_source), 5e-4);
  EXPECT_LT(rotation_difference_deg(with.T_target_source, without.T_target_source), 0.02);
  EXPECT_NEAR(with.fitness, without.fitness, 0.01);  // fitness is the data's alone
  plain.method = IcpMethod::PointToPoint;
  EXPECT_THROW(icp(bumpy, target, Isometry3d::Identity(), plain), InputError);
}

// A hinge splits the rotation prior: about the hinge axis as loose as rotation_sigma, off it
// as firm as off_axis_sigma per correspondence. On a surface that fixes every direction, with
// a prior 1 degree off the truth about the axis AND 1 degree off it: the loose prior leaves
// both to the data (the truth); a very firm hinge keeps the off-axis degree the prior says and
// still leaves the turn about the axis to the data.
TEST(Icp, HingePriorHoldsTiltAndRollAndLeavesTheTurn) {
  std::mt19937 rng(31);
  const PointCloud target = sample_surface(rng, 6000, Isometry3d::Identity());
  const PointCloud source = sample_surface(rng, 6000, Isometry3d::Identity());
  const Eigen::Vector3d axis = Eigen::Vector3d::UnitY();
  const Eigen::Vector3d off_axis = Eigen::Vector3d::UnitZ();
  constexpr double kOne = M_PI / 180.0;
  IcpOptions o = options(IcpMethod::PointToPlane);
  IcpPosePrior prior;
  prior.T_target_source.linear() = (Eigen::AngleAxisd(kOne, off_axis) *
                                    Eigen::AngleAxisd(kOne, axis)).toRotationMatrix();
  prior.centre_sigma_m = 0.03;
  prior.rotation_sigma_deg = 5.0;
  prior.point_sigma_m = 0.01;
  o.pose_prior = prior;
  const IcpResult loose = icp(source, target, Isometry3d::Identity(), o);
  ASSERT_TRUE(loose.success) << loose.reason;
  EXPECT_LT(rotation_difference_deg(loose.T_target_source, Isometry3d::Identity()), 0.05);
  o.pose_prior->hinge_axis = axis;
  o.pose_prior->off_axis_sigma_deg = 0.001;
  const IcpResult held = icp(source, target, Isometry3d::Identity(), o);
  ASSERT_TRUE(held.success) << held.reason;
  const Eigen::AngleAxisd r(held.T_target_source.linear());
  const Eigen::Vector3d w = r.angle() * r.axis() / kOne;  // degrees
  EXPECT_NEAR(w.dot(off_axis), 1.0, 0.02);  // held to the prior
  EXPECT_NEAR(w.dot(axis), 0.0, 0.05);      // left to the data
  EXPECT_NEAR(w.dot(Eigen::Vector3d::UnitX()), 0.0, 0.02);
  o.pose_prior->hinge_axis = Eigen::Vector3d(0.0, 2.0, 0.0);
  EXPECT_THROW(icp(source, target, Isometry3d::Identity(), o), InputError);
}

// When every source point has an exact partner (the same samples, moved and shuffled),
// point-to-point's fixed point is the truth itself.
TEST(Icp, PointToPointIsExactOnSharedSamples) {
  std::mt19937 rng(18);
  const PointCloud target = sample_surface(rng, 5000, Isometry3d::Identity(), false, false);
  for (int trial = 0; trial < 3; ++trial) {
    const Isometry3d T_target_source = random_motion(rng, 0.03, 3.0);
    PointCloud source = target;
    std::shuffle(source.positions.begin(), source.positions.end(), rng);
    const Eigen::Isometry3f inverse = T_target_source.inverse().cast<float>();
    for (auto& p : source.positions) p = inverse * p;
    IcpOptions o = options(IcpMethod::PointToPoint);
    o.convergence.max_iterations = 200;
    const IcpResult forward = icp(source, target, Isometry3d::Identity(), o);
    EXPECT_TRUE(forward.success) << forward.reason;
    EXPECT_THAT(forward.T_target_source, IsNearPose(T_target_source, 0.001, 1e-5)) << trial;
    const IcpResult backward = icp(target, source, Isometry3d::Identity(), o);
    EXPECT_THAT(backward.T_target_source, IsNearPose(T_target_source.inverse(), 0.001, 1e-5));
  }
}

// The same registration 1 km from the origin (coordinates of a survey grid): the centred,
// double-precision frame keeps the answer; float positions there are still 0.06 mm apart.
TEST(Icp, FarFromTheOriginKeepsPrecision) {
  std::mt19937 rng(12);
  Isometry3d far = Isometry3d::Identity();
  far.translation() = Eigen::Vector3d(1000.0, -700.0, 300.0);
  const PointCloud target = sample_surface(rng, 6000, far);
  // The motion is small where the surface is (about its own centre): M in the local frame.
  const Isometry3d M = random_motion(rng, 0.05, 5.0);
  const Isometry3d T_target_source = far * M * far.inverse();
  const PointCloud source = sample_surface(rng, 6000, T_target_source.inverse() * far);
  for (const auto method : {IcpMethod::PointToPlane, IcpMethod::Colored}) {
    const IcpResult r = icp(source, target, Isometry3d::Identity(), options(method));
    EXPECT_TRUE(r.success) << r.reason;
    // Compared where the surface is: in world coordinates a 1e-5 rad difference would read as
    // a centimetre of translation at the origin, 1.3 km away.
    EXPECT_THAT(far.inverse() * r.T_target_source * far, IsNearPose(M, 0.05, 0.0005))
        << to_string(method);
  }
}

// 30 % of the source replaced by outliers scattered around the surface: each robust kernel
// still lands on the truth.
TEST(Icp, RobustKernelsRejectOutliers) {
  std::mt19937 rng(13);
  const PointCloud target = sample_surface(rng, 6000, Isometry3d::Identity());
  const Isometry3d T_target_source = random_motion(rng, 0.03, 3.0);
  PointCloud source = sample_surface(rng, 6000, T_target_source.inverse(), false, false);
  std::uniform_real_distribution<double> u(-0.5, 0.5), off(-0.08, 0.08);
  for (std::size_t i = 0; i < source.size(); i += 3) {
    const double x = u(rng), y = u(rng);
    source.positions[i] = (T_target_source.inverse() *
                           Eigen::Vector3d(x, y, height(x, y) + off(rng)))
                              .cast<float>();
  }
  const IcpResult plain = icp(source, target, Isometry3d::Identity(), options(IcpMethod::PointToPlane));
  const double plain_error = translation_difference_m(T_target_source, plain.T_target_source);
  for (const auto kernel :
       {RobustKernelType::Huber, RobustKernelType::Tukey, RobustKernelType::GemanMcClure}) {
    IcpOptions o = options(IcpMethod::PointToPlane);
    o.kernel = {kernel, 0.01};
    const IcpResult r = icp(source, target, Isometry3d::Identity(), o);
    EXPECT_TRUE(r.success) << r.reason;
    // Huber only down-weights outliers (k / |r|), the redescending kernels drop them.
    const double max_m = kernel == RobustKernelType::Huber ? 0.002 : 0.001;
    EXPECT_THAT(r.T_target_source, IsNearPose(T_target_source, 0.1, max_m)) << to_string(kernel);
    EXPECT_LT(translation_difference_m(T_target_source, r.T_target_source), plain_error)
        << to_string(kernel) << " does no better than no kernel";
  }
}

// A textured plane: geometry alone leaves the in-plane motion free, so point-to-plane must
// say it cannot decide (not return a silent guess), while coloured ICP locks the texture.
TEST(Icp, ColouredIcpLocksATexturedPlaneThatGeometryCannot) {
  std::mt19937 rng(14);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  const auto plane = [&](const Isometry3d& T) {
    PointCloud c;
    for (int i = 0; i < 8000; ++i) {
      const double x = u(rng), y = u(rng);
      c.positions.push_back((T * Eigen::Vector3d(x, y, 0.0)).cast<float>());
      c.normals.push_back((T.linear() * Eigen::Vector3d::UnitZ()).cast<float>());
      const std::uint8_t g = static_cast<std::uint8_t>(127.5 + 100 * std::sin(9 * x) * std::cos(6 * y));
      c.colors.push_back({g, g, g});
    }
    return c;
  };
  Isometry3d T_target_source = Isometry3d::Identity();
  T_target_source.linear() = Eigen::AngleAxisd(0.03, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_target_source.translation() = Eigen::Vector3d(0.02, -0.015, 0.0);
  const PointCloud target = plane(Isometry3d::Identity());
  const PointCloud source = plane(T_target_source.inverse());

  const IcpResult geometric = icp(source, target, Isometry3d::Identity(),
                                  options(IcpMethod::PointToPlane, 0.05));
  EXPECT_FALSE(geometric.success);
  EXPECT_THAT(geometric.reason, HasSubstr("singular"));

  IcpOptions o = options(IcpMethod::Colored, 0.05);
  const IcpResult colored = icp(source, target, Isometry3d::Identity(), o);
  EXPECT_TRUE(colored.success) << colored.reason;
  EXPECT_THAT(colored.T_target_source, IsNearPose(T_target_source, 0.1, 0.001));
}

TEST(Icp, MultiScaleWidensTheBasin) {
  std::mt19937 rng(15);
  const PointCloud target = sample_surface(rng, 20000, Isometry3d::Identity());
  const Isometry3d T_target_source = random_motion(rng, 0.15, 12.0);
  const PointCloud source = sample_surface(rng, 20000, T_target_source.inverse());
  const IcpResult r = icp_multiscale(source, target, Isometry3d::Identity(),
                                     options(IcpMethod::PointToPlane),
                                     {{0.04, 0.3, 50}, {0.02, 0.08, 50}, {0.0, 0.02, 50}});
  EXPECT_TRUE(r.success) << r.reason;
  EXPECT_THAT(r.T_target_source, IsNearPose(T_target_source, 0.05, 0.0005));
  ASSERT_EQ(r.levels.size(), 3u);
  EXPECT_LT(r.levels[0].source_points, r.levels[2].source_points);  // coarse level is coarse
  EXPECT_EQ(r.levels[2].source_points, source.size());
  int total = 0;
  for (const auto& level : r.levels) total += level.iterations;
  EXPECT_EQ(r.iterations, total);
  EXPECT_THROW(icp_multiscale(source, target, Isometry3d::Identity(), IcpOptions{}, {}),
               InputError);
}

// Open3D's GetInformationMatrixFromPointClouds, by brute force, in the target frame (the
// clouds sit 5 m from the origin so a wrong frame shows), and the final Gauss-Newton Hessian
// of point-to-plane, sum [q x n, n][q x n, n]^T over the final correspondences.
TEST(Icp, InformationMatrixAndHessianMatchBruteForce) {
  std::mt19937 rng(16);
  Isometry3d off = Isometry3d::Identity();
  off.translation() = Eigen::Vector3d(5.0, -3.0, 2.0);
  const PointCloud target = sample_surface(rng, 1500, off);
  const Isometry3d T_target_source = off * random_motion(rng, 0.02, 2.0) * off.inverse();
  const PointCloud source = sample_surface(rng, 1500, T_target_source.inverse() * off);
  const double d = 0.03;
  const IcpResult r = icp(source, target, Isometry3d::Identity(), options(IcpMethod::PointToPlane, d));
  ASSERT_TRUE(r.success) << r.reason;

  Matrix6d info = Matrix6d::Zero(), hessian = Matrix6d::Zero();
  std::size_t matched = 0;
  for (const auto& s : source.positions) {
    const Eigen::Vector3d q = r.T_target_source * s.cast<double>();
    std::size_t best = 0;
    double best_d2 = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < target.size(); ++j) {
      const double d2 = (q - target.positions[j].cast<double>()).squaredNorm();
      if (d2 < best_d2) best_d2 = d2, best = j;
    }
    if (best_d2 > d * d) continue;
    ++matched;
    const Eigen::Vector3d t = target.positions[best].cast<double>();
    Eigen::Matrix<double, 3, 6> G;
    G << 0, t.z(), -t.y(), 1, 0, 0,  //
        -t.z(), 0, t.x(), 0, 1, 0,   //
        t.y(), -t.x(), 0, 0, 0, 1;
    info += G.transpose() * G;
    const Eigen::Vector3d n = target.normals[best].cast<double>();
    Eigen::Matrix<double, 6, 1> J;
    J << q.cross(n), n;
    hessian += J * J.transpose();
  }
  EXPECT_EQ(r.correspondences, matched);
  EXPECT_LT((r.information - info).cwiseAbs().maxCoeff(), 1e-6 * info.cwiseAbs().maxCoeff());
  EXPECT_LT((r.hessian - hessian).cwiseAbs().maxCoeff(), 1e-5 * hessian.cwiseAbs().maxCoeff());
  EXPECT_LT((r.information - r.information.transpose()).cwiseAbs().maxCoeff(), 1e-9);
  const Matrix6d standalone = information_matrix(source, target, r.T_target_source, d);
  EXPECT_LT((standalone - info).cwiseAbs().maxCoeff(), 1e-6 * info.cwiseAbs().maxCoeff());
}

// Same input, same answer bit for bit, with one thread or four.
TEST(Icp, IdenticalForAnyThreadCount) {
  std::mt19937 rng(17);
  const PointCloud target = sample_surface(rng, 6000, Isometry3d::Identity());
  const PointCloud source = sample_surface(rng, 6000, random_motion(rng, 0.03, 3.0));
  for (const auto method : {IcpMethod::PointToPoint, IcpMethod::PointToPlane, IcpMethod::Colored}) {
    const auto run = [&](int threads) {
      const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
      return icp(source, target, Isometry3d::Identity(), options(method));
    };
    const IcpResult one = run(1), four = run(4);
    EXPECT_EQ(one.T_target_source.matrix(), four.T_target_source.matrix()) << to_string(method);
    EXPECT_EQ(one.information, four.information);
    EXPECT_EQ(one.hessian, four.hessian);
    EXPECT_EQ(one.inlier_rmse, four.inlier_rmse);
    EXPECT_EQ(one.iterations, four.iterations);
  }
}

// ---- bad input ------------------------------------------------------------------------------

TEST(IcpBadInput, EmptyAndTinyCloudsAreClearErrors) {
  std::mt19937 rng(20);
  const PointCloud good = sample_surface(rng, 500, Isometry3d::Identity());
  const PointCloud empty;
  PointCloud tiny;
  tiny.positions = {{0, 0, 0}, {1, 0, 0}};
  const IcpOptions o = options(IcpMethod::PointToPoint);
  EXPECT_THROW(icp(empty, good, Isometry3d::Identity(), o), InputError);
  EXPECT_THROW(icp(good, empty, Isometry3d::Identity(), o), InputError);
  try {
    icp(tiny, good, Isometry3d::Identity(), o);
    FAIL() << "a 2-point source must be rejected";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("source cloud has 2 usable points"));
  }
  // Only NaN points: the message says so.
  PointCloud nans;
  nans.positions.assign(10, Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  try {
    icp(good, nans, Isometry3d::Identity(), o);
    FAIL() << "an all-NaN target must be rejected";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("10 with NaN/Inf coordinates dropped"));
  }
}

TEST(IcpBadInput, BadOptionsAreErrors) {
  std::mt19937 rng(21);
  const PointCloud c = sample_surface(rng, 500, Isometry3d::Identity());
  IcpOptions o;
  o.max_correspondence_distance = -1.0;
  EXPECT_THROW(icp(c, c, Isometry3d::Identity(), o), InputError);
  o = IcpOptions{};
  o.kernel = {RobustKernelType::Tukey, 0.0};
  EXPECT_THROW(icp(c, c, Isometry3d::Identity(), o), InputError);
  o = IcpOptions{};
  o.lambda_geometric = 1.5;
  EXPECT_THROW(icp(c, c, Isometry3d::Identity(), o), InputError);
  Isometry3d bad = Isometry3d::Identity();
  bad.translation().x() = std::numeric_limits<double>::infinity();
  EXPECT_THROW(icp(c, c, bad, IcpOptions{}), InputError);
}

// NaN/Inf points are dropped and counted; the result is the one without them, bit for bit.
TEST(IcpBadInput, NonFinitePointsAreDroppedCountedAndChangeNothing) {
  std::mt19937 rng(22);
  const PointCloud target = sample_surface(rng, 3000, Isometry3d::Identity());
  const PointCloud source = sample_surface(rng, 3000, random_motion(rng, 0.03, 3.0));
  PointCloud dirty_source = source, dirty_target = target;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (const Eigen::Vector3f& bad : {Eigen::Vector3f(nan, 0, 0), Eigen::Vector3f(0, inf, 0),
                                    Eigen::Vector3f(0, 0, -inf)}) {
    dirty_source.positions.insert(dirty_source.positions.begin() + 100, bad);
    dirty_source.normals.insert(dirty_source.normals.begin() + 100, Eigen::Vector3f::UnitZ());
    dirty_source.colors.insert(dirty_source.colors.begin() + 100, Rgb8{});
  }
  dirty_target.positions.push_back(Eigen::Vector3f::Constant(nan));
  dirty_target.normals.push_back(Eigen::Vector3f::UnitZ());
  dirty_target.colors.push_back(Rgb8{});
  // A finite point with a NaN normal cannot serve point-to-plane either.
  dirty_target.positions.push_back(Eigen::Vector3f(0.1f, 0.1f, 0.0f));
  dirty_target.normals.push_back(Eigen::Vector3f::Constant(nan));
  dirty_target.colors.push_back(Rgb8{});
  for (const auto method : {IcpMethod::PointToPlane, IcpMethod::Colored}) {
    const IcpResult clean = icp(source, target, Isometry3d::Identity(), options(method));
    const IcpResult dirty = icp(dirty_source, dirty_target, Isometry3d::Identity(), options(method));
    EXPECT_EQ(dirty.source_non_finite, 3u);
    EXPECT_EQ(dirty.target_non_finite, 2u);
    EXPECT_EQ(clean.source_non_finite, 0u);
    EXPECT_EQ(dirty.source_points, source.size());
    EXPECT_EQ(clean.T_target_source.matrix(), dirty.T_target_source.matrix());
    EXPECT_EQ(clean.fitness, dirty.fitness);
  }
}

// No overlap: a failed result with its fitness and a reason, holding the initial estimate
// it was given, never a silent identity.
TEST(IcpBadInput, NoOverlapIsAFailedResultNotAnIdentity) {
  std::mt19937 rng(23);
  const PointCloud target = sample_surface(rng, 2000, Isometry3d::Identity());
  Isometry3d away = Isometry3d::Identity();
  away.translation() = Eigen::Vector3d(10.0, 0.0, 0.0);
  const PointCloud source = sample_surface(rng, 2000, Isometry3d::Identity());
  for (const auto method : {IcpMethod::PointToPoint, IcpMethod::PointToPlane, IcpMethod::Colored}) {
    const IcpResult r = icp(source, target, away, options(method, 0.05));
    EXPECT_FALSE(r.success);
    EXPECT_EQ(r.fitness, 0.0);
    EXPECT_THAT(r.reason, HasSubstr("do not overlap"));
    EXPECT_TRUE(r.T_target_source.isApprox(away)) << "the failed result keeps its input pose";
  }
  // Barely touching: a few correspondences, but fitness below min_fitness.
  Isometry3d edge = Isometry3d::Identity();
  edge.translation() = Eigen::Vector3d(0.97, 0.0, 0.0);
  IcpOptions o = options(IcpMethod::PointToPoint, 0.05);
  o.convergence.max_iterations = 0;  // judge the given pose as it is
  const IcpResult r = icp(source, target, edge, o);
  EXPECT_FALSE(r.success);
  EXPECT_GT(r.fitness, 0.0);
  EXPECT_LT(r.fitness, o.min_fitness);
  EXPECT_THAT(r.reason, HasSubstr("below min_fitness"));
}

TEST(IcpBadInput, MissingNormalsAreEstimatedAndReported) {
  std::mt19937 rng(24);
  const Isometry3d T_target_source = random_motion(rng, 0.03, 3.0);
  const PointCloud target = sample_surface(rng, 6000, Isometry3d::Identity(), false, true);
  const PointCloud source = sample_surface(rng, 6000, T_target_source.inverse(), false, true);
  for (const auto method : {IcpMethod::PointToPlane, IcpMethod::Colored}) {
    const IcpResult r = icp(source, target, Isometry3d::Identity(), options(method));
    EXPECT_TRUE(r.success) << r.reason;
    EXPECT_TRUE(r.target_normals_estimated);
    EXPECT_THAT(r.T_target_source, IsNearPose(T_target_source, 0.1, 0.001));
  }
  const PointCloud with_normals = sample_surface(rng, 6000, Isometry3d::Identity());
  EXPECT_FALSE(icp(source, with_normals, Isometry3d::Identity(), options(IcpMethod::PointToPlane))
                   .target_normals_estimated);
  EXPECT_FALSE(icp(source, target, Isometry3d::Identity(), options(IcpMethod::PointToPoint))
                   .target_normals_estimated);
}

TEST(IcpBadInput, ColouredIcpWithoutColoursIsAnError) {
  std::mt19937 rng(25);
  const PointCloud grey = sample_surface(rng, 500, Isometry3d::Identity(), true, false);
  const PointCloud coloured = sample_surface(rng, 500, Isometry3d::Identity());
  try {
    icp(grey, coloured, Isometry3d::Identity(), options(IcpMethod::Colored));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("needs colours on both clouds; the source has none"));
  }
  EXPECT_THROW(icp(coloured, grey, Isometry3d::Identity(), options(IcpMethod::Colored)),
               InputError);
}

TEST(IcpBadInput, IterationLimitIsReportedNotHidden) {
  std::mt19937 rng(26);
  const PointCloud target = sample_surface(rng, 3000, Isometry3d::Identity());
  const PointCloud source = sample_surface(rng, 3000, random_motion(rng, 0.05, 5.0));
  IcpOptions o = options(IcpMethod::PointToPoint);
  o.convergence.max_iterations = 1;
  const IcpResult r = icp(source, target, Isometry3d::Identity(), o);
  EXPECT_EQ(r.iterations, 1);
  EXPECT_FALSE(r.converged);
}

}  // namespace
}  // namespace locard
