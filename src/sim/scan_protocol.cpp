#include <locard/sim/scan_protocol.hpp>

#include <locard/sim/counter_rng.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace locard::sim {

Isometry3d tripod_pose(const Eigen::Vector3d& position, double yaw_rad, double pitch_rad) {
  const double cy = std::cos(yaw_rad), sy = std::sin(yaw_rad);
  const double cp = std::cos(pitch_rad), sp = std::sin(pitch_rad);
  const Eigen::Vector3d forward(cy * cp, sy * cp, sp);
  const Eigen::Vector3d right(sy, -cy, 0.0);
  const Eigen::Vector3d down = forward.cross(right);
  Isometry3d T_world_camera = Isometry3d::Identity();
  T_world_camera.linear().col(0) = right;
  T_world_camera.linear().col(1) = down;
  T_world_camera.linear().col(2) = forward;
  T_world_camera.translation() = position;
  return T_world_camera;
}

double view_timestamp(std::size_t view_index) {
  return std::round(static_cast<double>(view_index) / kSimulatedFrameRate * 1e6) / 1e6;
}

Trajectory tripod_scan_trajectory(const ScannerSpec& scanner) {
  constexpr double kDegToRad = std::numbers::pi / 180.0;
  Trajectory trajectory;
  std::size_t index = 0;
  for (std::size_t ring = 0; ring < scanner.pitch_deg.size(); ++ring) {
    const double pitch_deg = scanner.pitch_deg[ring];
    const int views = std::max(scanner.views_in_ring(ring), 0);
    for (int k = 0; k < views; ++k, ++index) {
      CounterRng rng(scanner.seed, RngStream::Pose, index, 0);
      const double yaw_deg = 360.0 * k / views + scanner.yaw_jitter_deg * rng.normal();
      Eigen::Vector3d position = scanner.position;
      for (int axis = 0; axis < 3; ++axis) position[axis] += scanner.position_jitter_m * rng.normal();
      StampedPose pose;
      pose.frame_index = static_cast<std::int64_t>(index);
      pose.timestamp = view_timestamp(index);
      pose.T_world_camera = tripod_pose(position, yaw_deg * kDegToRad, pitch_deg * kDegToRad);
      trajectory.push_back(pose);
    }
  }
  return trajectory;
}

}  // namespace locard::sim
