// Pose graph: a loop with known drift is closed exactly, wrong loop edges are rejected by the
// line process or the post-check, bad input is refused, results are repeatable.
#include <locard/alignment/pose_graph.hpp>

#include <locard/core/error.hpp>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <numbers>
#include <random>

namespace locard {
namespace {

constexpr double kPi = std::numbers::pi;

Isometry3d pose(double yaw, const Eigen::Vector3d& t, double pitch = 0.0) {
  Isometry3d T = Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()))
                   .toRotationMatrix();
  T.translation() = t;
  return T;
}

// A camera turning on a circle of radius 1 m: n poses, the ground truth.
std::vector<Isometry3d> circle(std::size_t n) {
  std::vector<Isometry3d> out;
  for (std::size_t i = 0; i < n; ++i) {
    const double a = 2.0 * kPi * static_cast<double>(i) / static_cast<double>(n);
    out.push_back(pose(a + kPi / 2, Eigen::Vector3d(std::cos(a), std::sin(a), 0.1 * std::sin(3 * a)),
                       0.2 * std::cos(a)));
  }
  return out;
}

// ICP-like information: N correspondences spread over a 1 m patch.
Matrix6d information(double correspondences) {
  Matrix6d m = Matrix6d::Identity() * correspondences;
  m.topLeftCorner<3, 3>() *= 0.3;  // rotation block ~ N * mean |t|^2
  return m;
}

PoseGraphEdge edge(std::size_t s, std::size_t t, const Isometry3d& T_t_s, bool loop,
                   double n = 5000.0) {
  PoseGraphEdge e;
  e.source = s;
  e.target = t;
  e.T_target_source = T_t_s;
  e.information = information(n);
  e.uncertain = loop;
  return e;
}

double max_error_m(const std::vector<Isometry3d>& a, const std::vector<Isometry3d>& b) {
  double m = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, translation_difference_m(a[i], b[i]));
  return m;
}

double max_error_deg(const std::vector<Isometry3d>& a, const std::vector<Isometry3d>& b) {
  double m = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, rotation_difference_deg(a[i], b[i]));
  return m;
}

// Exact relative measurements, initial poses integrated with a drifting odometry (every step
// rotated by 0.5 degrees and stretched by 1 cm): the loop edge makes the graph consistent only
// at the truth, so the optimum is the ground truth.
TEST(PoseGraph, SyntheticLoopWithKnownDriftIsClosedExactly) {
  const auto truth = circle(24);
  PoseGraph graph;
  graph.nodes.push_back(truth[0]);
  const Isometry3d drift = pose(0.5 * kPi / 180.0, Eigen::Vector3d(0.01, 0.0, 0.0));
  for (std::size_t i = 1; i < truth.size(); ++i) {
    const Isometry3d step = truth[i - 1].inverse() * truth[i];
    graph.nodes.push_back(graph.nodes.back() * step * drift);
    graph.edges.push_back(edge(i, i - 1, step, false));
  }
  graph.edges.push_back(edge(0, truth.size() - 1, truth.back().inverse() * truth[0], true));
  ASSERT_GT(max_error_m(graph.nodes, truth), 0.1);  // the drift is real: > 10 cm at the end
  PoseGraphOptions options;
  options.max_correspondence_distance = 0.5;  // the drifted start is far from the truth
  const PoseGraphResult r = optimize_pose_graph(graph, options);
  ASSERT_TRUE(r.success) << r.reason;
  EXPECT_TRUE(r.rejected.empty());
  EXPECT_LT(max_error_m(graph.nodes, truth), 1e-6);
  EXPECT_LT(max_error_deg(graph.nodes, truth), 1e-5);
  EXPECT_LT(r.final_cost, 1e-6);
  EXPECT_GT(r.initial_cost, 1.0);
  ASSERT_EQ(graph.edges.size(), truth.size());
  EXPECT_NEAR(graph.edges.back().confidence, 1.0, 1e-9);
}

// Noisy odometry, a correct loop edge: the end-point drift shrinks and is spread evenly.
TEST(PoseGraph, LoopEdgeReducesAccumulatedDrift) {
  const auto truth = circle(30);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  PoseGraph graph;
  graph.nodes.push_back(truth[0]);
  for (std::size_t i = 1; i < truth.size(); ++i) {
    const Isometry3d step = truth[i - 1].inverse() * truth[i];
    const Isometry3d meas =
        step * pose(0.003 * noise(rng), Eigen::Vector3d(0.004 * noise(rng), 0.004 * noise(rng),
                                                        0.004 * noise(rng)));
    graph.nodes.push_back(graph.nodes.back() * meas);
    graph.edges.push_back(edge(i, i - 1, meas, false));
  }
  graph.edges.push_back(edge(0, truth.size() - 1, truth.back().inverse() * truth[0], true));
  const double before = translation_difference_m(graph.nodes.back(), truth.back());
  PoseGraphOptions options;
  options.max_correspondence_distance = 0.2;
  const PoseGraphResult r = optimize_pose_graph(graph, options);
  ASSERT_TRUE(r.success);
  EXPECT_TRUE(r.rejected.empty());
  const double after = translation_difference_m(graph.nodes.back(), truth.back());
  EXPECT_LT(after, 0.25 * before) << "before " << before << " after " << after;
  EXPECT_LT(r.final_cost, r.initial_cost);
}

// One correct and one wrong loop edge (a 40 cm, 20 degree false closure, as a repeated
// structure would give): the line process switches the wrong one off and it is reported.
TEST(PoseGraph, WrongLoopEdgeIsRejected) {
  const auto truth = circle(24);
  PoseGraph graph;
  graph.nodes = truth;
  for (std::size_t i = 1; i < truth.size(); ++i)
    graph.edges.push_back(edge(i, i - 1, truth[i - 1].inverse() * truth[i], false));
  graph.edges.push_back(edge(0, 23, truth[23].inverse() * truth[0], true));
  const Isometry3d wrong = truth[6].inverse() * truth[18] *
                           pose(20.0 * kPi / 180.0, Eigen::Vector3d(0.4, 0.0, 0.0));
  graph.edges.push_back(edge(18, 6, wrong, true));
  PoseGraphOptions options;
  options.max_correspondence_distance = 0.03;
  const PoseGraphResult r = optimize_pose_graph(graph, options);
  ASSERT_TRUE(r.success);
  ASSERT_EQ(r.rejected.size(), 1u);
  EXPECT_EQ(r.rejected[0].edge.source, 18u);
  EXPECT_EQ(r.rejected[0].edge.target, 6u);
  EXPECT_NE(r.rejected[0].reason.find("line process"), std::string::npos) << r.rejected[0].reason;
  EXPECT_LT(r.rejected[0].edge.confidence, options.prune_threshold);
  EXPECT_LT(max_error_m(graph.nodes, truth), 1e-6);
  EXPECT_EQ(graph.edges.size(), truth.size());  // 23 odometry + the correct loop
}

// A wrong edge that is strong (huge information, so its chi2 cannot be absorbed) with a very
// permissive line process: the post-check on the odometry bend rejects it.
TEST(PoseGraph, PostCheckRejectsClosureThatBendsOdometry) {
  const auto truth = circle(12);
  PoseGraph graph;
  graph.nodes = truth;
  for (std::size_t i = 1; i < truth.size(); ++i)
    graph.edges.push_back(edge(i, i - 1, truth[i - 1].inverse() * truth[i], false));
  const Isometry3d wrong = truth[0].inverse() * truth[6] *
                           pose(0.0, Eigen::Vector3d(0.0, 0.3, 0.0));
  graph.edges.push_back(edge(6, 0, wrong, true, 5e5));
  PoseGraphOptions options;
  options.max_correspondence_distance = 10.0;  // line process keeps everything
  options.max_odometry_bend_m = 0.01;
  const PoseGraphResult r = optimize_pose_graph(graph, options);
  ASSERT_TRUE(r.success);
  ASSERT_EQ(r.rejected.size(), 1u);
  EXPECT_NE(r.rejected[0].reason.find("post-check"), std::string::npos) << r.rejected[0].reason;
  EXPECT_LT(max_error_m(graph.nodes, truth), 1e-6);
  EXPECT_LE(r.max_odometry_bend_m, options.max_odometry_bend_m);
}

TEST(PoseGraph, NearPiRotationsAndFixedNode) {
  // Two nodes 179.9 degrees apart, the second perturbed; node 1 fixed instead of node 0.
  PoseGraph graph;
  const Isometry3d a = pose(0.0, Eigen::Vector3d::Zero());
  const Isometry3d b = pose(kPi - 1e-3, Eigen::Vector3d(1, 2, 3));
  graph.nodes = {a * pose(0.1, Eigen::Vector3d(0.05, 0, 0)), b};
  graph.edges.push_back(edge(1, 0, a.inverse() * b, false));
  PoseGraphOptions options;
  options.fixed_node = 1;
  const PoseGraphResult r = optimize_pose_graph(graph, options);
  ASSERT_TRUE(r.success);
  EXPECT_LT(translation_difference_m(graph.nodes[0], a), 1e-9);
  EXPECT_LT(rotation_difference_deg(graph.nodes[0], a), 1e-7);
  EXPECT_EQ(graph.nodes[1].matrix(), b.matrix());
}

TEST(PoseGraph, Chi2IsZeroAtConsistentPosesAndGrowsQuadratically) {
  const auto truth = circle(4);
  PoseGraphEdge e = edge(1, 0, truth[0].inverse() * truth[1], false, 100.0);
  EXPECT_LT(edge_chi2(e, truth), 1e-20);
  auto moved = truth;
  moved[1].translation() += Eigen::Vector3d(0.001, 0, 0);
  const double c1 = edge_chi2(e, moved);
  moved[1].translation() += Eigen::Vector3d(0.001, 0, 0);
  const double c2 = edge_chi2(e, moved);
  EXPECT_NEAR(c1, 100.0 * 1e-6, 1e-9);
  EXPECT_NEAR(c2 / c1, 4.0, 1e-6);
}

// The Jacobians pose_covariances uses, against an independent oracle: central differences of
// the residual as the header defines it (E = (T_w_t^-1 T_w_s) Z^-1, xi = (2 vec(q_E), p_E),
// q_E with w >= 0), written out again here, under world-frame left perturbations exp(delta) T,
// at a measurement that does not match the poses (a residual far from zero, where a wrong sign
// or frame would show).
TEST(PoseGraph, EdgeJacobiansMatchCentralDifferences) {
  using Vector6d = Eigen::Matrix<double, 6, 1>;
  const auto truth = circle(5);
  const std::vector<Isometry3d> nodes = {truth[1], truth[3]};
  const Isometry3d Z = pose(0.3, Eigen::Vector3d(0.2, -0.1, 0.05), 0.1) *
                       (truth[3].inverse() * truth[1]);
  const auto residual = [&](const Isometry3d& T_w_s, const Isometry3d& T_w_t) {
    const Isometry3d E = T_w_t.inverse() * T_w_s * Z.inverse();
    Eigen::Quaterniond q(E.rotation());
    if (q.w() < 0) q.coeffs() *= -1.0;
    Vector6d xi;
    xi << 2.0 * q.vec(), E.translation();
    return xi;
  };
  const auto perturb = [](const Isometry3d& T, const Vector6d& d) {
    Isometry3d D = Isometry3d::Identity();
    const Eigen::Vector3d w = d.head<3>();
    if (w.norm() > 0) D.linear() = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
    D.translation() = d.tail<3>();
    return D * T;
  };
  ASSERT_GT(residual(nodes[0], nodes[1]).norm(), 0.1);
  const EdgeJacobians J = edge_jacobians(edge(0, 1, Z, false), nodes);
  constexpr double h = 1e-6;
  for (int c = 0; c < 6; ++c) {
    Vector6d d = Vector6d::Zero();
    d[c] = h;
    const Vector6d source = (residual(perturb(nodes[0], d), nodes[1]) -
                             residual(perturb(nodes[0], -d), nodes[1])) / (2 * h);
    const Vector6d target = (residual(nodes[0], perturb(nodes[1], d)) -
                             residual(nodes[0], perturb(nodes[1], -d))) / (2 * h);
    EXPECT_LT((J.source.col(c) - source).cwiseAbs().maxCoeff(), 1e-7) << "source column " << c;
    EXPECT_LT((J.target.col(c) - target).cwiseAbs().maxCoeff(), 1e-7) << "target column " << c;
  }
  // Not a zero matrix by accident: the rotation of a node moves every residual component.
  EXPECT_GT(J.source.norm(), 1.0);
  EXPECT_GT(J.target.norm(), 1.0);
}

TEST(PoseGraph, SameGraphSameResultBitForBit) {
  const auto truth = circle(16);
  PoseGraph g;
  g.nodes.push_back(truth[0]);
  for (std::size_t i = 1; i < truth.size(); ++i) {
    const Isometry3d step = truth[i - 1].inverse() * truth[i];
    g.nodes.push_back(g.nodes.back() * step * pose(0.002, Eigen::Vector3d(0.003, 0, 0)));
    g.edges.push_back(edge(i, i - 1, step * pose(0.001, Eigen::Vector3d::Zero()), false));
  }
  g.edges.push_back(edge(0, 15, truth[15].inverse() * truth[0], true));
  PoseGraph h = g;
  optimize_pose_graph(g);
  optimize_pose_graph(h);
  for (std::size_t i = 0; i < g.nodes.size(); ++i)
    EXPECT_EQ(g.nodes[i].matrix(), h.nodes[i].matrix()) << i;
}

TEST(PoseGraph, BadInputIsRefused) {
  PoseGraph g;
  g.nodes = circle(3);
  g.edges.push_back(edge(1, 5, Isometry3d::Identity(), false));
  EXPECT_THROW(optimize_pose_graph(g), InputError);
  g.edges = {edge(1, 1, Isometry3d::Identity(), false)};
  EXPECT_THROW(optimize_pose_graph(g), InputError);
  g.edges = {edge(1, 0, Isometry3d::Identity(), false)};
  g.edges[0].information(0, 1) = 5.0;  // not symmetric
  EXPECT_THROW(optimize_pose_graph(g), InputError);
  g.edges = {edge(1, 0, Isometry3d::Identity(), false)};
  g.edges[0].information(2, 2) = std::nan("");
  EXPECT_THROW(optimize_pose_graph(g), InputError);
  g.edges = {edge(1, 0, Isometry3d::Identity(), false)};
  PoseGraphOptions o;
  o.fixed_node = 3;
  EXPECT_THROW(optimize_pose_graph(g, o), InputError);
  PoseGraph empty;
  EXPECT_TRUE(optimize_pose_graph(empty).success);
}

}  // namespace
}  // namespace locard
