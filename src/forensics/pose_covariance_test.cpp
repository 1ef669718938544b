// Pose covariances from the pose graph's Hessian: a single edge gives back sigma^2 Lambda^-1,
// a chain grows away from the gauge, a loop edge shrinks it, an unconstrained node is huge.
#include <locard/forensics/pose_covariance.hpp>

#include <locard/core/error.hpp>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace locard::forensics {
namespace {

double translation_trace(const Matrix6d& c) { return c.bottomRightCorner<3, 3>().trace(); }

Isometry3d translation(double x, double y, double z) {
  Isometry3d T = Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

PoseGraphEdge edge(const PoseGraph& g, std::size_t s, std::size_t t, const Matrix6d& info) {
  PoseGraphEdge e;
  e.source = s;
  e.target = t;
  e.T_target_source = g.nodes[t].inverse() * g.nodes[s];  // consistent: zero residual
  e.information = info;
  return e;
}

TEST(PoseCovariance, OneEdgeGivesTheInverseInformation) {
  PoseGraph g;
  g.nodes = {Isometry3d::Identity(), Isometry3d::Identity()};
  Matrix6d info = Matrix6d::Zero();
  for (int i = 0; i < 6; ++i) info(i, i) = 100.0 * (i + 1);
  g.edges = {edge(g, 1, 0, info)};
  const double sigma = 0.01;
  const auto cov = pose_covariances(g, {sigma});
  ASSERT_EQ(cov.size(), 2u);
  EXPECT_TRUE(cov[0].isZero());  // the gauge
  const Matrix6d expected = sigma * sigma * info.inverse();
  EXPECT_TRUE(cov[1].isApprox(expected, 1e-5)) << cov[1] << "\nvs\n" << expected;
}

TEST(PoseCovariance, ChainGrowsAndALoopEdgeShrinksIt) {
  PoseGraph g;
  for (int k = 0; k < 5; ++k) g.nodes.push_back(translation(0.5 * k, 0.1 * k, 0));
  const Matrix6d info = Matrix6d::Identity() * 1e4;
  for (std::size_t k = 1; k < 5; ++k) g.edges.push_back(edge(g, k, k - 1, info));
  const auto chain = pose_covariances(g, {0.005});
  for (std::size_t k = 2; k < 5; ++k)
    EXPECT_GT(translation_trace(chain[k]), translation_trace(chain[k - 1]));
  PoseGraph loop = g;
  PoseGraphEdge closure = edge(g, 4, 0, info);
  closure.uncertain = true;
  closure.confidence = 1.0;
  loop.edges.push_back(closure);
  const auto closed = pose_covariances(loop, {0.005});
  EXPECT_LT(translation_trace(closed[4]), translation_trace(chain[4]));
  // A loop edge the line process switched off adds nothing.
  loop.edges.back().confidence = 0.0;
  const auto off = pose_covariances(loop, {0.005});
  EXPECT_NEAR(off[4].trace(), chain[4].trace(), 1e-9 * chain[4].trace());
}

TEST(PoseCovariance, UnconstrainedNodeAndBadInput) {
  PoseGraph g;
  g.nodes = {Isometry3d::Identity(), translation(1, 0, 0), translation(2, 0, 0)};
  g.edges = {edge(g, 1, 0, Matrix6d::Identity() * 1e4)};
  const auto cov = pose_covariances(g, {0.005});
  EXPECT_GT(cov[2].trace(), 1e3);  // nothing ties node 2: its covariance says so
  EXPECT_LT(cov[1].trace(), 1e-3);
  EXPECT_THROW(pose_covariances(g, {0.005, 0.005}), InputError);  // neither one nor per edge
  EXPECT_THROW(pose_covariances(g, {0.005}, 7), InputError);
  g.edges[0].target = 9;
  EXPECT_THROW(pose_covariances(g, {0.005}), InputError);
}

}  // namespace
}  // namespace locard::forensics
