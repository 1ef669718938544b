#include <locard/preprocess/crop.hpp>

#include "preprocess/point_status.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace locard {

namespace {

// Marks finite points for which `inside(p)` differs from `keep_inside` as rejected.
template <typename Inside>
FilterResult crop_by(const PointCloud& cloud, const Inside& inside, bool keep_inside) {
  cloud.check_consistent();
  std::vector<detail::PointStatus> status = detail::finite_status(cloud);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cloud.size(), 8192),
                    [&](const auto& range) {
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        if (status[i] == detail::PointStatus::Keep &&
                            inside(cloud.positions[i]) != keep_inside) {
                          status[i] = detail::PointStatus::Rejected;
                        }
                      }
                    });
  return detail::build_filter_result(cloud, status);
}

}  // namespace

bool OrientedBox::contains(const Eigen::Vector3f& p) const {
  const Eigen::Vector3d p_box = T_world_box.inverse() * p.cast<double>();
  return (p_box.array().abs() <= half_extents.array()).all();
}

FilterResult crop_depth_range(const PointCloud& cloud, double min_depth_m, double max_depth_m,
                              const Isometry3d& T_cloud_camera) {
  // depth = z of the point in the camera frame = (T_camera_cloud * p).z, i.e. the third row of
  // T_camera_cloud applied to p.
  const Isometry3d T_camera_cloud = T_cloud_camera.inverse();
  const Eigen::RowVector3d z_row = T_camera_cloud.linear().row(2);
  const double z_offset = T_camera_cloud.translation().z();
  return crop_by(
      cloud,
      [&](const Eigen::Vector3f& p) {
        const double depth = z_row.dot(p.cast<double>()) + z_offset;
        return depth >= min_depth_m && depth <= max_depth_m;
      },
      true);
}

FilterResult crop_box(const PointCloud& cloud, const AxisAlignedBox& box, bool keep_inside) {
  return crop_by(cloud, [&](const Eigen::Vector3f& p) { return box.contains(p); }, keep_inside);
}

FilterResult crop_box(const PointCloud& cloud, const OrientedBox& box, bool keep_inside) {
  const Isometry3d T_box_world = box.T_world_box.inverse();
  return crop_by(
      cloud,
      [&](const Eigen::Vector3f& p) {
        const Eigen::Vector3d p_box = T_box_world * p.cast<double>();
        return (p_box.array().abs() <= box.half_extents.array()).all();
      },
      keep_inside);
}

}  // namespace locard
