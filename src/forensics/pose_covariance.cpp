#include <locard/forensics/pose_covariance.hpp>

#include <locard/core/error.hpp>

#include <Eigen/Geometry>
#include <Eigen/SparseCholesky>

#include <fmt/format.h>

#include <algorithm>

namespace locard::forensics {

std::vector<Matrix6d> pose_covariances(const PoseGraph& graph,
                                       const std::vector<double>& residual_sigma_m,
                                       std::size_t fixed_node) {
  const std::size_t n = graph.nodes.size();
  if (n == 0) return {};
  if (fixed_node >= n) throw InputError("pose covariance: fixed node out of range");
  if (residual_sigma_m.size() != 1 && residual_sigma_m.size() != graph.edges.size())
    throw InputError("pose covariance: one residual sigma, or one per edge, is needed");
  // Free nodes get consecutive 6-blocks; the fixed node has none.
  auto block = [&](std::size_t k) { return static_cast<int>(6 * (k < fixed_node ? k : k - 1)); };
  const int dim = static_cast<int>(6 * (n - 1));
  std::vector<Eigen::Triplet<double>> triplets;
  for (std::size_t e = 0; e < graph.edges.size(); ++e) {
    const PoseGraphEdge& edge = graph.edges[e];
    if (edge.source >= n || edge.target >= n)
      throw InputError(fmt::format("pose covariance: edge {} names a missing node", e));
    const double sigma = residual_sigma_m.size() == 1 ? residual_sigma_m[0] : residual_sigma_m[e];
    const double weight = (edge.uncertain ? edge.confidence : 1.0) / (sigma * sigma);
    if (!(weight > 0) || !std::isfinite(weight)) continue;
    const EdgeJacobians J = edge_jacobians(edge, graph.nodes);
    const Matrix6d L = weight * edge.information;
    const std::size_t ids[2] = {edge.source, edge.target};
    const Matrix6d* Js_t[2] = {&J.source, &J.target};
    for (int a = 0; a < 2; ++a)
      for (int b = 0; b < 2; ++b) {
        if (ids[a] == fixed_node || ids[b] == fixed_node) continue;
        const Matrix6d H = Js_t[a]->transpose() * L * *Js_t[b];
        for (int r = 0; r < 6; ++r)
          for (int c = 0; c < 6; ++c)
            triplets.emplace_back(block(ids[a]) + r, block(ids[b]) + c, H(r, c));
      }
  }
  std::vector<Matrix6d> out(n, Matrix6d::Zero());
  if (dim == 0) return out;
  Eigen::SparseMatrix<double> H(dim, dim);
  H.setFromTriplets(triplets.begin(), triplets.end());
  // A tiny ridge keeps a node that no edge constrains from making the system singular; its
  // covariance then comes out huge, which is the honest answer.
  for (int i = 0; i < dim; ++i) H.coeffRef(i, i) += 1e-9;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(H);
  if (solver.info() != Eigen::Success) throw Error("pose covariance: Hessian factorisation failed");
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(dim, 6);
  for (std::size_t k = 0; k < n; ++k) {
    if (k == fixed_node) continue;
    rhs.setZero();
    for (int c = 0; c < 6; ++c) rhs(block(k) + c, c) = 1.0;
    const Eigen::MatrixXd x = solver.solve(rhs);
    out[k] = x.block(block(k), 0, 6, 6);
    out[k] = 0.5 * (out[k] + out[k].transpose()).eval();
  }
  return out;
}

ViewCovariances view_covariances(const AlignmentResult& result, double noise_floor_sigma_m,
                                 std::size_t fixed_node) {
  ViewCovariances out;
  for (const PoseGraphEdge& e : result.graph.edges) {
    const FrameAlignment& fs_ = result.frames[result.node_frames[e.source]];
    const FrameAlignment& ft = result.frames[result.node_frames[e.target]];
    out.sigmas.push_back(std::max({noise_floor_sigma_m, fs_.inlier_rmse, ft.inlier_rmse}));
  }
  const std::vector<double>& sigmas = out.sigmas;
  out.covariances = sigmas.empty()
                        ? std::vector<Matrix6d>(result.graph.nodes.size(), Matrix6d::Zero())
                        : pose_covariances(result.graph, sigmas, fixed_node);
  const std::vector<Isometry3d>& judged_at =
      result.refinement.graph_optimum.size() == result.graph.nodes.size()
          ? result.refinement.graph_optimum
          : result.graph.nodes;
  double chi2 = 0.0;
  for (std::size_t e = 0; e < result.graph.edges.size(); ++e) {
    const PoseGraphEdge& edge = result.graph.edges[e];
    const double w = (edge.uncertain ? edge.confidence : 1.0) / (sigmas[e] * sigmas[e]);
    chi2 += w * edge_chi2(edge, judged_at);
  }
  const double redundancy = 6.0 * static_cast<double>(result.graph.edges.size()) -
                            6.0 * static_cast<double>(result.graph.nodes.size() - 1);
  if (redundancy > 0) out.variance_factor = std::max(1.0, chi2 / redundancy);
  for (Matrix6d& c : out.covariances) c *= out.variance_factor;
  return out;
}

}  // namespace locard::forensics
