// Loads and back-projects the 374-frame 7-Scenes subset (colour JPEG + 16-bit depth PNG ->
// coloured camera-frame points), then runs Open3D on the same frames in the same process run
// and prints both throughputs and their ratio.
//
//   build/release/bench/load_backproject_bench [--benchmark_repetitions=N]
#include <locard/io/rgbd_sequence.hpp>
#include <locard/preprocess/depth_to_points.hpp>

#include <benchmark/benchmark.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <limits>

namespace {

const std::filesystem::path kData = std::filesystem::path(LOCARD_SHARED_DATA) /
                                    "7scenes-tsdf-fusion" / "data";
double g_best_seconds = std::numeric_limits<double>::infinity();
std::size_t g_frames = 0;
std::size_t g_points = 0;

void BM_LoadAndBackProject7Scenes(benchmark::State& state) {
  const locard::RgbdSequence seq = locard::open_rgbd_sequence(kData);
  locard::DepthToPointsOptions options;
  options.min_depth_m = 0.0;  // Open3D keeps every non-zero depth up to depth_trunc
  options.max_depth_m = 10.0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    std::atomic<std::size_t> points{0};
    // One frame per task: decoding dominates and frames are independent.
    tbb::parallel_for(std::size_t{0}, seq.frames.size(), [&](std::size_t i) {
      const locard::RgbdFrame frame = seq.load_frame(i);
      const locard::PointCloud cloud = locard::depth_to_points(frame, options);
      points += cloud.size();
      benchmark::DoNotOptimize(cloud.positions.data());
    });
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    g_best_seconds = std::min(g_best_seconds, seconds);
    g_points = points;
  }
  g_frames = seq.frames.size();
  state.SetItemsProcessed(static_cast<long>(state.iterations() * seq.frames.size()));
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations() * seq.frames.size()),
                         benchmark::Counter::kIsRate);
}
BENCHMARK(BM_LoadAndBackProject7Scenes)->Unit(benchmark::kMillisecond)->UseRealTime()
    ->MinTime(2.0);

nlohmann::json run_open3d() {
  const std::string script = std::filesystem::path(__FILE__).parent_path() / "peers" /
                             "open3d_load_backproject.py";
  const std::string command = "/usr/bin/python3 '" + script + "' '" + kData.string() + "' 3";
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return {};
  std::string out;
  std::array<char, 4096> buf{};
  std::size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) out.append(buf.data(), n);
  if (::pclose(pipe) != 0) return {};
  const auto line = out.substr(out.find('{'));
  return nlohmann::json::parse(line, nullptr, false);
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();

  const double locard_fps = g_frames / g_best_seconds;
  fmt::print("\nload + back-project, 7-Scenes subset ({} frames, colour + depth, camera frame)\n",
             g_frames);
  fmt::print("  locard : {:8.1f} frames/s  ({:.3f} s best, {} points)\n", locard_fps,
             g_best_seconds, g_points);
  const nlohmann::json peer = run_open3d();
  if (peer.is_discarded() || peer.empty()) {
    fmt::print("  open3d : not measured (/usr/bin/python3 with python3-open3d is needed)\n");
    return 0;
  }
  const double open3d_fps = peer["fps"].get<double>();
  fmt::print("  {:7}: {:8.1f} frames/s  ({:.3f} s best, {} points)\n", "open3d", open3d_fps,
             peer["seconds"].get<double>(), peer["points"].get<std::size_t>());
  fmt::print("  ratio  : {:.2f}x Open3D ({})\n", locard_fps / open3d_fps,
             peer["peer"].get<std::string>());
  if (peer["points"].get<std::size_t>() != g_points)
    fmt::print("  warning: point counts differ ({} vs {})\n", g_points,
               peer["points"].get<std::size_t>());
  return 0;
}
