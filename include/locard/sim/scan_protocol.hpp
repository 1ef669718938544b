#pragma once
// Where the simulated sensor stands and looks: a tripod turned by hand at the room centre, as
// in the reference paper's acquisition.
//
// Camera frame (pinhole, as CameraIntrinsics): x right, y down, z forward. A tripod pose at
// position p with yaw psi (about world +z, 0 = looking along +x) and pitch theta (positive
// looks up) has, in world coordinates,
//   forward z_c = (cos psi cos theta, sin psi cos theta, sin theta)
//   right   x_c = (sin psi, -cos psi, 0)
//   down    y_c = z_c x x_c
// so T_world_camera = [x_c y_c z_c | p]. The horizon stays level (no roll).

#include <locard/core/pose.hpp>
#include <locard/sim/scene.hpp>

#include <Eigen/Core>

namespace locard::sim {

Isometry3d tripod_pose(const Eigen::Vector3d& position, double yaw_rad, double pitch_rad);

// Frame rate the simulated sequence is stamped with: view i is at i / 30 s (rounded to the
// microsecond, the precision of the TUM text files).
inline constexpr double kSimulatedFrameRate = 30.0;
double view_timestamp(std::size_t view_index);

// Every view of the scan, pitch row after pitch row, `views` per row evenly spaced over 360
// degrees of yaw, each with seeded Gaussian yaw and position jitter. frame_index = view index.
Trajectory tripod_scan_trajectory(const ScannerSpec& scanner);

}  // namespace locard::sim
