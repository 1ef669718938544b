#pragma once
// The error after each alignment stage, as the reference paper's Fig. 4: after SVD (feature
// alignment), after ICP, after loop closure (pose graph).
//
// Per-view cumulative error, when the sequence has ground truth: each stage's poses are taken
// relative to the first registered frame of its piece, as are the ground-truth poses, so the
// error of view i is the drift accumulated from the first view to view i:
//   e_i = | trans( (G_0^-1 G_i)^-1 (T_0^-1 T_i) ) |,   r_i = angle of the same motion,
// G the ground truth, T the stage's estimate. The stage's ATE (TUM definition, rigid
// alignment, trajectory_eval.hpp) is reported too. Loop-closure residuals (fitness, inlier RMSE,
// chi2 before and after the pose graph, line-process weight) are reported always.

#include <locard/alignment/sequential_alignment.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace locard {

enum class AlignmentStage { Svd, Icp, LoopClosure };
std::string_view to_string(AlignmentStage stage);  // "svd", "icp", "loop_closure"

struct StageViewError {
  std::int64_t frame_index = -1;
  std::optional<double> translation_m[3];  // indexed by AlignmentStage
  std::optional<double> rotation_deg[3];
};

struct StageSummary {
  std::size_t views = 0;          // views with a pose at this stage (and ground truth)
  double mean_translation_m = 0.0;
  double max_translation_m = 0.0;
  double mean_rotation_deg = 0.0;
  double max_rotation_deg = 0.0;
  std::optional<double> ate_rmse_m;  // when at least 3 views
};

struct StageReport {
  bool has_ground_truth = false;
  std::vector<StageViewError> views;  // registered frames of piece 0, in order
  StageSummary summary[3];
};

// `ground_truth[k]` is the ground-truth T_world_camera of result.frames[k], if known (the
// FrameEntry poses of the sequence). Only the first piece is measured (a single world frame).
StageReport make_stage_report(const AlignmentResult& result,
                              const std::vector<std::optional<Isometry3d>>& ground_truth);
// Convenience: ground truth from the sequence's frame entries.
StageReport make_stage_report(const AlignmentResult& result, const RgbdSequence& sequence);

// JSON with the stage errors, the loop closures and the pose-graph summary.
void write_stage_report_json(const std::filesystem::path& path, const AlignmentResult& result,
                             const StageReport& report);
// An SVG line plot (error in mm against view, one line per stage, like the paper's Fig. 4);
// without ground truth, the loop closures' inlier RMSE before and after instead.
std::string stage_report_svg(const AlignmentResult& result, const StageReport& report);
void write_stage_report_svg(const std::filesystem::path& path, const AlignmentResult& result,
                            const StageReport& report);

}  // namespace locard
