#pragma once
// Pose graph over views (or fragments), optimised with Ceres on SE(3), robust to wrong loop
// closures by the line process of Choi, Zhou, Koltun 2015 ("Robust reconstruction of indoor
// scenes", CVPR, eq. 3-6) followed by edge pruning and a post-check.
//
// Nodes are T_world_node. An edge (source s, target t) measures Z = T_t_s, the pose of s in
// the frame of t, with a 6x6 information matrix Lambda ordered (rotation x y z, translation
// x y z) in the TARGET frame: exactly what IcpResult::information holds for an ICP of s (as
// source) against t (as target).
//
// Residual of an edge. The prediction is P = T_w_t^-1 T_w_s. Its error is the left
// perturbation that takes the measurement to the prediction, P = exp(xi) Z, i.e.
//   E = P Z^-1,   xi = (2 vec(q_E), p_E)          (first order in the rotation angle)
// which is the same perturbation ICP's information matrix is written for (icp.hpp), so
//   chi2_e = xi^T Lambda xi  and the Ceres residual is  r = L^T xi  with Lambda = L L^T.
//
// Robustness (Choi et al. eq. 3): the energy is
//   E = sum_odometry chi2 + sum_loop [ l_e chi2_e + mu (sqrt(l_e) - 1)^2 ],   l_e in [0, 1].
// For fixed poses the optimal l_e = (mu / (mu + chi2_e))^2, and substituting it gives the
// robust loss rho(chi2) = mu chi2 / (mu + chi2) on loop edges (Black & Rangarajan 1996), which
// is what we hand to Ceres. The information matrix of ICP is a sum over correspondences, so
// chi2 ~ N D^2 for an edge whose alignment disagrees with the graph by a displacement D over N
// correspondences. We set mu = N_mean * d^2 with N_mean the mean correspondence count of the
// loop edges (trace of their translation block / 3) and d = max_correspondence_distance:
// l_e < 1/4 roughly when the edge disagrees with the rest of the graph by more than d.
//
// Pruning and post-check. After the robust solve, loop edges with l_e < prune_threshold are
// removed and the graph is solved again from the initial poses (Open3D's scheme). Then every
// odometry edge's optimised relative pose is compared with its measurement; when one is bent
// by more than max_odometry_bend_deg or max_odometry_bend_m, the remaining loop edge with the
// largest chi2 is rejected and the graph is solved again, until the bound holds or no loop
// edge is left. Rejected edges are reported with the reason, never silently dropped.
//
// The gauge: node `fixed_node` keeps its initial pose. Solved with a single thread, so the
// same graph gives the same poses bit for bit.

#include <locard/core/pose.hpp>

#include <Eigen/Core>

#include <cstddef>
#include <string>
#include <vector>

namespace locard {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

struct PoseGraphEdge {
  std::size_t source = 0;
  std::size_t target = 0;
  Isometry3d T_target_source = Isometry3d::Identity();
  Matrix6d information = Matrix6d::Identity();
  bool uncertain = false;   // a loop closure: may be down-weighted, pruned or rejected
  // Filled by optimize_pose_graph: the line-process weight l_e (1 for odometry edges) and the
  // final chi2 (0 for pruned edges).
  double confidence = 1.0;
  double chi2 = 0.0;
};

struct PoseGraph {
  std::vector<Isometry3d> nodes;  // T_world_node
  std::vector<PoseGraphEdge> edges;
};

struct PoseGraphOptions {
  double max_correspondence_distance = 0.03;  // d above, metres
  double preference_loop_closure = 1.0;       // scales mu
  double prune_threshold = 0.25;              // l_e below this: pruned
  double max_odometry_bend_deg = 2.0;         // post-check bounds
  double max_odometry_bend_m = 0.05;
  int max_iterations = 200;
  std::size_t fixed_node = 0;
};

struct RejectedEdge {
  PoseGraphEdge edge;
  std::string reason;
};

struct PoseGraphResult {
  bool success = false;
  std::string reason;
  double initial_cost = 0.0;  // sum of chi2 over all edges at the initial poses
  double final_cost = 0.0;    // sum of chi2 over the kept edges at the final poses
  int solves = 0;
  int iterations = 0;         // Ceres iterations over all solves
  double mu = 0.0;
  double max_odometry_bend_deg = 0.0;  // after the final solve
  double max_odometry_bend_m = 0.0;
  std::vector<RejectedEdge> rejected;  // pruned or rejected loop edges
};

// chi2 of one edge at the given node poses (see above).
double edge_chi2(const PoseGraphEdge& edge, const std::vector<Isometry3d>& nodes);

// The derivatives of an edge's residual xi (the one the solver minimises, unweighted) with
// respect to world-frame left perturbations exp(delta) T_w_node of its two nodes, delta =
// (rotation vector, translation), at the given poses; by Ceres' automatic differentiation
// (jets), so exact, not finite differences. forensics::pose_covariances builds the pose graph's
// Hessian from them.
struct EdgeJacobians {
  Matrix6d source;  // d xi / d delta_source
  Matrix6d target;  // d xi / d delta_target
};
EdgeJacobians edge_jacobians(const PoseGraphEdge& edge, const std::vector<Isometry3d>& nodes);

// Optimises graph.nodes in place; edges that do not survive are moved from graph.edges into
// result.rejected. Throws InputError for an edge naming a missing node, a non-symmetric or
// non-finite information matrix, or a fixed node out of range.
PoseGraphResult optimize_pose_graph(PoseGraph& graph, const PoseGraphOptions& options = {});

}  // namespace locard
