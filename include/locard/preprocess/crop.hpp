#pragma once
// Crops: depth range and boxes. Parallel, order-preserving, non-finite points dropped and
// counted in report.non_finite. Boundaries are inclusive.

#include <locard/core/pose.hpp>
#include <locard/preprocess/point_selection.hpp>

#include <Eigen/Geometry>

namespace locard {

struct AxisAlignedBox {
  Eigen::Vector3f min = Eigen::Vector3f::Zero();
  Eigen::Vector3f max = Eigen::Vector3f::Zero();
  bool contains(const Eigen::Vector3f& p) const {
    return (p.array() >= min.array()).all() && (p.array() <= max.array()).all();
  }
};

// A box of half-extents `half_extents` along its own axes; T_world_box maps box coordinates
// (centred on the box) into the cloud's frame.
struct OrientedBox {
  Isometry3d T_world_box = Isometry3d::Identity();
  Eigen::Vector3d half_extents = Eigen::Vector3d::Zero();
  bool contains(const Eigen::Vector3f& p) const;
};

// Keeps points whose depth, the z coordinate in the camera frame, is in [min_depth, max_depth]
// metres. T_cloud_camera is the camera pose in the cloud's frame (identity when the cloud is
// in the camera frame, T_world_camera for a world-frame cloud).
FilterResult crop_depth_range(const PointCloud& cloud, double min_depth_m, double max_depth_m,
                              const Isometry3d& T_cloud_camera = Isometry3d::Identity());

// Keeps the points inside (or, with keep_inside = false, outside) the box.
FilterResult crop_box(const PointCloud& cloud, const AxisAlignedBox& box,
                      bool keep_inside = true);
FilterResult crop_box(const PointCloud& cloud, const OrientedBox& box, bool keep_inside = true);

}  // namespace locard
