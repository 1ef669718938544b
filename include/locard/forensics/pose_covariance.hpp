#pragma once
// Marginal covariance of every pose-graph node: the inverse of the Gauss-Newton Hessian of the
// pose graph at its optimum, with the gauge node held fixed.
//
// Each kept edge contributes J^T (Lambda / sigma^2) J, J the derivative of the edge residual xi
// (pose_graph.hpp) with respect to left perturbations exp(delta) T_world_node of its two nodes
// (edge_jacobians: Ceres' automatic differentiation of the very residual the pose graph solves,
// delta = (rotation, translation) in the world frame), Lambda its
// information matrix (a sum over ICP correspondences of unit-weight terms, so it is scaled by
// the correspondences' residual variance sigma^2: the inlier RMSE of the registration, at
// least the sensor's noise floor). Loop edges are weighted by their line-process weight.
// The result for node k is Sigma_k (6x6), world-frame left perturbation: a world point p seen
// from node k moves by  [-[p]x  I] delta,  so its covariance is J Sigma_k J^T.

#include <locard/alignment/pose_graph.hpp>
#include <locard/alignment/sequential_alignment.hpp>

#include <vector>

namespace locard::forensics {

// residual_sigma_m: per edge (same order as graph.edges) or one value for all.
std::vector<Matrix6d> pose_covariances(const PoseGraph& graph,
                                       const std::vector<double>& residual_sigma_m,
                                       std::size_t fixed_node = 0);

// Every node's covariance for an aligned sequence, as a case records it.
//   sigmas: per edge, the residual sigma: the larger inlier RMSE of its two views' registrations,
//           at least `noise_floor_sigma_m` (the sensor's axial noise at a typical range);
//   variance_factor: the a posteriori variance factor of a least-squares adjustment, the
//           weighted chi2 of the kept edges over the redundancy (6 per edge - 6 per free node),
//           at least 1. Above 1 the registrations disagree more than their stated precision and
//           every covariance is inflated by it. Judged at the pose graph's own optimum
//           (AlignmentResult::refinement.graph_optimum when there is one): the joint refinement
//           moves poses off the tracking edges on purpose, which would read as the edges
//           disagreeing.
struct ViewCovariances {
  std::vector<double> sigmas;          // per edge of result.graph
  std::vector<Matrix6d> covariances;   // per node, already multiplied by variance_factor
  double variance_factor = 1.0;
};
ViewCovariances view_covariances(const AlignmentResult& result, double noise_floor_sigma_m,
                                 std::size_t fixed_node);

}  // namespace locard::forensics
