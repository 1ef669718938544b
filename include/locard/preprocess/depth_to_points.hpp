#pragma once
// Back-projection of a depth image to 3D points (pinhole model, see camera_intrinsics.hpp):
//   z = depth / depth_scale,  x = (u - cx) * z / fx,  y = (v - cy) * z / fy.
// Parallel over rows; the output order is row-major regardless of thread count.

#include <locard/core/point_cloud.hpp>
#include <locard/core/pose.hpp>
#include <locard/core/rgbd_frame.hpp>

namespace locard {

struct DepthToPointsOptions {
  double min_depth_m = 0.1;   // closer readings are dropped (sensor dead zone)
  double max_depth_m = 10.0;  // farther readings are dropped (noise grows with range)
  bool with_color = true;     // attach colours when the frame has a colour image
  int stride = 1;             // take every stride-th pixel in u and v
};

// Points in the camera frame, or in the world frame when T_world_camera is given.
PointCloud depth_to_points(const RgbdFrame& frame, const DepthToPointsOptions& options,
                           const Isometry3d& T_world_camera = Isometry3d::Identity());

}  // namespace locard
