// Whole-sequence alignment against Open3D, same frames, same run.
//
//  7-Scenes  the 374 frames in ../shared/data (0..59 consecutive, then every 3rd to 999):
//            `locard align --mode odometry --odometry-icp point-to-plane` (frame-to-local-model
//            ICP, loop closure, pose graph), timed end to end (frame loading included). ATE RMSE against
//            the 1000-pose ground truth, poses paired by frame index.
//            Open3D peer (bench/peers/open3d_alignment.py): multi-scale point-to-plane ICP
//            chain + keyframe loop edges + LM pose graph ("icp", the faster of the two Open3D
//            pipelines of issue 5); with LOCARD_BENCH_O3D_ODOMETRY=1 also hybrid RGB-D
//            odometry + loop edges + LM ("odometry", ~450 s). Same frames, its own wall time,
//            its trajectory scored by the same evaluator.
//  Bedroom   the simulated Kinect v2 bedroom turn (50 views, `locard scan-sim` defaults),
//            written once to a temporary folder, `--mode cumulative`: the stage report's errors
//            after SVD, ICP and loop closure, and the ATE.
//
//   build/release/bench/alignment_bench --benchmark_filter=SevenScenes
#include "bench_peers.hpp"

#include <locard/alignment/sequential_alignment.hpp>
#include <locard/alignment/stage_report.hpp>
#include <locard/alignment/trajectory_eval.hpp>
#include <locard/io/trajectory_io.hpp>
#include <locard/sim/scan_writer.hpp>
#include <locard/sim/scene.hpp>

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <chrono>
#include <cstdlib>
#include <fstream>

namespace {

namespace fs = std::filesystem;

const fs::path kWork = fs::temp_directory_path() / "locard-alignment-bench";

struct Outcome {
  double seconds = 0.0;
  double ate_m = -1.0;
  std::size_t registered = 0;
  std::size_t frames = 0;
  std::size_t loops = 0;
  double stage_ate[3] = {-1, -1, -1};
  double stage_mean[3] = {-1, -1, -1};
};
Outcome g_seven, g_bedroom;

double ate_by_index(const locard::Trajectory& gt, const locard::Trajectory& est) {
  locard::AssociationOptions a;
  a.match_by_frame_index = true;
  return locard::absolute_trajectory_error(gt, est, a).translation.rmse;
}

Outcome run_locard(const locard::RgbdSequence& seq, const locard::AlignmentOptions& options) {
  Outcome o;
  const auto start = std::chrono::steady_clock::now();
  const locard::AlignmentResult r = locard::align_sequence(seq, options);
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const locard::Trajectory est = r.trajectory(0);
  o.frames = r.frames.size();
  o.registered = est.size();
  for (const auto& c : r.loops) o.loops += c.accepted;
  if (seq.has_ground_truth() && est.size() >= 3) o.ate_m = ate_by_index(seq.ground_truth, est);
  const locard::StageReport report = locard::make_stage_report(r, seq);
  for (int s = 0; s < 3; ++s) {
    if (report.summary[s].ate_rmse_m) o.stage_ate[s] = *report.summary[s].ate_rmse_m;
    if (report.summary[s].views) o.stage_mean[s] = report.summary[s].mean_translation_m;
  }
  return o;
}

void BM_SevenScenesOdometry(benchmark::State& state) {
  const locard::RgbdSequence seq = locard::open_rgbd_sequence(locard::bench::kSevenScenes);
  locard::AlignmentOptions options;
  options.mode = locard::AlignmentMode::Odometry;
  // Kinect v1: colour not registered to depth, so no photometric term (reconstruct's default
  // for this sensor).
  options.odometry_method = locard::IcpMethod::PointToPlane;
  for (auto _ : state) g_seven = run_locard(seq, options);
  state.counters["ate_mm"] = 1000.0 * g_seven.ate_m;
  state.counters["registered"] = static_cast<double>(g_seven.registered);
  state.counters["loops"] = static_cast<double>(g_seven.loops);
}
BENCHMARK(BM_SevenScenesOdometry)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);

void BM_BedroomCumulative(benchmark::State& state) {
  const fs::path folder = kWork / "bedroom";
  if (!fs::exists(folder / "groundtruth.txt")) {
    fs::remove_all(folder);
    locard::sim::write_simulated_scan(locard::sim::builtin_scene("bedroom"), folder);
  }
  const locard::RgbdSequence seq = locard::open_rgbd_sequence(folder);
  locard::AlignmentOptions options;
  options.mode = locard::AlignmentMode::Cumulative;
  for (auto _ : state) g_bedroom = run_locard(seq, options);
  state.counters["ate_mm"] = 1000.0 * g_bedroom.ate_m;
  state.counters["registered"] = static_cast<double>(g_bedroom.registered);
}
BENCHMARK(BM_BedroomCumulative)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);

// The Open3D peer on the same 7-Scenes frames; its trajectory is scored here.
struct PeerOutcome {
  bool ok = false;
  double seconds = 0.0;
  double ate_m = -1.0;
};

PeerOutcome run_open3d(const std::string& pipeline) {
  PeerOutcome p;
  const locard::RgbdSequence seq = locard::open_rgbd_sequence(locard::bench::kSevenScenes);
  fs::create_directories(kWork);
  const fs::path frames = kWork / "frames.txt";
  const fs::path intrinsics = kWork / "intrinsics.json";
  const fs::path out = kWork / ("open3d_" + pipeline + ".txt");
  {
    std::ofstream f(frames);
    for (const auto& e : seq.frames)
      f << e.frame_index << ' ' << fmt::format("{:.6f}", e.timestamp) << ' '
        << e.color_path.string() << ' ' << e.depth_path.string() << '\n';
    std::ofstream k(intrinsics);
    k << fmt::format(R"({{"width": {}, "height": {}, "fx": {}, "fy": {}, "cx": {}, "cy": {}, "depth_scale": {}}})",
                     seq.intrinsics.width, seq.intrinsics.height, seq.intrinsics.fx,
                     seq.intrinsics.fy, seq.intrinsics.cx, seq.intrinsics.cy, seq.depth_scale);
  }
  const std::string script =
      (fs::path(__FILE__).parent_path() / "peers" / "open3d_alignment.py").string();
  const nlohmann::json j =
      locard::bench::run_peer("/usr/bin/python3 " + locard::bench::quoted(script) + " " +
                              pipeline + " " + locard::bench::quoted(frames) + " " +
                              locard::bench::quoted(intrinsics) + " " + locard::bench::quoted(out));
  if (j.is_discarded() || !j.contains("seconds")) return p;
  p.ok = true;
  p.seconds = j["seconds"].get<double>();
  // Open3D's trajectory starts at the identity: same frames, same frame indices via timestamps.
  locard::Trajectory est = locard::read_tum_trajectory(out);
  for (std::size_t i = 0; i < est.size() && i < seq.frames.size(); ++i)
    est[i].frame_index = seq.frames[i].frame_index;
  p.ate_m = ate_by_index(seq.ground_truth, est);
  return p;
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();

  if (g_bedroom.frames) {
    fmt::print("\nsimulated bedroom turn ({} views, cumulative): {} registered, {:.1f} s\n",
               g_bedroom.frames, g_bedroom.registered, g_bedroom.seconds);
    const char* names[3] = {"after SVD", "after ICP", "after loop closure"};
    for (int s = 0; s < 3; ++s)
      fmt::print("  {:<19} mean cumulative error {:6.2f} mm, ATE {:6.2f} mm\n", names[s],
                 1000.0 * g_bedroom.stage_mean[s], 1000.0 * g_bedroom.stage_ate[s]);
  }
  if (!g_seven.frames) return 0;
  fmt::print("\n7-Scenes subset ({} frames, odometry mode)\n", g_seven.frames);
  fmt::print("  locard          : {:7.1f} s, ATE {:6.1f} mm, {} registered, {} loop closures\n",
             g_seven.seconds, 1000.0 * g_seven.ate_m, g_seven.registered, g_seven.loops);
  std::vector<std::string> pipelines{"icp"};
  if (const char* all = std::getenv("LOCARD_BENCH_O3D_ODOMETRY"); all && std::string(all) == "1")
    pipelines.push_back("odometry");
  for (const std::string& pipeline : pipelines) {
    const PeerOutcome p = run_open3d(pipeline);
    if (!p.ok) {
      fmt::print("  open3d {:<9}: not measured (/usr/bin/python3 with python3-open3d is "
                 "needed)\n",
                 pipeline);
      continue;
    }
    fmt::print("  open3d {:<9}: {:7.1f} s, ATE {:6.1f} mm\n", pipeline, p.seconds,
               1000.0 * p.ate_m);
    fmt::print("  ratio           : {:.1f}x faster than Open3D {} (ATE {:.1f} vs {:.1f} mm)\n",
               p.seconds / g_seven.seconds, pipeline, 1000.0 * g_seven.ate_m, 1000.0 * p.ate_m);
  }
  return 0;
}
