// Pose graph with a line process on loop edges (Choi et al. 2015); the residual and the loss
// are derived in include/locard/alignment/pose_graph.hpp.
#include <locard/alignment/pose_graph.hpp>

#include <locard/core/error.hpp>

#include <ceres/ceres.h>
#include <ceres/manifold.h>
#include <ceres/rotation.h>
#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>

namespace locard {
namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;

// xi = (2 vec(q_E), p_E) with E = (T_w_t^-1 T_w_s) Z^-1 (header, "Residual of an edge").
template <typename T>
Eigen::Matrix<T, 6, 1> edge_error(const Eigen::Quaternion<T>& q_w_t,
                                  const Eigen::Matrix<T, 3, 1>& p_w_t,
                                  const Eigen::Quaternion<T>& q_w_s,
                                  const Eigen::Matrix<T, 3, 1>& p_w_s,
                                  const Eigen::Quaterniond& q_z, const Eigen::Vector3d& p_z) {
  const Eigen::Quaternion<T> q_t_inv = q_w_t.conjugate();
  const Eigen::Quaternion<T> q_p = q_t_inv * q_w_s;
  const Eigen::Matrix<T, 3, 1> p_p = q_t_inv * (p_w_s - p_w_t);
  const Eigen::Quaternion<T> q_z_inv = q_z.conjugate().cast<T>();
  Eigen::Quaternion<T> q_e = q_p * q_z_inv;
  const Eigen::Matrix<T, 3, 1> p_e = p_p - q_e * p_z.cast<T>();
  // q and -q are the same rotation: take the one with w >= 0 so the residual is small.
  if (q_e.w() < T(0)) q_e.coeffs() = -q_e.coeffs();
  Eigen::Matrix<T, 6, 1> xi;
  xi.template head<3>() = T(2) * q_e.vec();
  xi.template tail<3>() = p_e;
  return xi;
}

struct EdgeCost {
  EdgeCost(const Isometry3d& Z, const Matrix6d& sqrt_information)
      : q_z(Z.linear()), p_z(Z.translation()), sqrt_info(sqrt_information) {}

  template <typename T>
  bool operator()(const T* p_t, const T* q_t, const T* p_s, const T* q_s, T* residual) const {
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> pt(p_t), ps(p_s);
    const Eigen::Map<const Eigen::Quaternion<T>> qt(q_t), qs(q_s);
    const Eigen::Matrix<T, 6, 1> xi = edge_error<T>(qt, pt, qs, ps, q_z, p_z);
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual);
    r = sqrt_info.cast<T>() * xi;
    return true;
  }

  Eigen::Quaterniond q_z;
  Eigen::Vector3d p_z;
  Matrix6d sqrt_info;
};

// rho(s) = mu s / (mu + s): the line process with l eliminated (header, "Robustness").
class LineProcessLoss final : public ceres::LossFunction {
 public:
  explicit LineProcessLoss(double mu) : mu_(mu) {}
  void Evaluate(double s, double rho[3]) const override {
    const double d = mu_ + s;
    rho[0] = mu_ * s / d;
    rho[1] = (mu_ * mu_) / (d * d);
    rho[2] = -2.0 * (mu_ * mu_) / (d * d * d);
  }

 private:
  double mu_;
};

// L^T with Lambda = L L^T; a tiny ridge keeps rank-deficient (e.g. planar) information usable.
Matrix6d sqrt_information(const Matrix6d& information) {
  const double ridge = std::max(1e-9, 1e-9 * information.trace());
  const Eigen::LLT<Matrix6d> llt(information + ridge * Matrix6d::Identity());
  return llt.matrixL().transpose();
}

void check_graph(const PoseGraph& graph, const PoseGraphOptions& options) {
  const std::size_t n = graph.nodes.size();
  if (n == 0) return;
  if (options.fixed_node >= n)
    throw InputError(fmt::format("pose graph: fixed node {} does not exist ({} nodes)",
                                 options.fixed_node, n));
  for (std::size_t i = 0; i < graph.edges.size(); ++i) {
    const PoseGraphEdge& e = graph.edges[i];
    if (e.source >= n || e.target >= n || e.source == e.target)
      throw InputError(fmt::format("pose graph: edge {} joins nodes {} and {}; nodes are 0..{} "
                                   "and an edge needs two different ones",
                                   i, e.source, e.target, n - 1));
    if (!e.information.allFinite() ||
        (e.information - e.information.transpose()).cwiseAbs().maxCoeff() >
            1e-9 * std::max(1.0, e.information.cwiseAbs().maxCoeff()))
      throw InputError(fmt::format("pose graph: edge {} ({} -> {}) has a non-finite or "
                                   "non-symmetric information matrix",
                                   i, e.source, e.target));
    if (!e.T_target_source.matrix().allFinite())
      throw InputError(fmt::format("pose graph: edge {} ({} -> {}) has a non-finite transform",
                                   i, e.source, e.target));
  }
}

struct SolveOutcome {
  std::vector<Isometry3d> nodes;
  int iterations = 0;
  bool usable = false;
};

SolveOutcome solve(const std::vector<Isometry3d>& initial, const std::vector<PoseGraphEdge>& edges,
                   double mu, const PoseGraphOptions& options) {
  const std::size_t n = initial.size();
  std::vector<std::array<double, 3>> p(n);
  std::vector<std::array<double, 4>> q(n);  // x y z w, Eigen's storage order
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d t = initial[i].translation();
    const Eigen::Quaterniond r(initial[i].linear());
    p[i] = {t.x(), t.y(), t.z()};
    q[i] = {r.x(), r.y(), r.z(), r.w()};
  }
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  for (const PoseGraphEdge& e : edges) {
    auto* cost = new ceres::AutoDiffCostFunction<EdgeCost, 6, 3, 4, 3, 4>(
        new EdgeCost(e.T_target_source, sqrt_information(e.information)));
    ceres::LossFunction* loss = e.uncertain ? new LineProcessLoss(mu) : nullptr;
    problem.AddResidualBlock(cost, loss, p[e.target].data(), q[e.target].data(),
                             p[e.source].data(), q[e.source].data());
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!problem.HasParameterBlock(p[i].data())) continue;  // an isolated node keeps its pose
    problem.SetManifold(q[i].data(), new ceres::EigenQuaternionManifold);
  }
  if (problem.HasParameterBlock(p[options.fixed_node].data())) {
    problem.SetParameterBlockConstant(p[options.fixed_node].data());
    problem.SetParameterBlockConstant(q[options.fixed_node].data());
  }
  ceres::Solver::Options solver;
  solver.max_num_iterations = options.max_iterations;
  solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  if (!ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE) &&
      !ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::EIGEN_SPARSE))
    solver.linear_solver_type = ceres::DENSE_QR;
  solver.num_threads = 1;
  solver.function_tolerance = 1e-12;
  solver.gradient_tolerance = 1e-14;
  solver.parameter_tolerance = 1e-12;
  solver.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);

  SolveOutcome out;
  out.iterations = static_cast<int>(summary.iterations.size());
  out.usable = summary.IsSolutionUsable();
  out.nodes.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    Isometry3d T = Isometry3d::Identity();
    T.linear() = Eigen::Quaterniond(q[i][3], q[i][0], q[i][1], q[i][2]).normalized()
                     .toRotationMatrix();
    T.translation() = Eigen::Vector3d(p[i][0], p[i][1], p[i][2]);
    out.nodes[i] = T;
  }
  return out;
}

}  // namespace

double edge_chi2(const PoseGraphEdge& edge, const std::vector<Isometry3d>& nodes) {
  const Isometry3d& T_w_t = nodes.at(edge.target);
  const Isometry3d& T_w_s = nodes.at(edge.source);
  const Eigen::Quaterniond q_t(T_w_t.linear()), q_s(T_w_s.linear());
  const Eigen::Quaterniond q_z(edge.T_target_source.linear());
  const Vector6d xi = edge_error<double>(q_t, T_w_t.translation(), q_s, T_w_s.translation(), q_z,
                                         edge.T_target_source.translation());
  return xi.dot(edge.information * xi);
}

EdgeJacobians edge_jacobians(const PoseGraphEdge& edge, const std::vector<Isometry3d>& nodes) {
  // Jets over the 12 perturbation parameters: delta_source (0-5), delta_target (6-11).
  using Jet = ceres::Jet<double, 12>;
  const auto perturbed = [](const Isometry3d& T, int first, Eigen::Quaternion<Jet>& q,
                            Eigen::Matrix<Jet, 3, 1>& p) {
    Jet rotation[3], q_delta[4];  // rotation vector; its quaternion (w, x, y, z)
    for (int i = 0; i < 3; ++i) rotation[i] = Jet(0.0, first + i);
    ceres::AngleAxisToQuaternion(rotation, q_delta);
    const Eigen::Quaternion<Jet> dq(q_delta[0], q_delta[1], q_delta[2], q_delta[3]);
    q = dq * Eigen::Quaterniond(T.linear()).cast<Jet>();
    p = dq * T.translation().cast<Jet>();
    for (int i = 0; i < 3; ++i) p[i] += Jet(0.0, first + 3 + i);
  };
  Eigen::Quaternion<Jet> q_s, q_t;
  Eigen::Matrix<Jet, 3, 1> p_s, p_t;
  perturbed(nodes.at(edge.source), 0, q_s, p_s);
  perturbed(nodes.at(edge.target), 6, q_t, p_t);
  const Eigen::Quaterniond q_z(edge.T_target_source.linear());
  const Eigen::Matrix<Jet, 6, 1> xi =
      edge_error<Jet>(q_t, p_t, q_s, p_s, q_z, edge.T_target_source.translation());
  EdgeJacobians J;
  for (int r = 0; r < 6; ++r) {
    J.source.row(r) = xi[r].v.head<6>().transpose();
    J.target.row(r) = xi[r].v.tail<6>().transpose();
  }
  return J;
}

PoseGraphResult optimize_pose_graph(PoseGraph& graph, const PoseGraphOptions& options) {
  check_graph(graph, options);
  PoseGraphResult result;
  if (graph.nodes.empty()) {
    result.success = true;
    return result;
  }
  const std::vector<Isometry3d> initial = graph.nodes;
  for (const PoseGraphEdge& e : graph.edges) result.initial_cost += edge_chi2(e, initial);

  // mu = preference * N_mean * d^2 over the loop edges (header, "Robustness").
  double correspondences = 0.0;
  std::size_t loops = 0;
  for (const PoseGraphEdge& e : graph.edges)
    if (e.uncertain) {
      correspondences += e.information.bottomRightCorner<3, 3>().trace() / 3.0;
      ++loops;
    }
  const double d = options.max_correspondence_distance;
  result.mu = loops ? options.preference_loop_closure * (correspondences / loops) * d * d : 0.0;
  if (loops && !(result.mu > 0.0)) result.mu = d * d;

  std::vector<PoseGraphEdge> edges = std::move(graph.edges);
  graph.edges.clear();
  const auto run = [&](const std::vector<PoseGraphEdge>& es) {
    SolveOutcome o = solve(initial, es, result.mu, options);
    ++result.solves;
    result.iterations += o.iterations;
    return o;
  };

  // 1. Robust solve; 2. prune loop edges whose line process fell below the threshold.
  SolveOutcome outcome = run(edges);
  if (!outcome.usable) {
    graph.edges = std::move(edges);
    result.reason = "Ceres found no usable solution";
    return result;
  }
  std::vector<PoseGraphEdge> kept;
  for (PoseGraphEdge& e : edges) {
    const double chi2 = edge_chi2(e, outcome.nodes);
    e.chi2 = chi2;
    e.confidence = e.uncertain ? std::pow(result.mu / (result.mu + chi2), 2) : 1.0;
    if (e.uncertain && e.confidence < options.prune_threshold) {
      result.rejected.push_back(
          {e, fmt::format("line process weight {:.3f} < {:.2f} (chi2 {:.4g}, mu {:.4g})",
                          e.confidence, options.prune_threshold, chi2, result.mu)});
    } else {
      kept.push_back(e);
    }
  }
  if (kept.size() != edges.size()) outcome = run(kept);

  // 3. Post-check: no odometry edge may be bent beyond the stated bound.
  for (;;) {
    result.max_odometry_bend_deg = 0.0;
    result.max_odometry_bend_m = 0.0;
    for (const PoseGraphEdge& e : kept) {
      if (e.uncertain) continue;
      const Isometry3d P = outcome.nodes[e.target].inverse() * outcome.nodes[e.source];
      result.max_odometry_bend_deg =
          std::max(result.max_odometry_bend_deg, rotation_difference_deg(P, e.T_target_source));
      result.max_odometry_bend_m =
          std::max(result.max_odometry_bend_m, translation_difference_m(P, e.T_target_source));
    }
    const bool within = result.max_odometry_bend_deg <= options.max_odometry_bend_deg &&
                        result.max_odometry_bend_m <= options.max_odometry_bend_m;
    if (within) break;
    std::size_t worst = kept.size();
    double worst_chi2 = -1.0;
    for (std::size_t i = 0; i < kept.size(); ++i) {
      if (!kept[i].uncertain) continue;
      const double chi2 = edge_chi2(kept[i], outcome.nodes);
      if (chi2 > worst_chi2) {
        worst_chi2 = chi2;
        worst = i;
      }
    }
    if (worst == kept.size()) break;  // only odometry left: the bend is the data's own
    result.rejected.push_back(
        {kept[worst],
         fmt::format("post-check: with it an odometry edge bends {:.3f} deg / {:.4f} m (bound "
                     "{:.3f} deg / {:.4f} m); it had the largest chi2 ({:.4g})",
                     result.max_odometry_bend_deg, result.max_odometry_bend_m,
                     options.max_odometry_bend_deg, options.max_odometry_bend_m, worst_chi2)});
    kept.erase(kept.begin() + static_cast<std::ptrdiff_t>(worst));
    outcome = run(kept);
  }

  for (PoseGraphEdge& e : kept) {
    e.chi2 = edge_chi2(e, outcome.nodes);
    e.confidence = e.uncertain ? std::pow(result.mu / (result.mu + e.chi2), 2) : 1.0;
    result.final_cost += e.chi2;
  }
  graph.nodes = std::move(outcome.nodes);
  graph.edges = std::move(kept);
  result.success = outcome.usable;
  if (!result.success) result.reason = "Ceres found no usable solution";
  return result;
}

}  // namespace locard
