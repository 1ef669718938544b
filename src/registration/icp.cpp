// ICP: point-to-point, point-to-plane, coloured (Park et al. 2017). The residuals, Jacobians
// and frames are derived in include/locard/registration/icp.hpp; comments here point at them.
#include <locard/registration/icp.hpp>

#include <locard/core/error.hpp>
#include <locard/core/kdtree.hpp>
#include <locard/core/nearest_with_hints.hpp>
#include <locard/preprocess/normals.hpp>
#include <locard/preprocess/voxel_grid.hpp>
#include <locard/registration/color_gradient.hpp>
#include <locard/registration/rigid_transform.hpp>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <cmath>
#include <limits>
#include <numbers>

namespace locard {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;
constexpr double kDegToRad = std::numbers::pi / 180.0;

// Fixed chunk of the deterministic reductions: the split tree depends only on the point
// count, so the floating-point sums are the same for any thread count.
constexpr std::size_t kGrain = 1024;

// Source: finite points, centred at their centroid (float storage, double arithmetic).
struct PreparedSource {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3f> points;
  std::vector<float> intensity;  // coloured ICP only
  std::size_t non_finite = 0;
};

// Target: finite points centred at their centroid inside a kd-tree, plus what the method
// needs per point.
struct PreparedTarget {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  KdTree tree;
  std::vector<Eigen::Vector3f> normals;   // point-to-plane, coloured
  std::vector<float> intensity;           // coloured
  std::vector<Eigen::Vector3f> gradient;  // coloured: d_t, Park eq. 10
  std::size_t non_finite = 0;
  bool normals_estimated = false;
};

bool needs_normals(IcpMethod m) { return m != IcpMethod::PointToPoint; }

void check_options(const IcpOptions& o) {
  const auto bad = [](const std::string& what) { throw InputError("ICP options: " + what); };
  if (!(o.max_correspondence_distance > 0.0) || !std::isfinite(o.max_correspondence_distance))
    bad(fmt::format("max_correspondence_distance must be a positive number of metres, got {}",
                    o.max_correspondence_distance));
  if (o.kernel.type != RobustKernelType::None &&
      (!(o.kernel.scale > 0.0) || !std::isfinite(o.kernel.scale)))
    bad(fmt::format("the {} kernel needs a positive scale, got {}", to_string(o.kernel.type),
                    o.kernel.scale));
  if (o.convergence.max_iterations < 0)
    bad(fmt::format("max_iterations must be >= 0, got {}", o.convergence.max_iterations));
  if (!(o.lambda_geometric >= 0.0 && o.lambda_geometric <= 1.0))
    bad(fmt::format("lambda_geometric must be in [0, 1], got {}", o.lambda_geometric));
  if (o.min_correspondences < 3) bad("min_correspondences must be at least 3");
  if (const auto& p = o.pose_prior) {
    if (o.method == IcpMethod::PointToPoint)
      bad("a pose prior needs point-to-plane or coloured ICP (point-to-point is solved in "
          "closed form)");
    if (!p->T_target_source.matrix().allFinite()) bad("the pose prior has NaN/Inf entries");
    const auto spread = [](double v) { return v >= 0.0 && std::isfinite(v); };
    if (!spread(p->centre_sigma_m) || !spread(p->rotation_sigma_deg) ||
        !(p->point_sigma_m > 0.0) || !std::isfinite(p->point_sigma_m) ||
        (p->centre_sigma_m == 0.0 && p->rotation_sigma_deg == 0.0))
      bad(fmt::format("the pose prior needs spreads >= 0 (not both 0) and a positive point "
                      "spread, got centre {} m, rotation {} deg, point {} m",
                      p->centre_sigma_m, p->rotation_sigma_deg, p->point_sigma_m));
    if (p->hinge_axis && (!p->hinge_axis->allFinite() ||
                          std::abs(p->hinge_axis->norm() - 1.0) > 1e-6 ||
                          !(p->off_axis_sigma_deg > 0.0) || !std::isfinite(p->off_axis_sigma_deg) ||
                          !(p->rotation_sigma_deg > 0.0)))
      bad(fmt::format("the pose prior's hinge axis must be a unit vector with a positive "
                      "off-axis spread and a positive rotation spread, got |axis| {}, off-axis "
                      "{} deg, rotation {} deg",
                      p->hinge_axis->norm(), p->off_axis_sigma_deg, p->rotation_sigma_deg));
  }
}

void check_count(const char* which, std::size_t finite, std::size_t dropped,
                 std::size_t needed) {
  if (finite >= needed) return;
  throw InputError(fmt::format(
      "ICP: the {} cloud has {} usable point{}{}; at least {} are needed", which, finite,
      finite == 1 ? "" : "s",
      dropped ? fmt::format(" ({} with NaN/Inf coordinates dropped)", dropped) : "", needed));
}

Eigen::Vector3d centroid_of(const std::vector<Eigen::Vector3f>& pts,
                            const std::vector<std::uint32_t>& keep) {
  // Parallel deterministic sum in double.
  const Eigen::Vector3d sum = tbb::parallel_deterministic_reduce(
      tbb::blocked_range<std::size_t>(0, keep.size(), 8192), Eigen::Vector3d::Zero().eval(),
      [&](const tbb::blocked_range<std::size_t>& r, Eigen::Vector3d acc) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) acc += pts[keep[i]].cast<double>();
        return acc;
      },
      [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) -> Eigen::Vector3d {
        return a + b;
      });
  return keep.empty() ? Eigen::Vector3d::Zero() : (sum / static_cast<double>(keep.size())).eval();
}

std::vector<std::uint32_t> finite_indices(const PointCloud& cloud, bool with_normals) {
  std::vector<std::uint32_t> keep;
  keep.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!cloud.positions[i].allFinite()) continue;
    if (with_normals && !cloud.normals[i].allFinite()) continue;
    keep.push_back(static_cast<std::uint32_t>(i));
  }
  return keep;
}

PreparedSource prepare_source(const PointCloud& cloud, const IcpOptions& o) {
  cloud.check_consistent();
  PreparedSource s;
  const std::vector<std::uint32_t> keep = finite_indices(cloud, false);
  s.non_finite = cloud.size() - keep.size();
  check_count("source", keep.size(), s.non_finite, std::max<std::size_t>(o.min_points, 3));
  s.centroid = centroid_of(cloud.positions, keep);
  s.points.resize(keep.size());
  const bool color = o.method == IcpMethod::Colored;
  if (color) s.intensity.resize(keep.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, keep.size(), 4096), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      s.points[i] = (cloud.positions[keep[i]].cast<double>() - s.centroid).cast<float>();
      if (color) s.intensity[i] = intensity_of(cloud.colors[keep[i]]);
    }
  });
  return s;
}

PreparedTarget prepare_target(const PointCloud& cloud, const IcpOptions& o) {
  cloud.check_consistent();
  PreparedTarget t;
  const bool use_normals = needs_normals(o.method);
  const bool has_normals = use_normals && cloud.has_normals();
  const std::vector<std::uint32_t> keep = finite_indices(cloud, has_normals);
  t.non_finite = cloud.size() - keep.size();
  check_count("target", keep.size(), t.non_finite, std::max<std::size_t>(o.min_points, 3));
  t.centroid = centroid_of(cloud.positions, keep);
  const bool color = o.method == IcpMethod::Colored;
  std::vector<Eigen::Vector3f> centred(keep.size());
  if (has_normals) t.normals.resize(keep.size());
  if (color) t.intensity.resize(keep.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, keep.size(), 4096), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      centred[i] = (cloud.positions[keep[i]].cast<double>() - t.centroid).cast<float>();
      if (has_normals) t.normals[i] = cloud.normals[keep[i]];
      if (color) t.intensity[i] = intensity_of(cloud.colors[keep[i]]);
    }
  });
  if (use_normals && !has_normals) {
    // Local PCA normals on the centred points, oriented towards the target frame's origin.
    PointCloud tmp;
    tmp.positions = centred;
    t.tree = KdTree(std::move(centred));
    NormalOptions nopt;
    nopt.radius = static_cast<float>(o.normal_radius);
    nopt.max_neighbors = o.normal_max_neighbors;
    nopt.orientation = NormalOrientation::TowardsViewpoint;
    nopt.viewpoint = (-t.centroid).cast<float>();
    estimate_normals(tmp, nopt, &t.tree);
    t.normals = std::move(tmp.normals);
    t.normals_estimated = true;
  } else {
    t.tree = KdTree(std::move(centred));
  }
  if (color) {
    const double radius = o.color_gradient_radius > 0.0 ? o.color_gradient_radius
                                                        : 2.0 * o.max_correspondence_distance;
    t.gradient = color_gradients(t.tree, t.normals, t.intensity, radius,
                                 o.color_gradient_max_neighbors);
  }
  return t;
}

// Everything one pass over the source accumulates. H is kept upper-triangular during the
// reduction and mirrored before use.
struct PassSums {
  Matrix6d H = Matrix6d::Zero();  // Gauss-Newton (point-to-plane, coloured)
  Vector6d b = Vector6d::Zero();
  RigidTransformAccumulator kabsch;  // point-to-point step
  // Point-to-point Hessian moments: sum w, sum w q, sum w q q^T (H = sum w [-[q]x I]^T [..]).
  double w_sum = 0.0;
  Eigen::Vector3d wq = Eigen::Vector3d::Zero();
  Eigen::Matrix3d wqq = Eigen::Matrix3d::Zero();
  // Information-matrix moments of the matched target points: n, sum t, sum t t^T.
  Eigen::Vector3d t_sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d tt_sum = Eigen::Matrix3d::Zero();
  double squared_distance = 0.0;  // sum |q - t|^2
  std::size_t count = 0;

  void join(const PassSums& o) {
    H += o.H;
    b += o.b;
    kabsch.merge(o.kabsch);
    w_sum += o.w_sum;
    wq += o.wq;
    wqq += o.wqq;
    t_sum += o.t_sum;
    tt_sum += o.tt_sum;
    squared_distance += o.squared_distance;
    count += o.count;
  }
};

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// sum_i w_i G_i^T G_i with G_i = [-[p_i]x  I], from the moments W = sum w, m = sum w p,
// M = sum w p p^T. Blocks: [-[p]x]^T [-[p]x] = |p|^2 I - p p^T, [-[p]x]^T I = [p]x.
Matrix6d point_hessian(double W, const Eigen::Vector3d& m, const Eigen::Matrix3d& M) {
  Matrix6d H;
  H.topLeftCorner<3, 3>() = M.trace() * Eigen::Matrix3d::Identity() - M;
  H.topRightCorner<3, 3>() = skew(m);
  H.bottomLeftCorner<3, 3>() = skew(m).transpose();
  H.bottomRightCorner<3, 3>() = W * Eigen::Matrix3d::Identity();
  return H;
}

// A 6x6 matrix in (rotation, translation) order for left perturbations of the centred target
// frame, expressed in the target frame: with c the target centroid, a point Jacobian becomes
// [-[q + c]x  I] = [-[q]x  I] A, A = [[I, 0], [-[c]x, I]], so H_target = A^T H_centred A.
Matrix6d to_target_frame(const Matrix6d& H, const Eigen::Vector3d& c) {
  Matrix6d A = Matrix6d::Identity();
  A.bottomLeftCorner<3, 3>() = -skew(c);
  return A.transpose() * H * A;
}

// H += w J J^T (upper triangle only), b += w r J. Written out: Eigen's rankUpdate is a call
// into a generic kernel, too heavy for one 6-vector per correspondence.
inline void add_weighted(PassSums& acc, const Vector6d& J, double w, double r) {
  const Vector6d wJ = w * J;
  for (int c = 0; c < 6; ++c)
    for (int row = 0; row <= c; ++row) acc.H(row, c) += wJ(row) * J(c);
  acc.b += r * wJ;
}

struct PassContext {
  const PreparedSource& source;
  const PreparedTarget& target;
  const IcpOptions& options;
  // Search hints, optional (see run_pass): each source point's previous correspondence
  // (NearestWithHints::kNoHint if none) and the target's hinted search over them.
  std::vector<std::uint32_t>* previous = nullptr;
  const NearestWithHints* hinted = nullptr;
};

// One pass at the estimate T_c (centred frames): correspondences and the sums of the method.
template <IcpMethod M>
PassSums run_pass(const PassContext& ctx, const Isometry3d& T_c) {
  const Eigen::Matrix3d R = T_c.linear();
  const Eigen::Vector3d tr = T_c.translation();
  const auto& src = ctx.source.points;
  const auto& tpts = ctx.target.tree.points();
  const KdTree& tree = ctx.target.tree;
  const float max_d = static_cast<float>(ctx.options.max_correspondence_distance);
  const RobustKernel kernel = ctx.options.kernel;
  const double sqrt_lg = std::sqrt(ctx.options.lambda_geometric);
  const double sqrt_lc = std::sqrt(1.0 - ctx.options.lambda_geometric);

  return tbb::parallel_deterministic_reduce(
      tbb::blocked_range<std::size_t>(0, src.size(), kGrain), PassSums{},
      [&](const tbb::blocked_range<std::size_t>& r, PassSums acc) {
        Neighbor nb;
        std::vector<Neighbor> scratch;
        std::uint32_t* previous = ctx.previous ? ctx.previous->data() : nullptr;
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          const Eigen::Vector3d q = R * src[i].cast<double>() + tr;
          const Eigen::Vector3f qf = q.cast<float>();
          // From the previous correspondence where there is one (exact: nearest_with_hints.hpp).
          const bool found = ctx.hinted ? ctx.hinted->nearest(qf, max_d, previous[i], nb, scratch)
                                        : tree.nearest(qf, nb, max_d);
          if (!found) continue;
          const Eigen::Vector3d t = tpts[nb.index].cast<double>();
          const Eigen::Vector3d diff = q - t;
          acc.squared_distance += diff.squaredNorm();
          ++acc.count;
          acc.t_sum += t;
          acc.tt_sum.noalias() += t * t.transpose();
          if constexpr (M == IcpMethod::PointToPoint) {
            // r = q - t; IRLS weight on |r|.
            const double w = kernel.weight(diff.norm());
            acc.kabsch.add(q, t, w);
            acc.w_sum += w;
            acc.wq += w * q;
            acc.wqq.noalias() += (w * q) * q.transpose();
          } else {
            // Geometric residual r_G = n . (q - t), J_G = [q x n, n].
            const Eigen::Vector3d n = ctx.target.normals[nb.index].cast<double>();
            Vector6d J;
            double res = n.dot(diff);
            if constexpr (M == IcpMethod::Colored) {
              J << sqrt_lg * q.cross(n), sqrt_lg * n;
              res *= sqrt_lg;
            } else {
              J << q.cross(n), n;
            }
            double w = kernel.weight(res);
            add_weighted(acc, J, w, res);
            if constexpr (M == IcpMethod::Colored) {
              // Photometric residual r_C = C(t) + d . (f(q) - t) - C_s, f(q) the projection
              // of q on the tangent plane of t; dr_C/dq = g^T, g = (I - n n^T) d.
              const Eigen::Vector3d d = ctx.target.gradient[nb.index].cast<double>();
              const Eigen::Vector3d proj = diff - n * n.dot(diff);  // f(q) - t
              const double rc = sqrt_lc * (ctx.target.intensity[nb.index] + d.dot(proj) -
                                           ctx.source.intensity[i]);
              const Eigen::Vector3d g = sqrt_lc * (d - n * n.dot(d));
              J << q.cross(g), g;
              w = kernel.weight(rc);
              add_weighted(acc, J, w, rc);
            }
          }
        }
        return acc;
      },
      [](PassSums a, const PassSums& b) {
        a.join(b);
        return a;
      });
}

PassSums run_pass(const PassContext& ctx, const Isometry3d& T_c) {
  switch (ctx.options.method) {
    case IcpMethod::PointToPoint:
      return run_pass<IcpMethod::PointToPoint>(ctx, T_c);
    case IcpMethod::PointToPlane:
      return run_pass<IcpMethod::PointToPlane>(ctx, T_c);
    case IcpMethod::Colored:
      return run_pass<IcpMethod::Colored>(ctx, T_c);
  }
  return {};
}

Matrix6d full_hessian(const PassSums& s, IcpMethod method) {
  if (method == IcpMethod::PointToPoint) return point_hessian(s.w_sum, s.wq, s.wqq);
  Matrix6d H = s.H;
  H.triangularView<Eigen::StrictlyLower>() = H.transpose();
  return H;
}

// The centre prior's share of the normal equations at T_c (icp.hpp, "Centre prior"), in the
// centred frame: q0 is where the source origin lies now, p where the prior puts it.
struct PriorTerm {
  Matrix6d H = Matrix6d::Zero();
  Vector6d b = Vector6d::Zero();
};

PriorTerm prior_term(const IcpPosePrior& prior, const Isometry3d& T_c,
                     const Eigen::Vector3d& ct, const Eigen::Vector3d& cs,
                     std::size_t correspondences) {
  PriorTerm term;
  const double scale = prior.per_correspondence ? static_cast<double>(correspondences) : 1.0;
  if (prior.centre_sigma_m > 0.0) {
    const Eigen::Vector3d q0 = T_c * (-cs);
    const Eigen::Vector3d r = q0 - (prior.T_target_source.translation() - ct);
    Eigen::Matrix<double, 3, 6> J;
    J.leftCols<3>() = -skew(q0);
    J.rightCols<3>() = Eigen::Matrix3d::Identity();
    const double w = scale * std::pow(prior.point_sigma_m / prior.centre_sigma_m, 2);
    term.H += w * J.transpose() * J;
    term.b += w * J.transpose() * r;
  }
  if (prior.rotation_sigma_deg > 0.0) {
    const Eigen::AngleAxisd d(T_c.linear() * prior.T_target_source.linear().transpose());
    const Eigen::Vector3d r = d.angle() * d.axis();
    const double w =
        scale * std::pow(prior.point_sigma_m / (prior.rotation_sigma_deg * kDegToRad), 2);
    Eigen::Matrix3d W = w * Eigen::Matrix3d::Identity();
    if (prior.hinge_axis) {
      const Eigen::Matrix3d along = *prior.hinge_axis * prior.hinge_axis->transpose();
      const double w_off = static_cast<double>(correspondences) *
                           std::pow(prior.point_sigma_m / (prior.off_axis_sigma_deg * kDegToRad), 2);
      W = w * along + w_off * (Eigen::Matrix3d::Identity() - along);
    }
    term.H.topLeftCorner<3, 3>() += W;
    term.b.head<3>() += W * r;
  }
  return term;
}

// The update dT from one pass (see icp.hpp), or an error message.
std::optional<Isometry3d> solve_step(const PassSums& s, IcpMethod method, const PriorTerm* prior,
                                     std::string& why) {
  if (method == IcpMethod::PointToPoint) {
    const auto dT = s.kabsch.solve();
    if (!dT) why = "the correspondences are degenerate (collinear or all weights zero)";
    return dT;
  }
  Matrix6d H = full_hessian(s, method);
  Vector6d b = s.b;
  if (prior) {
    H += prior->H;
    b += prior->b;
  }
  // A (numerically) singular H means the geometry leaves a motion unconstrained (a plane
  // against a plane, a cylinder along its axis): the step would be arbitrary, so say so.
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(H, Eigen::EigenvaluesOnly);
  const double lmax = eig.eigenvalues()(5), lmin = eig.eigenvalues()(0);
  if (!(lmax > 0.0) || !(lmin > 1e-12 * lmax)) {
    why = fmt::format(
        "the normal equations are singular (eigenvalues {:.3g} .. {:.3g}): the overlap does "
        "not constrain all six degrees of freedom",
        lmin, lmax);
    return std::nullopt;
  }
  const Vector6d xi = H.ldlt().solve(-b);
  if (!xi.allFinite()) {
    why = "the Gauss-Newton step is not finite";
    return std::nullopt;
  }
  // T <- [exp(omega) | v] T (left perturbation, first-order consistent with J).
  Isometry3d dT = Isometry3d::Identity();
  const Eigen::Vector3d omega = xi.head<3>();
  const double angle = omega.norm();
  if (angle > 0.0) dT.linear() = Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix();
  dT.translation() = xi.tail<3>();
  return dT;
}

double rotation_angle_deg(const Eigen::Matrix3d& R) {
  const double c = std::clamp((R.trace() - 1.0) / 2.0, -1.0, 1.0);
  return std::acos(c) * 180.0 / std::numbers::pi;
}

// T_c = T(-c_t) T_target_source T(c_s) and back.
Isometry3d to_centred(const Isometry3d& T, const Eigen::Vector3d& ct, const Eigen::Vector3d& cs) {
  Isometry3d Tc = T;
  Tc.translation() = T.linear() * cs + T.translation() - ct;
  return Tc;
}
Isometry3d from_centred(const Isometry3d& Tc, const Eigen::Vector3d& ct,
                        const Eigen::Vector3d& cs) {
  Isometry3d T = Tc;
  T.translation() = Tc.translation() + ct - Tc.linear() * cs;
  return T;
}

IcpResult run_icp(const PreparedSource& source, const PreparedTarget& target,
                  const Isometry3d& init_T_target_source, const IcpOptions& o) {
  IcpResult result;
  result.method = o.method;
  result.source_points = source.points.size();
  result.target_points = target.tree.size();
  result.source_non_finite = source.non_finite;
  result.target_non_finite = target.non_finite;
  result.target_normals_estimated = target.normals_estimated;

  std::vector<std::uint32_t> previous(source.points.size(), NearestWithHints::kNoHint);
  const NearestWithHints hinted(target.tree);
  const PassContext ctx{source, target, o, &previous, &hinted};
  const double n_source = static_cast<double>(source.points.size());
  Isometry3d T_c = to_centred(init_T_target_source, target.centroid, source.centroid);
  const auto fitness_of = [&](const PassSums& s) { return s.count / n_source; };
  const auto rmse_of = [](const PassSums& s) {
    return s.count ? std::sqrt(s.squared_distance / static_cast<double>(s.count)) : 0.0;
  };

  PassSums final_sums;
  double prev_fitness = 0.0, prev_rmse = 0.0;
  const int max_iter = o.convergence.max_iterations;
  for (int k = 0;; ++k) {
    PassSums sums = run_pass(ctx, T_c);
    const double fit = fitness_of(sums), rmse = rmse_of(sums);
    if (sums.count < o.min_correspondences) {
      result.T_target_source = from_centred(T_c, target.centroid, source.centroid);
      result.fitness = fit;
      result.inlier_rmse = rmse;
      result.correspondences = sums.count;
      result.reason =
          k == 0 ? fmt::format("{} correspondence{} within {} m at the initial pose (at least "
                               "{} needed): the clouds do not overlap there",
                               sums.count, sums.count == 1 ? "" : "s",
                               o.max_correspondence_distance, o.min_correspondences)
                 : fmt::format("only {} correspondences left after {} iterations (at least {} "
                               "needed): ICP diverged",
                               sums.count, k, o.min_correspondences);
      return result;
    }
    if (k > 0 && std::abs(fit - prev_fitness) < o.convergence.relative_fitness &&
        std::abs(rmse - prev_rmse) < o.convergence.relative_rmse) {
      result.converged = true;
      final_sums = std::move(sums);
      break;
    }
    if (k == max_iter) {
      final_sums = std::move(sums);
      break;
    }
    std::string why;
    std::optional<PriorTerm> prior;
    if (o.pose_prior) prior = prior_term(*o.pose_prior, T_c, target.centroid, source.centroid, sums.count);
    const auto dT = solve_step(sums, o.method, prior ? &*prior : nullptr, why);
    if (!dT) {
      result.T_target_source = from_centred(T_c, target.centroid, source.centroid);
      result.fitness = fit;
      result.inlier_rmse = rmse;
      result.correspondences = sums.count;
      result.iterations = k;
      result.reason = fmt::format("iteration {}: {}", k + 1, why);
      return result;
    }
    T_c = *dT * T_c;
    // Re-orthonormalise now and then against drift from repeated products.
    T_c.linear() = Eigen::Quaterniond(T_c.linear()).normalized().toRotationMatrix();
    result.iterations = k + 1;
    if (rotation_angle_deg(dT->linear()) < o.convergence.rotation_eps_deg &&
        dT->translation().norm() < o.convergence.translation_eps_m) {
      result.converged = true;
      final_sums = run_pass(ctx, T_c);
      break;
    }
    prev_fitness = fit;
    prev_rmse = rmse;
  }

  result.T_target_source = from_centred(T_c, target.centroid, source.centroid);
  result.correspondences = final_sums.count;
  result.fitness = fitness_of(final_sums);
  result.inlier_rmse = rmse_of(final_sums);
  result.information = to_target_frame(
      point_hessian(static_cast<double>(final_sums.count), final_sums.t_sum, final_sums.tt_sum),
      target.centroid);
  result.hessian = to_target_frame(full_hessian(final_sums, o.method), target.centroid);
  if (!result.T_target_source.matrix().allFinite()) {
    result.reason = "the estimate is not finite";
    return result;
  }
  if (final_sums.count < o.min_correspondences) {
    result.reason = fmt::format("only {} correspondences at the final pose (at least {} needed)",
                                final_sums.count, o.min_correspondences);
    return result;
  }
  if (result.fitness < o.min_fitness) {
    result.reason = fmt::format(
        "fitness {:.4f} is below min_fitness {:.4f}: too few source points lie within {} m of "
        "the target at the registered pose",
        result.fitness, o.min_fitness, o.max_correspondence_distance);
    return result;
  }
  result.success = true;
  return result;
}

}  // namespace

std::string_view to_string(IcpMethod method) {
  switch (method) {
    case IcpMethod::PointToPoint:
      return "point-to-point";
    case IcpMethod::PointToPlane:
      return "point-to-plane";
    case IcpMethod::Colored:
      return "colored";
  }
  return "point-to-plane";
}

std::optional<IcpMethod> parse_icp_method(std::string_view name) {
  if (name == "point-to-point") return IcpMethod::PointToPoint;
  if (name == "point-to-plane") return IcpMethod::PointToPlane;
  if (name == "colored" || name == "coloured") return IcpMethod::Colored;
  return std::nullopt;
}

namespace {

void check_inputs(const PointCloud& source, bool target_has_colors,
                  const Isometry3d& init_T_target_source, const IcpOptions& options) {
  check_options(options);
  if (!init_T_target_source.matrix().allFinite())
    throw InputError("ICP: the initial transform has NaN/Inf entries");
  if (options.method == IcpMethod::Colored && (!source.has_colors() || !target_has_colors))
    throw InputError(fmt::format(
        "coloured ICP needs colours on both clouds; the {} has none (use point-to-plane)",
        !source.has_colors() ? (!target_has_colors ? "source and the target" : "source")
                             : "target"));
}

IcpResult run_single(const PointCloud& source, const PreparedTarget& target,
                     const Isometry3d& init_T_target_source, const IcpOptions& options) {
  const PreparedSource source_prepared = prepare_source(source, options);
  IcpResult result = run_icp(source_prepared, target, init_T_target_source, options);
  result.levels.push_back({0.0, options.max_correspondence_distance, result.source_points,
                           result.target_points, result.iterations, result.converged,
                           result.fitness, result.inlier_rmse});
  return result;
}

}  // namespace

IcpResult icp(const PointCloud& source, const PointCloud& target,
              const Isometry3d& init_T_target_source, const IcpOptions& options) {
  check_inputs(source, target.has_colors(), init_T_target_source, options);
  return run_single(source, prepare_target(target, options), init_T_target_source, options);
}

struct IcpTarget::Prepared {
  PreparedTarget target;
  IcpMethod method;
  bool has_colors;
};

IcpTarget::IcpTarget(const PointCloud& target, const IcpOptions& options) {
  check_options(options);
  if (options.method == IcpMethod::Colored && !target.has_colors())
    throw InputError("coloured ICP needs colours on both clouds; the target has none (use "
                     "point-to-plane)");
  prepared_ = std::make_shared<const Prepared>(
      Prepared{prepare_target(target, options), options.method, target.has_colors()});
}

IcpMethod IcpTarget::method() const { return prepared_->method; }
std::size_t IcpTarget::size() const { return prepared_->target.tree.size(); }

IcpResult icp(const PointCloud& source, const IcpTarget& target,
              const Isometry3d& init_T_target_source, const IcpOptions& options) {
  if (options.method != target.method())
    throw InputError(fmt::format("ICP: the target was prepared for {} but the options ask for {}",
                                 to_string(target.method()), to_string(options.method)));
  check_inputs(source, target.prepared_->has_colors, init_T_target_source, options);
  return run_single(source, target.prepared_->target, init_T_target_source, options);
}

IcpResult icp_levels(const std::vector<IcpLevel>& levels, const Isometry3d& init_T_target_source,
                     const IcpOptions& options) {
  Isometry3d T = init_T_target_source;
  IcpResult result;
  std::vector<IcpLevelReport> reports;
  int total_iterations = 0;
  IcpOptions lo = options;
  for (const IcpLevel& level : levels) {
    lo.method = level.method;
    lo.max_correspondence_distance = level.max_correspondence_distance;
    lo.convergence.max_iterations = level.max_iterations;
    if (level.normal_radius > 0.0) {
      lo.normal_radius = level.normal_radius;
      lo.normal_max_neighbors = level.normal_max_neighbors;
    } else {
      lo.normal_radius = options.normal_radius;
      lo.normal_max_neighbors = options.normal_max_neighbors;
    }
    if (level.skip_if_small && (level.source->size() < options.min_points ||
                                level.target->size() < options.min_points)) {
      result = IcpResult{};
      result.reason = level.name + ": too few points";
      break;
    }
    try {
      result = level.prepared && level.prepared->method() == lo.method
                   ? icp(*level.source, *level.prepared, T, lo)
                   : icp(*level.source, *level.target, T, lo);
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}: {}", level.name, e.what()));
    }
    total_iterations += result.iterations;
    reports.insert(reports.end(), result.levels.begin(), result.levels.end());
    if (!result.success) {
      result.reason = fmt::format("{}: {}", level.name, result.reason);
      break;
    }
    T = result.T_target_source;
  }
  result.iterations = total_iterations;
  result.levels = std::move(reports);
  return result;
}

IcpResult icp_multiscale(const PointCloud& source, const PointCloud& target,
                         const Isometry3d& init_T_target_source, const IcpOptions& options,
                         const std::vector<IcpScale>& scales) {
  if (scales.empty()) throw InputError("multi-scale ICP: the schedule has no levels");
  for (const IcpScale& s : scales)
    if (!(s.voxel_size >= 0.0) || !std::isfinite(s.voxel_size))
      throw InputError(fmt::format("multi-scale ICP: voxel size {} is not >= 0", s.voxel_size));
  // Judge the inputs before any voxel grid hides their non-finite points.
  for (const auto& [cloud, which] : {std::pair{&source, "source"}, std::pair{&target, "target"}}) {
    std::size_t finite = 0;
    for (const auto& p : cloud->positions) finite += p.allFinite();
    check_count(which, finite, cloud->size() - finite, std::max<std::size_t>(options.min_points, 3));
  }
  // Each level's clouds (voxel grid, sized up front so the pointers stay valid) and normals.
  std::vector<VoxelGridResult> grids(2 * scales.size());
  std::vector<IcpLevel> levels(scales.size());
  IcpResult result;
  try {
    for (std::size_t k = 0; k < scales.size(); ++k) {
      const IcpScale& s = scales[k];
      IcpLevel& level = levels[k];
      level.name = fmt::format("level {} of {} (voxel {} m)", k + 1, scales.size(), s.voxel_size);
      level.method = options.method;
      level.max_correspondence_distance = s.max_correspondence_distance;
      level.max_iterations = s.max_iterations;
      level.source = &source;
      level.target = &target;
      if (s.voxel_size <= 0.0) continue;
      grids[2 * k] = voxel_down_sample(source, static_cast<float>(s.voxel_size));
      grids[2 * k + 1] = voxel_down_sample(target, static_cast<float>(s.voxel_size));
      level.source = &grids[2 * k].cloud;
      level.target = &grids[2 * k + 1].cloud;
      if (options.normal_radius <= 0.0) {
        level.normal_radius = 2.0 * s.voxel_size;
        level.normal_max_neighbors = 30;
      }
    }
    result = icp_levels(levels, init_T_target_source, options);
  } catch (const InputError& e) {
    throw InputError(fmt::format("multi-scale ICP, {}", e.what()));
  }
  // The reports carry the grid's voxel, the result the non-finite points of the level that ran
  // last (a voxel grid drops them before ICP sees them).
  for (std::size_t k = 0; k < result.levels.size(); ++k)
    result.levels[k].voxel_size = scales[k].voxel_size;
  const std::size_t last = result.levels.size() - 1;
  if (scales[last].voxel_size > 0.0) {
    result.source_non_finite = grids[2 * last].report.non_finite;
    result.target_non_finite = grids[2 * last + 1].report.non_finite;
  }
  return result;
}

Eigen::Matrix<double, 6, 6> information_matrix(const PointCloud& source,
                                               const PointCloud& target,
                                               const Isometry3d& T_target_source,
                                               double max_distance) {
  IcpOptions o;
  o.method = IcpMethod::PointToPoint;
  o.max_correspondence_distance = max_distance;
  o.min_points = 1;
  check_options(o);
  const PreparedTarget t = prepare_target(target, o);
  const PreparedSource s = prepare_source(source, o);
  const PassContext ctx{s, t, o};
  const PassSums sums =
      run_pass<IcpMethod::PointToPoint>(ctx, to_centred(T_target_source, t.centroid, s.centroid));
  return to_target_frame(point_hessian(static_cast<double>(sums.count), sums.t_sum, sums.tt_sum),
                         t.centroid);
}

}  // namespace locard
