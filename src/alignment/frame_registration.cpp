// Registration steps shared by the alignment stages (alignment_stages.hpp).
#include "alignment/alignment_stages.hpp"

#include <locard/preprocess/voxel_grid.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace locard::alignment_detail {

Target make_target(PointCloud fine, double voxel_size) {
  Target t;
  t.coarse = voxel_down_sample(fine, static_cast<float>(2.0 * voxel_size)).cloud;
  t.fine = std::move(fine);
  return t;
}

// The colour gradients are fitted once per frame: only the last level is coloured.
IcpResult refine(const PointCloud& source_fine, const PointCloud& source_coarse,
                 const Target& target, const Isometry3d& init, const AlignmentOptions& o,
                 IcpMethod method) {
  const double v = o.voxel_size;
  IcpOptions options;
  options.method = IcpMethod::PointToPlane;
  options.min_fitness = 0.0;  // acceptance is decided by the caller
  options.normal_radius = 2.5 * v;
  struct Level {
    const PointCloud* source;
    const PointCloud* target;
    double gate;
    int iterations;
  };
  const Level levels[3] = {{&source_coarse, &target.coarse, 4.0 * v, 30},
                           {&source_fine, &target.fine, 2.0 * v, 20},
                           {&source_fine, &target.fine, v, 15}};
  Isometry3d T = init;
  IcpResult r;
  int iterations = 0;
  for (int level = 0; level < 3; ++level) {
    options.max_correspondence_distance = levels[level].gate;
    options.convergence.max_iterations = levels[level].iterations;
    if (level == 2 && method == IcpMethod::Colored && source_fine.has_colors() &&
        target.fine.has_colors())
      options.method = IcpMethod::Colored;
    if (levels[level].source->size() < options.min_points ||
        levels[level].target->size() < options.min_points) {
      r.success = false;
      r.reason = fmt::format("level {}: too few points", level + 1);
      return r;
    }
    r = icp(*levels[level].source, *levels[level].target, T, options);
    iterations += r.iterations;
    if (!r.success) {
      r.reason = fmt::format("level {} of 3: {}", level + 1, r.reason);
      break;
    }
    T = r.T_target_source;
  }
  r.iterations = iterations;
  return r;
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
  return o.mode == AlignmentMode::Odometry ? o.odometry_method : IcpMethod::PointToPlane;
}

Eigen::Vector3d forward(const Isometry3d& T) { return T.linear().col(2); }

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.dot(b), -1.0, 1.0)) * 180.0 / M_PI;
}

Components::Components(std::size_t n) : parent(n) {
  std::iota(parent.begin(), parent.end(), 0);
}

std::size_t Components::find(std::size_t x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

void Components::join(std::size_t a, std::size_t b) {
  a = find(a);
  b = find(b);
  if (a != b) parent[std::max(a, b)] = std::min(a, b);
}

}  // namespace locard::alignment_detail
