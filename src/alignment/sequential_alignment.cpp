// Sequential alignment, loop closure and pose graph (see sequential_alignment.hpp for the
// scheme): the stages of alignment_stages.hpp run in order over one state.
#include <locard/alignment/sequential_alignment.hpp>

#include "alignment/alignment_stages.hpp"

#include <locard/core/error.hpp>
#include <locard/preprocess/depth_to_points.hpp>
#include <locard/preprocess/voxel_grid.hpp>

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>

namespace locard {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

void check_options(const AlignmentOptions& o) {
  const auto bad = [](const std::string& what) { throw InputError("alignment options: " + what); };
  if (!(o.voxel_size > 0.0) || !std::isfinite(o.voxel_size))
    bad(fmt::format("voxel_size must be a positive number of metres, got {}", o.voxel_size));
  if (!(o.feature_voxel_size > 0.0))
    bad(fmt::format("feature_voxel_size must be positive, got {}", o.feature_voxel_size));
  if (o.stride < 1) bad(fmt::format("stride must be >= 1, got {}", o.stride));
  if (!(o.max_depth_m > o.min_depth_m))
    bad(fmt::format("max_depth_m ({}) must exceed min_depth_m ({})", o.max_depth_m,
                    o.min_depth_m));
  if (o.keyframe_interval < 1) bad("keyframe_interval must be >= 1");
  if (o.local_model_frames < 1) bad("local_model_frames must be >= 1");
  if (!(o.min_verified_share >= 0.0 && o.min_verified_share <= 1.0))
    bad(fmt::format("min_verified_share must lie in [0, 1], got {}", o.min_verified_share));
}

}  // namespace

std::string_view to_string(AlignmentMode mode) {
  return mode == AlignmentMode::Cumulative ? "cumulative" : "odometry";
}

std::string_view to_string(LoopSource source) {
  return source == LoopSource::Features ? "features" : "proximity";
}

std::optional<AlignmentMode> parse_alignment_mode(std::string_view name) {
  if (name == "cumulative") return AlignmentMode::Cumulative;
  if (name == "odometry") return AlignmentMode::Odometry;
  return std::nullopt;
}

std::string_view to_string(FrameStatus status) {
  switch (status) {
    case FrameStatus::Registered: return "registered";
    case FrameStatus::Unusable: return "unusable";
    case FrameStatus::Failed: return "failed";
  }
  return "unknown";
}

Trajectory AlignmentResult::trajectory(long piece) const {
  Trajectory out;
  for (const FrameAlignment& f : frames) {
    if (!f.trusted()) continue;
    if (piece >= 0 && f.piece != static_cast<std::size_t>(piece)) continue;
    out.push_back({f.frame_index, f.timestamp, *f.T_world_camera_final});
  }
  return out;
}

std::vector<std::int64_t> AlignmentResult::unregistered_frame_indices() const {
  std::vector<std::int64_t> out;
  for (const FrameAlignment& f : frames)
    if (f.status != FrameStatus::Registered) out.push_back(f.frame_index);
  return out;
}

std::vector<std::int64_t> AlignmentResult::flagged_frame_indices() const {
  std::vector<std::int64_t> out;
  for (const FrameAlignment& f : frames)
    if (f.status == FrameStatus::Registered && f.check.checked && !f.check.verified)
      out.push_back(f.frame_index);
  return out;
}

std::size_t AlignmentResult::usable_frames() const {
  return static_cast<std::size_t>(std::count_if(frames.begin(), frames.end(), [](const auto& f) {
    return f.status != FrameStatus::Unusable;
  }));
}

std::size_t AlignmentResult::trusted_frames() const {
  return static_cast<std::size_t>(
      std::count_if(frames.begin(), frames.end(), [](const auto& f) { return f.trusted(); }));
}

double AlignmentResult::trusted_share() const {
  const std::size_t usable = usable_frames();
  return usable ? static_cast<double>(trusted_frames()) / static_cast<double>(usable) : 0.0;
}

AlignmentResult align_sequence(const RgbdSequence& sequence, const AlignmentOptions& options) {
  check_options(options);
  const AlignmentOptions& o = options;
  if (sequence.frames.empty())
    throw_input_error(sequence.root, "the sequence has no frames to align");
  if (o.first_frame >= sequence.frames.size())
    throw_input_error(sequence.root, fmt::format("first frame {} is past the last frame ({})",
                                                 o.first_frame, sequence.frames.size() - 1));
  const std::size_t end =
      o.max_frames ? std::min(sequence.frames.size(), o.first_frame + o.max_frames)
                   : sequence.frames.size();
  const auto t_total = Clock::now();
  alignment_detail::AlignmentState state(sequence, o);
  state.n = end - o.first_frame;
  state.result.options = o;
  state.result.options.progress = nullptr;
  AlignmentTimings& timings = state.result.timings;

  auto t0 = Clock::now();
  alignment_detail::prepare_frames(state);
  timings.prepare_s = seconds_since(t0);

  t0 = Clock::now();
  alignment_detail::track_frames(state);
  alignment_detail::hold_to_tripod(state);
  timings.register_s = seconds_since(t0);

  t0 = Clock::now();
  alignment_detail::propose_loops(state);
  alignment_detail::verify_loops(state);
  timings.loop_closure_s = seconds_since(t0);

  t0 = Clock::now();
  alignment_detail::solve_graph(state);
  timings.pose_graph_s = seconds_since(t0);

  t0 = Clock::now();
  if (o.joint_refinement) alignment_detail::refine_jointly(state);
  timings.refinement_s = seconds_since(t0);

  t0 = Clock::now();
  if (o.verify_views) alignment_detail::check_views(state);
  timings.verification_s = seconds_since(t0);

  state.result.loops = std::move(state.candidates);
  timings.total_s = seconds_since(t_total);
  return std::move(state.result);
}

PointCloud fuse_aligned_frames(const RgbdSequence& sequence, const AlignmentResult& result,
                               double voxel_size, long piece) {
  const AlignmentOptions& o = result.options;
  std::vector<const FrameAlignment*> frames;
  for (const FrameAlignment& f : result.frames)
    if (f.trusted() && (piece < 0 || f.piece == static_cast<std::size_t>(piece)))
      frames.push_back(&f);
  std::vector<PointCloud> clouds(frames.size());
  tbb::parallel_for(std::size_t{0}, frames.size(), [&](std::size_t k) {
    const RgbdFrame frame = sequence.load_frame(frames[k]->sequence_index);
    DepthToPointsOptions dopt;
    dopt.min_depth_m = o.min_depth_m;
    dopt.max_depth_m = o.max_depth_m;
    dopt.stride = o.stride;
    const PointCloud raw = depth_to_points(frame, dopt, *frames[k]->T_world_camera_final);
    clouds[k] = voxel_down_sample(raw, static_cast<float>(voxel_size)).cloud;
  });
  PointCloud all;
  for (const PointCloud& c : clouds) all.append(c);
  if (all.empty()) return all;
  return voxel_down_sample(all, static_cast<float>(voxel_size)).cloud;
}

}  // namespace locard
