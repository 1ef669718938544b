#include <locard/core/error.hpp>
#include <locard/preprocess/depth_to_points.hpp>
#include <locard/preprocess/voxel_grid.hpp>
#include <locard/surface/fusion.hpp>

#include <algorithm>
#include <cmath>

namespace locard {

std::vector<std::optional<Isometry3d>> match_poses(const RgbdSequence& sequence,
                                                   const Trajectory& trajectory,
                                                   double max_time_difference) {
  std::vector<std::size_t> order(trajectory.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return trajectory[a].timestamp < trajectory[b].timestamp;
  });
  std::vector<std::optional<Isometry3d>> poses(sequence.frames.size());
  for (std::size_t f = 0; f < sequence.frames.size(); ++f) {
    const double t = sequence.frames[f].timestamp;
    auto it = std::lower_bound(order.begin(), order.end(), t, [&](std::size_t i, double v) {
      return trajectory[i].timestamp < v;
    });
    double best = max_time_difference;
    for (auto c : {it, it == order.begin() ? it : it - 1}) {
      if (c == order.end()) continue;
      const double d = std::abs(trajectory[*c].timestamp - t);
      if (d <= best) {
        best = d;
        poses[f] = trajectory[*c].T_world_camera;
      }
    }
  }
  return poses;
}

std::vector<std::optional<Isometry3d>> ground_truth_poses(const RgbdSequence& sequence) {
  std::vector<std::optional<Isometry3d>> poses;
  poses.reserve(sequence.frames.size());
  for (const FrameEntry& f : sequence.frames) poses.push_back(f.T_world_camera);
  return poses;
}

FusionResult fuse_sequence(const RgbdSequence& sequence,
                           const std::vector<std::optional<Isometry3d>>& T_world_camera,
                           const FusionOptions& options) {
  if (T_world_camera.size() != sequence.frames.size())
    throw InputError("fuse_sequence: one pose (or none) per frame is needed");
  const std::size_t step = std::max<std::size_t>(1, options.frame_step);
  std::vector<std::size_t> selected;
  FusionResult result;
  for (std::size_t i = 0; i < sequence.frames.size(); i += step) {
    if (!T_world_camera[i]) {
      ++result.frames_without_pose;
      continue;
    }
    if (options.max_frames && selected.size() >= options.max_frames) break;
    selected.push_back(i);
  }
  if (selected.empty())
    throw_input_error(sequence.root, "no frame has a pose to fuse it at");

  TsdfVolume volume(options.tsdf);
  PointCloud cloud;
  DepthToPointsOptions points;
  points.min_depth_m = std::max(options.tsdf.min_depth_m, 0.001);
  points.max_depth_m = options.tsdf.max_depth_m;
  for (std::size_t n = 0; n < selected.size(); ++n) {
    const std::size_t i = selected[n];
    const RgbdFrame frame = sequence.load_frame(i);
    volume.integrate(frame, *T_world_camera[i]);
    if (options.cloud_voxel > 0.0) {
      cloud.append(depth_to_points(frame, points, *T_world_camera[i]));
      // Keep memory bounded: re-average every few frames.
      if (n % 16 == 15) cloud = voxel_down_sample(cloud, static_cast<float>(options.cloud_voxel)).cloud;
    }
    if (options.progress) options.progress(n + 1, selected.size());
  }
  if (options.cloud_voxel > 0.0 && !cloud.empty())
    result.cloud = voxel_down_sample(cloud, static_cast<float>(options.cloud_voxel)).cloud;
  result.frames_fused = selected.size();
  result.mesh = volume.extract_mesh();
  result.stats = volume.stats();
  return result;
}

}  // namespace locard
