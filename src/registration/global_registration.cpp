// Feature-based global registration: voxel grid, normals, FPFH, matching, RANSAC.
#include <locard/registration/global_registration.hpp>

#include <locard/core/error.hpp>
#include <locard/core/kdtree.hpp>
#include <locard/features/fpfh.hpp>
#include <locard/preprocess/normals.hpp>
#include <locard/preprocess/voxel_grid.hpp>

#include <fmt/format.h>

#include <cmath>

namespace locard {
namespace {

struct Features {
  PointCloud cloud;
  std::vector<Fpfh> descriptors;
  std::size_t non_finite = 0;
};

Features describe(const PointCloud& input, const GlobalRegistrationOptions& o,
                  const Eigen::Vector3f& viewpoint, const char* which) {
  Features f;
  VoxelGridResult v = voxel_down_sample(input, static_cast<float>(o.voxel_size));
  f.non_finite = v.report.non_finite;
  if (v.cloud.size() < 3)
    throw InputError(fmt::format(
        "global registration: the {} cloud has {} point{} after {} m voxel down-sampling ({} "
        "input points, {} with NaN/Inf coordinates); at least 3 are needed",
        which, v.cloud.size(), v.cloud.size() == 1 ? "" : "s", o.voxel_size, input.size(),
        f.non_finite));
  f.cloud = std::move(v.cloud);
  const KdTree tree(f.cloud.positions);
  NormalOptions nopt;
  nopt.radius = static_cast<float>(o.normal_radius > 0.0 ? o.normal_radius : 2.0 * o.voxel_size);
  nopt.max_neighbors = o.normal_max_neighbors;
  nopt.orientation = NormalOrientation::TowardsViewpoint;
  if (o.orient_to_centroid) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (const auto& p : f.cloud.positions) c += p.cast<double>();
    nopt.viewpoint = (c / static_cast<double>(f.cloud.size())).cast<float>();
  } else {
    nopt.viewpoint = viewpoint;
  }
  estimate_normals(f.cloud, nopt, &tree);
  FpfhOptions fopt;
  fopt.radius =
      static_cast<float>(o.feature_radius > 0.0 ? o.feature_radius : 5.0 * o.voxel_size);
  fopt.max_neighbors = o.feature_max_neighbors;
  f.descriptors = compute_fpfh(f.cloud, fopt, &tree);
  return f;
}

}  // namespace

GlobalRegistrationResult global_registration(const PointCloud& source, const PointCloud& target,
                                             const GlobalRegistrationOptions& options) {
  if (!(options.voxel_size > 0.0) || !std::isfinite(options.voxel_size))
    throw InputError(fmt::format(
        "global registration: the voxel size must be a positive number of metres, got {}",
        options.voxel_size));
  const Features s = describe(source, options, options.source_viewpoint, "source");
  const Features t = describe(target, options, options.target_viewpoint, "target");
  const std::vector<Correspondence> matches =
      match_descriptors(s.descriptors, t.descriptors, options.matching);
  RansacOptions ropt = options.ransac;
  if (!(ropt.max_correspondence_distance > 0.0))
    ropt.max_correspondence_distance = 1.5 * options.voxel_size;
  GlobalRegistrationResult result;
  result.ransac = ransac_registration(s.cloud, t.cloud, matches, ropt);
  result.source_points = s.cloud.size();
  result.target_points = t.cloud.size();
  result.source_non_finite = s.non_finite;
  result.target_non_finite = t.non_finite;
  result.matches = matches.size();
  return result;
}

}  // namespace locard
