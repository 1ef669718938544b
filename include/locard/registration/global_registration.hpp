#pragma once
// Feature-based global registration, the reference paper's section III-C/III-D.1 in one call:
//   voxel down-sampling -> normals (local PCA) -> FPFH -> mutual nearest neighbours in FPFH
//   space -> RANSAC + Kabsch (ransac.hpp).
// The defaults follow Open3D's global-registration tutorial, scaled by the voxel size v:
// normals within 2v (30 neighbours), FPFH within 5v (100 neighbours), inlier distance 1.5v.
// Non-finite points are dropped and counted by the voxel grid; an empty cloud after that, or
// a non-positive voxel size, is an InputError.

#include <locard/core/point_cloud.hpp>
#include <locard/features/descriptor_matching.hpp>
#include <locard/registration/ransac.hpp>

#include <Eigen/Core>

#include <cstddef>

namespace locard {

struct GlobalRegistrationOptions {
  double voxel_size = 0.005;       // metres
  double normal_radius = 0.0;      // 0: 2 * voxel_size
  int normal_max_neighbors = 30;
  double feature_radius = 0.0;     // 0: 5 * voxel_size
  int feature_max_neighbors = 100;
  // FPFH depends on the sign of the normals, so source and target must orient them alike:
  // every normal points towards a viewpoint. For scans in their sensor's frame that is the
  // sensor, the origin (the defaults below); for a cloud that was moved, pass where its sensor
  // now is. With orient_to_centroid, each cloud's own centroid is used instead: it moves with
  // the cloud, so it suits single objects and clouds whose sensor position is unknown.
  Eigen::Vector3f source_viewpoint = Eigen::Vector3f::Zero();
  Eigen::Vector3f target_viewpoint = Eigen::Vector3f::Zero();
  bool orient_to_centroid = false;
  MatchOptions matching;           // mutual by default
  // RANSAC; max_correspondence_distance <= 0 means 1.5 * voxel_size.
  RansacOptions ransac{.max_correspondence_distance = 0.0};
};

struct GlobalRegistrationResult {
  RansacResult ransac;  // the transform, success and reason live here
  std::size_t source_points = 0;      // after down-sampling
  std::size_t target_points = 0;
  std::size_t source_non_finite = 0;  // dropped from the input clouds
  std::size_t target_non_finite = 0;
  std::size_t matches = 0;            // descriptor correspondences handed to RANSAC
};

GlobalRegistrationResult global_registration(const PointCloud& source, const PointCloud& target,
                                             const GlobalRegistrationOptions& options);

}  // namespace locard
