#pragma once
// Poses are Eigen::Isometry3d named after the frames they connect: T_a_b maps a point from
// frame b into frame a (p_a = T_a_b * p_b). T_world_camera is a camera-to-world pose.

#include <Eigen/Geometry>

#include <cstdint>
#include <vector>

namespace locard {

using Isometry3d = Eigen::Isometry3d;

// One pose of a trajectory. `frame_index` is the index in the source sequence (7-Scenes frame
// number, TUM line order) so sparse subsets keep their identity; timestamp in seconds.
struct StampedPose {
  std::int64_t frame_index = -1;
  double timestamp = 0.0;
  Isometry3d T_world_camera = Isometry3d::Identity();
};

using Trajectory = std::vector<StampedPose>;

// Builds an isometry from a translation and a unit quaternion given as (x, y, z, w).
Isometry3d isometry_from_translation_quaternion(const Eigen::Vector3d& t, double qx, double qy,
                                                double qz, double qw);

// Rotation angle (degrees) and translation norm (metres) of A^-1 * B.
double rotation_difference_deg(const Isometry3d& A, const Isometry3d& B);
double translation_difference_m(const Isometry3d& A, const Isometry3d& B);

}  // namespace locard
