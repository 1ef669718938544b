// Whole-sequence alignment against Open3D through the peer harness (bench/harness): the same
// frames, the same depth range and the same loop-candidate policy on both sides, same run.
//
//  7-Scenes  the 374 frames in ../shared/data (0..59 consecutive, then every 3rd to 999), with
//            the defaults `locard align` takes for this data (hand-held video, structured
//            light: odometry mode, point-to-plane, 3 m): frame-to-local-model ICP, loop
//            closure, pose graph, view checks. Timed end to end on both sides, frame reading
//            included (both read the same PNG/JPEG files inside the pass).
//            Open3D (bench/peers/open3d_alignment.py, kernel "align_sequence"): multi-scale
//            point-to-plane ICP chain frame to frame, then loop candidates chosen by Locard's
//            policy, passed in the workload (keyframes every `keyframe_interval` frames, at
//            least `loop_min_separation` frames apart, cameras within `loop_max_distance_m`
//            and `loop_max_angle_deg`, the `loop_candidates_per_keyframe` nearest earlier
//            keyframes of each, `max_loop_candidates` nearest first overall), verified by
//            ICP (fitness >= loop_min_fitness), and Open3D's LM pose graph (line process).
//            With LOCARD_BENCH_O3D_ODOMETRY=1 a third side, "o3d-rgbd": Open3D's hybrid
//            RGB-D odometry instead of the ICP chain (~450 s).
//            One evaluator: ATE RMSE against the 1000-pose reference, poses paired by frame
//            index; frames posed; loop edges kept.
//  Bedroom   the simulated Kinect v2 bedroom turn (50 views, `locard scan-sim` defaults),
//            cumulative mode: the stage report's errors after SVD, ICP and loop closure, and
//            the ATE (Locard only: no peer aligns a tripod turn).
//
//   build/release/bench/alignment_bench --benchmark_filter=align_7scenes [--repeats=N]
#include "bench_data.hpp"
#include "peer_harness.hpp"

#include <locard/alignment/alignment_defaults.hpp>
#include <locard/alignment/sequential_alignment.hpp>
#include <locard/alignment/stage_report.hpp>
#include <locard/alignment/trajectory_eval.hpp>
#include <locard/sim/scan_writer.hpp>
#include <locard/sim/scene.hpp>

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <chrono>
#include <cstdlib>
#include <fstream>

namespace {

namespace fs = std::filesystem;
namespace bench = locard::bench;

double ate_by_index(const locard::Trajectory& gt, const locard::Trajectory& est) {
  locard::AssociationOptions a;
  a.match_by_frame_index = true;
  return locard::absolute_trajectory_error(gt, est, a).translation.rmse;
}

// --- 7-Scenes: Locard and Open3D on one workload -----------------------------------------

const locard::RgbdSequence& seven_scenes() {
  static const locard::RgbdSequence seq = locard::open_rgbd_sequence(bench::kSevenScenes);
  return seq;
}

// The options `locard align` takes for this data with no flags.
locard::AlignmentOptions locard_defaults() {
  return locard::default_alignment_options(seven_scenes().traits);
}

// The loop-candidate policy both sides use, from Locard's options: pairs closer in the sequence
// than Locard's local model are tied by its tracking, so the policy starts beyond it.
nlohmann::json loop_policy(const locard::AlignmentOptions& o) {
  return {{"keyframe_interval", o.keyframe_interval},
          {"loop_min_separation",
           std::max(o.loop_min_separation, o.local_model_frames * o.keyframe_interval)},
          {"loop_max_distance_m", o.loop_max_distance_m},
          {"loop_max_angle_deg", o.loop_max_angle_deg},
          {"loop_candidates_per_keyframe", o.loop_candidates_per_keyframe},
          {"max_loop_candidates", o.max_loop_candidates},
          {"loop_min_fitness", o.loop_min_fitness}};
}

bench::Workload seven_scenes_workload() {
  const locard::RgbdSequence& seq = seven_scenes();
  const fs::path dir = bench::work_folder("alignment");
  const fs::path frames = dir / "frames.txt";
  std::ofstream f(frames);
  for (const auto& e : seq.frames)
    f << e.frame_index << ' ' << fmt::format("{:.6f}", e.timestamp) << ' '
      << e.color_path.string() << ' ' << e.depth_path.string() << '\n';
  const locard::AlignmentOptions o = locard_defaults();
  bench::Workload w;
  w.kernel = "align_sequence";
  w.inputs = {{"frames", frames.string()},
              {"intrinsics",
               {{"width", seq.intrinsics.width}, {"height", seq.intrinsics.height},
                {"fx", seq.intrinsics.fx}, {"fy", seq.intrinsics.fy},
                {"cx", seq.intrinsics.cx}, {"cy", seq.intrinsics.cy},
                {"depth_scale", seq.depth_scale}}}};
  w.parameters = {{"min_depth_m", o.min_depth_m}, {"max_depth_m", o.max_depth_m},
                  {"loop_policy", loop_policy(o)}};
  return w;
}

nlohmann::json locard_align(const bench::Workload& w) {
  const locard::RgbdSequence& seq = seven_scenes();
  locard::AlignmentOptions o = locard_defaults();
  o.min_depth_m = w.parameters["min_depth_m"].get<double>();
  o.max_depth_m = w.parameters["max_depth_m"].get<double>();
  const locard::AlignmentResult r = locard::align_sequence(seq, o);
  std::size_t loops = 0;
  for (const auto& c : r.loops) loops += c.accepted;
  return {{"trajectory", bench::trajectory_rows(r.trajectory(0))}, {"loop_edges", loops},
          {"frames", r.frames.size()}};
}

void report_seven_scenes(const bench::Comparison& c) {
  const locard::RgbdSequence& seq = seven_scenes();
  for (const auto& side : c.sides()) {
    const bench::SideRun* run = c.run_of(side->name());
    if (!run) continue;
    const locard::Trajectory est = bench::trajectory_from_rows(run->output.at("trajectory"));
    fmt::print("  {:<8} ATE {:6.1f} mm, {}/{} frames posed, {} loop edges kept\n", run->side,
               est.size() >= 3 ? 1000.0 * ate_by_index(seq.ground_truth, est) : -1.0,
               est.size(), seq.frames.size(), run->output.value("loop_edges", 0));
  }
}

void add_seven_scenes() {
  auto& c = bench::add_comparison(
      "align_7scenes",
      "whole-sequence alignment, 7-Scenes subset (374 frames), Locard's defaults for the data "
      "and the same loop-candidate policy on both sides",
      {.warmup = 0, .repeats = 1}, seven_scenes_workload);
  c.side(bench::in_process_side("locard", locard_align))
      .side(bench::open3d_side("open3d_alignment.py"));
  if (const char* all = std::getenv("LOCARD_BENCH_O3D_ODOMETRY"); all && std::string(all) == "1")
    c.side(bench::program_side(
        "o3d-rgbd", {"/usr/bin/python3",
                     (fs::path(__FILE__).parent_path() / "peers" / "open3d_alignment.py").string(),
                     "--rgbd-odometry"}));
  c.report(report_seven_scenes);
}

// --- Bedroom: Locard only -----------------------------------------------------------------

void BM_BedroomCumulative(benchmark::State& state) {
  const fs::path folder = bench::work_folder("alignment") / "bedroom";
  if (!fs::exists(folder / "groundtruth.txt")) {
    fs::remove_all(folder);
    locard::sim::write_simulated_scan(locard::sim::builtin_scene("bedroom"), folder);
  }
  const locard::RgbdSequence seq = locard::open_rgbd_sequence(folder);
  locard::AlignmentOptions options;
  options.mode = locard::AlignmentMode::Cumulative;
  locard::StageReport report;
  double ate = -1.0;
  for (auto _ : state) {
    const locard::AlignmentResult r = locard::align_sequence(seq, options);
    report = locard::make_stage_report(r, seq);
    ate = ate_by_index(seq.ground_truth, r.trajectory(0));
  }
  state.counters["ate_mm"] = 1000.0 * ate;
  const char* names[3] = {"after SVD", "after ICP", "after loop closure"};
  fmt::print("\nsimulated bedroom turn ({} views, cumulative)\n", seq.frames.size());
  for (int s = 0; s < 3; ++s)
    fmt::print("  {:<19} mean cumulative error {:6.2f} mm, ATE {:6.2f} mm\n", names[s],
               1000.0 * report.summary[s].mean_translation_m,
               1000.0 * report.summary[s].ate_rmse_m.value_or(-1.0));
}
BENCHMARK(BM_BedroomCumulative)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);

}  // namespace

int main(int argc, char** argv) {
  add_seven_scenes();
  return bench::run_main(argc, argv);
}
