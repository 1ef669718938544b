// Registration steps shared by the alignment stages (alignment_stages.hpp).
#include "alignment/alignment_stages.hpp"

#include <locard/preprocess/voxel_grid.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <numeric>

namespace locard::alignment_detail {

Target make_target(PointCloud fine, double voxel_size) {
  Target t;
  t.coarse = voxel_down_sample(fine, static_cast<float>(2.0 * voxel_size)).cloud;
  t.fine = std::move(fine);
  return t;
}

namespace {

IcpOptions plane_options(double voxel_size) {
  IcpOptions options;
  options.method = IcpMethod::PointToPlane;
  options.min_fitness = 0.0;  // acceptance is decided by the caller
  options.normal_radius = 2.5 * voxel_size;
  return options;
}

IcpResult run_level(const PointCloud& source, const PointCloud& target,
                    std::initializer_list<const IcpTarget*> prepared, const Isometry3d& init,
                    const IcpOptions& options) {
  for (const IcpTarget* p : prepared)
    if (p && options.method == p->method()) return icp(source, *p, init, options);
  return icp(source, target, init, options);
}

}  // namespace

void prepare_for_icp(Target& target, double voxel_size, IcpMethod method) {
  IcpOptions options = plane_options(voxel_size);
  const std::size_t min_points = std::max<std::size_t>(options.min_points, 3);
  if (target.coarse.size() >= min_points)
    target.coarse_icp = std::make_shared<const IcpTarget>(target.coarse, options);
  if (target.fine.size() < min_points) return;
  target.fine_icp = std::make_shared<const IcpTarget>(target.fine, options);
  if (method == IcpMethod::Colored && target.fine.has_colors()) {
    options.method = IcpMethod::Colored;
    options.max_correspondence_distance = voxel_size;  // refine()'s last level: its gradients
    target.fine_colored_icp = std::make_shared<const IcpTarget>(target.fine, options);
  }
}

IcpResult screen(const PointCloud& source_coarse, const Target& target, const Isometry3d& init,
                 const AlignmentOptions& o, const std::optional<IcpPosePrior>& prior) {
  IcpOptions options = plane_options(o.voxel_size);
  options.pose_prior = prior;
  options.max_correspondence_distance = 5.0 * o.voxel_size;
  options.convergence.max_iterations = 10;
  if (source_coarse.size() < options.min_points || target.coarse.size() < options.min_points) {
    IcpResult r;
    r.reason = "too few points";
    return r;
  }
  return run_level(source_coarse, target.coarse, {target.coarse_icp.get()}, init, options);
}

// The colour gradients are fitted once per frame: only the last level is coloured.
IcpResult refine(const PointCloud& source_fine, const PointCloud& source_coarse,
                 const Target& target, const Isometry3d& init, const AlignmentOptions& o,
                 IcpMethod method, const std::optional<IcpPosePrior>& prior) {
  const double v = o.voxel_size;
  IcpOptions options = plane_options(v);
  options.pose_prior = prior;
  const bool colored = method == IcpMethod::Colored && source_fine.has_colors() &&
                       target.fine.has_colors();
  const IcpTarget* last = colored ? target.fine_colored_icp.get() : target.fine_icp.get();
  const std::vector<IcpLevel> levels = {
      {"level 1 of 3", &source_coarse, &target.coarse, target.coarse_icp.get(),
       IcpMethod::PointToPlane, 4.0 * v, 30, true},
      {"level 2 of 3", &source_fine, &target.fine, target.fine_icp.get(), IcpMethod::PointToPlane,
       2.0 * v, 20, true},
      {"level 3 of 3", &source_fine, &target.fine, last,
       colored ? IcpMethod::Colored : IcpMethod::PointToPlane, v, 15, true}};
  return icp_levels(levels, init, options);
}

bool acceptable(const IcpResult& r, const AlignmentOptions& o, double min_fitness) {
  return r.success && r.fitness >= min_fitness &&
         r.inlier_rmse <= o.max_inlier_rmse_ratio * o.voxel_size;
}

std::string rejection(const IcpResult& r, const AlignmentOptions& o, double min_fitness) {
  if (!r.success) return "ICP failed: " + r.reason;
  return fmt::format("ICP fitness {:.3f} (need >= {:.2f}), inlier RMSE {:.4f} m (need <= {:.4f})",
                     r.fitness, min_fitness, r.inlier_rmse,
                     o.max_inlier_rmse_ratio * o.voxel_size);
}

bool better(const IcpResult& a, const IcpResult& b) {
  if (a.fitness != b.fitness) return a.fitness > b.fitness;
  return a.inlier_rmse < b.inlier_rmse;
}

GlobalRegistrationResult features(const PointCloud& source, const PointCloud& target,
                                  const Eigen::Vector3f& target_viewpoint,
                                  const AlignmentOptions& o, std::uint64_t salt) {
  GlobalRegistrationOptions g;
  g.voxel_size = o.feature_voxel_size;
  g.target_viewpoint = target_viewpoint;
  g.ransac.seed = o.seed + salt;
  g.ransac.max_iterations = 20000;
  g.ransac.confidence = 0.999;
  g.ransac.min_fitness = 0.2;
  return global_registration(source, target, g);
}

IcpMethod tracking_method(const AlignmentOptions& o) {
  return o.mode == AlignmentMode::Odometry ? o.odometry_method : o.tripod_method;
}

Eigen::Vector3d forward(const Isometry3d& T) { return T.linear().col(2); }

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.dot(b), -1.0, 1.0)) * 180.0 / M_PI;
}


}  // namespace locard::alignment_detail
