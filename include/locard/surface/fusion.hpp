#pragma once
// Fuses a recorded RGB-D sequence into a coloured mesh: every frame with a pose goes through
// TsdfVolume::integrate, then marching cubes. Poses come from a trajectory (matched to frames
// by timestamp, as the TUM tools do) or from the sequence's own ground truth.

#include <locard/core/point_cloud.hpp>
#include <locard/core/pose.hpp>
#include <locard/core/progress.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/surface/tsdf_volume.hpp>

#include <cstddef>
#include <optional>
#include <vector>

namespace locard {

struct FusionOptions {
  TsdfOptions tsdf;
  std::size_t frame_step = 1;       // fuse every n-th frame
  std::size_t max_frames = 0;       // 0: no limit
  double cloud_voxel = 0.0;         // > 0: also build the registered point cloud at this voxel
  ProgressCallback progress;        // (frames done, frames to fuse)
};

struct FusionResult {
  TriangleMesh mesh;
  PointCloud cloud;  // the registered depth points, voxel-averaged (empty unless asked)
  TsdfStats stats;
  std::size_t frames_fused = 0;
  std::size_t frames_without_pose = 0;  // skipped: no pose within the time tolerance
};

// For each frame of the sequence, the pose of `trajectory` with the nearest timestamp within
// `max_time_difference` seconds (none when the trajectory has no pose that close).
std::vector<std::optional<Isometry3d>> match_poses(const RgbdSequence& sequence,
                                                   const Trajectory& trajectory,
                                                   double max_time_difference = 0.02);
// The sequence's own ground-truth pose of every frame.
std::vector<std::optional<Isometry3d>> ground_truth_poses(const RgbdSequence& sequence);

// Throws InputError when no frame has a pose.
FusionResult fuse_sequence(const RgbdSequence& sequence,
                           const std::vector<std::optional<Isometry3d>>& T_world_camera,
                           const FusionOptions& options);

}  // namespace locard
