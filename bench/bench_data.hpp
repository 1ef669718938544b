#pragma once
// The real data the benchmarks share: the 7-Scenes subset and the fused cloud the filter and
// feature benchmarks run on. Running peers: harness/peer_harness.hpp.

#include <locard/core/point_cloud.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/preprocess/depth_to_points.hpp>

#include <filesystem>
#include <string>

namespace locard::bench {

inline const std::filesystem::path kSevenScenes =
    std::filesystem::path(LOCARD_SHARED_DATA) / "7scenes-tsdf-fusion" / "data";

// `frames` frames spread evenly over the 374 with images, back-projected with colour and put
// in the world frame by their ground-truth poses, then concatenated.
inline PointCloud fused_seven_scenes(std::size_t frames) {
  const RgbdSequence sequence = open_rgbd_sequence(kSevenScenes);
  DepthToPointsOptions options;
  options.min_depth_m = 0.1;
  options.max_depth_m = 10.0;
  PointCloud fused;
  const std::size_t step = std::max<std::size_t>(1, sequence.frames.size() / frames);
  for (std::size_t i = 0; i < sequence.frames.size() && i / step < frames; i += step) {
    const RgbdFrame frame = sequence.load_frame(i);
    fused.append(depth_to_points(frame, options, *sequence.frames[i].T_world_camera));
  }
  return fused;
}

}  // namespace locard::bench
