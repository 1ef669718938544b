// Stage 1 of align_sequence: every frame becomes a camera-frame cloud (alignment_stages.hpp).
#include "alignment/alignment_stages.hpp"

#include <locard/preprocess/depth_to_points.hpp>
#include <locard/preprocess/normals.hpp>
#include <locard/preprocess/voxel_grid.hpp>

#include <fmt/format.h>
#include <tbb/parallel_for.h>

namespace locard::alignment_detail {
namespace {

PreparedFrame prepare_frame(const RgbdSequence& sequence, std::size_t index,
                            const AlignmentOptions& o) {
  PreparedFrame f;
  const RgbdFrame frame = sequence.load_frame(index);
  DepthToPointsOptions dopt;
  dopt.min_depth_m = o.min_depth_m;
  dopt.max_depth_m = o.max_depth_m;
  dopt.stride = o.stride;
  const PointCloud raw = depth_to_points(frame, dopt);
  if (raw.size() < o.min_frame_points) {
    f.unusable = fmt::format("only {} depth pixels in [{}, {}] m at stride {} (at least {} "
                             "needed): blank, covered or out of range",
                             raw.size(), o.min_depth_m, o.max_depth_m, o.stride,
                             o.min_frame_points);
    return f;
  }
  f.cloud = voxel_down_sample(raw, static_cast<float>(o.voxel_size)).cloud;
  if (f.cloud.size() < o.min_frame_points / 4 + 6) {
    f.unusable = fmt::format("only {} points after the {} m voxel grid", f.cloud.size(),
                             o.voxel_size);
    return f;
  }
  NormalOptions nopt;
  nopt.radius = static_cast<float>(2.5 * o.voxel_size);
  nopt.max_neighbors = 30;
  estimate_normals(f.cloud, nopt);
  f.coarse = voxel_down_sample(f.cloud, static_cast<float>(2.0 * o.voxel_size)).cloud;
  return f;
}

}  // namespace

// In parallel: each frame is independent; the order is the index order.
void prepare_frames(AlignmentState& s) {
  const AlignmentOptions& o = s.options;
  s.prepared.resize(s.n);
  tbb::parallel_for(std::size_t{0}, s.n, [&](std::size_t i) {
    s.prepared[i] = prepare_frame(s.sequence, o.first_frame + i, o);
  });
  s.result.frames.resize(s.n);
  for (std::size_t i = 0; i < s.n; ++i) {
    FrameAlignment& f = s.result.frames[i];
    const FrameEntry& e = s.sequence.frames[o.first_frame + i];
    f.sequence_index = o.first_frame + i;
    f.frame_index = e.frame_index;
    f.timestamp = e.timestamp;
    f.points = s.prepared[i].cloud.size();
    f.status = s.prepared[i].unusable.empty() ? FrameStatus::Failed : FrameStatus::Unusable;
    f.reason = s.prepared[i].unusable;
  }
}

}  // namespace locard::alignment_detail
