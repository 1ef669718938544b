// `locard eval-trajectory GT EST`: ATE RMSE after rigid alignment and RPE, with the TUM RGB-D
// benchmark's definitions (include/locard/alignment/trajectory_eval.hpp). GT and EST are TUM
// trajectory files or Redwood .log files; GT may also be a sequence folder (its ground truth,
// e.g. a 7-Scenes folder's pose files).
#include "commands.hpp"

#include <locard/alignment/trajectory_eval.hpp>
#include <locard/core/error.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/io/trajectory_io.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

namespace locard::cli {
namespace {

struct EvalOptions {
  std::string ground_truth;
  std::string estimate;
  double max_difference = 0.02;
  double offset = 0.0;
  bool by_frame_index = false;
  double delta = 1.0;
  std::string delta_unit = "f";
  bool no_align = false;
  bool json = false;
};

Trajectory read_any(const std::string& path, const char* which) {
  namespace fs = std::filesystem;
  if (!fs::exists(path)) throw_input_error(path, "no such file or folder");
  Trajectory t;
  if (fs::is_directory(path)) {
    const RgbdSequence seq = open_rgbd_sequence(path);
    if (!seq.has_ground_truth())
      throw_input_error(path, fmt::format("the {} folder is a {} sequence without ground truth",
                                          which, to_string(seq.format)));
    t = seq.ground_truth;
  } else if (fs::path(path).extension() == ".log") {
    t = read_redwood_log(path);
  } else {
    t = read_tum_trajectory(path);
  }
  if (t.empty()) throw_input_error(path, fmt::format("the {} trajectory has no poses", which));
  return t;
}

nlohmann::json stats_json(const ErrorStatistics& s) {
  return {{"rmse", s.rmse}, {"mean", s.mean}, {"median", s.median},
          {"std", s.std_dev}, {"min", s.min}, {"max", s.max}};
}

int run_eval(const EvalOptions& opt) {
  if (opt.delta_unit != "f" && opt.delta_unit != "s")
    throw InputError(fmt::format("--delta-unit must be f (frames) or s (seconds), got '{}'",
                                 opt.delta_unit));
  const Trajectory gt = read_any(opt.ground_truth, "ground-truth");
  const Trajectory est = read_any(opt.estimate, "estimated");
  AssociationOptions a;
  a.max_time_difference = opt.max_difference;
  a.time_offset = opt.offset;
  a.match_by_frame_index = opt.by_frame_index;
  const AteResult ate = absolute_trajectory_error(gt, est, a, !opt.no_align);
  RpeOptions r;
  r.delta = opt.delta;
  r.unit = opt.delta_unit == "s" ? DeltaUnit::Seconds : DeltaUnit::Frames;
  const RpeResult rpe = relative_pose_error(gt, est, a, r);
  if (opt.json) {
    nlohmann::json j = {
        {"ground_truth", opt.ground_truth},
        {"estimate", opt.estimate},
        {"ground_truth_poses", gt.size()},
        {"estimate_poses", est.size()},
        {"pairs", ate.pairs},
        {"ate_m", stats_json(ate.translation)},
        {"rpe", {{"delta", opt.delta}, {"unit", opt.delta_unit}, {"pairs", rpe.pairs},
                 {"translation_m", stats_json(rpe.translation)},
                 {"rotation_deg", stats_json(rpe.rotation_deg)}}}};
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  fmt::print("compared_pose_pairs {} (ground truth {}, estimate {})\n", ate.pairs, gt.size(),
             est.size());
  fmt::print("absolute_translational_error.rmse {:.6f} m\n", ate.translation.rmse);
  fmt::print("absolute_translational_error.mean {:.6f} m\n", ate.translation.mean);
  fmt::print("absolute_translational_error.median {:.6f} m\n", ate.translation.median);
  fmt::print("absolute_translational_error.std {:.6f} m\n", ate.translation.std_dev);
  fmt::print("absolute_translational_error.min {:.6f} m\n", ate.translation.min);
  fmt::print("absolute_translational_error.max {:.6f} m\n", ate.translation.max);
  fmt::print("relative_pose_pairs {} (delta {} {})\n", rpe.pairs, opt.delta, opt.delta_unit);
  fmt::print("translational_error.rmse {:.6f} m\n", rpe.translation.rmse);
  fmt::print("translational_error.mean {:.6f} m\n", rpe.translation.mean);
  fmt::print("rotational_error.rmse {:.6f} deg\n", rpe.rotation_deg.rmse);
  fmt::print("rotational_error.mean {:.6f} deg\n", rpe.rotation_deg.mean);
  return 0;
}

}  // namespace

void register_eval_trajectory(CLI::App& app, GlobalOptions& /*global*/) {
  auto options = std::make_shared<EvalOptions>();
  CLI::App* cmd = app.add_subcommand(
      "eval-trajectory",
      "Absolute trajectory error (RMSE after rigid alignment) and relative pose error of an "
      "estimated trajectory, with the TUM RGB-D benchmark's definitions");
  cmd->add_option("ground_truth", options->ground_truth,
                  "Ground truth: TUM file, Redwood .log or a sequence folder")
      ->required();
  cmd->add_option("estimate", options->estimate, "Estimate: TUM file or Redwood .log")
      ->required();
  cmd->add_option("--max-difference", options->max_difference,
                  "Time association tolerance (s)")
      ->capture_default_str();
  cmd->add_option("--offset", options->offset, "Added to the estimate's timestamps (s)")
      ->capture_default_str();
  cmd->add_flag("--by-frame-index", options->by_frame_index,
                "Pair poses by frame index instead of timestamp (a TUM file has no frame "
                "index: its poses are numbered in line order, so pair a TUM estimate by "
                "timestamp unless it holds every frame)");
  cmd->add_option("--delta", options->delta, "RPE step")->capture_default_str();
  cmd->add_option("--delta-unit", options->delta_unit, "RPE step unit: f (frames) or s (seconds)")
      ->capture_default_str();
  cmd->add_flag("--no-align", options->no_align, "ATE without the rigid alignment");
  cmd->add_flag("--json", options->json, "Print JSON");
  set_runner(cmd, [options] { return run_eval(*options); });
}

}  // namespace locard::cli
