// Voxel-grid down-sampling of a fused 7-Scenes cloud (30 frames spread over the sequence,
// back-projected with colour and put in the world frame by their ground-truth poses: ~8 M
// points), against Open3D (voxel_down_sample) and PCL (pcl::VoxelGrid) on the same cloud,
// in the same run. Every library averages positions and colours per voxel.
//
//   build/release/bench/filters_bench [--benchmark_min_time=2]
// PCL is measured when <build>/bench/pcl/locard_pcl_peer exists (configure with
// -DLOCARD_WITH_PCL=ON) or LOCARD_PCL_PEER names it.

#include "bench_peers.hpp"

#include <locard/io/ply.hpp>
#include <locard/preprocess/voxel_grid.hpp>

#include <benchmark/benchmark.h>
#include <fmt/format.h>
#include <tbb/task_arena.h>

#include <chrono>
#include <cstdlib>
#include <limits>
#include <map>

namespace {

constexpr std::size_t kFrames = 30;
constexpr int kPeerRepeats = 5;

const locard::PointCloud& fused_cloud() {
  static const locard::PointCloud cloud = locard::bench::fused_seven_scenes(kFrames);
  return cloud;
}

struct Measured {
  double best_seconds = std::numeric_limits<double>::infinity();
  double best_cpu_seconds = std::numeric_limits<double>::infinity();
  std::size_t output_points = 0;
};
std::map<int, Measured> g_locard;  // by voxel size in mm

void BM_VoxelDownSample(benchmark::State& state) {
  const locard::PointCloud& cloud = fused_cloud();
  const int voxel_mm = static_cast<int>(state.range(0));
  Measured& measured = g_locard[voxel_mm];
  for (auto _ : state) {
    const double cpu_start = locard::bench::cpu_seconds();
    const auto start = std::chrono::steady_clock::now();
    const locard::VoxelGridResult result = locard::voxel_down_sample(cloud, voxel_mm / 1000.f);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    benchmark::DoNotOptimize(result.cloud.positions.data());
    measured.best_seconds = std::min(measured.best_seconds, seconds);
    measured.best_cpu_seconds =
        std::min(measured.best_cpu_seconds, locard::bench::cpu_seconds() - cpu_start);
    measured.output_points = result.cloud.size();
  }
  state.counters["points"] = static_cast<double>(cloud.size());
  state.counters["voxels"] = static_cast<double>(measured.output_points);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * cloud.size()));
}
BENCHMARK(BM_VoxelDownSample)->Arg(10)->Arg(50)->Unit(benchmark::kMillisecond)->UseRealTime()
    ->MinTime(5.0);  // several iterations: the best one is reported, like the peers

std::filesystem::path pcl_peer(const char* argv0) {
  if (const char* env = std::getenv("LOCARD_PCL_PEER")) return env;
  return std::filesystem::absolute(argv0).parent_path() / "pcl" / "locard_pcl_peer";
}

void print_peer(const std::string& name, const nlohmann::json& peer, const Measured& locard) {
  if (peer.is_discarded()) {
    fmt::print("  {:7}: not measured\n", name);
    return;
  }
  const double seconds = peer["seconds"].get<double>();
  const double cpu = peer["cpu_seconds"].get<double>();
  fmt::print("  {:7}: {:9.1f} ms wall, {:9.1f} ms CPU  ({} voxels)  -> locard is {:.2f}x faster "
             "(wall), {:.2f}x less CPU ({})\n", name, 1e3 * seconds, 1e3 * cpu,
             peer["output_points"].get<std::size_t>(), seconds / locard.best_seconds,
             cpu / locard.best_cpu_seconds, peer["peer"].get<std::string>());
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();

  const locard::PointCloud& cloud = fused_cloud();
  const auto dir = std::filesystem::temp_directory_path() / "locard-filters-bench";
  std::filesystem::create_directories(dir);
  const auto ply = dir / "fused_7scenes.ply";
  locard::write_ply(ply, cloud);
  const auto script = std::filesystem::path(__FILE__).parent_path() / "peers" / "open3d_filters.py";
  const auto pcl = pcl_peer(argv[0]);

  fmt::print("\nvoxel down-sampling, fused 7-Scenes cloud: {} frames, {} points with colour, "
             "{} threads\n", kFrames, cloud.size(), tbb::this_task_arena::max_concurrency());
  for (const auto& [voxel_mm, locard] : g_locard) {
    const std::string voxel = fmt::format("{}", voxel_mm / 1000.0);
    fmt::print("voxel {} m\n  locard : {:9.1f} ms wall, {:9.1f} ms CPU  ({} voxels)\n", voxel,
               1e3 * locard.best_seconds, 1e3 * locard.best_cpu_seconds, locard.output_points);
    print_peer("open3d",
               locard::bench::run_peer(fmt::format("/usr/bin/python3 {} {} {} {}",
                                                   locard::bench::quoted(script),
                                                   locard::bench::quoted(ply), voxel, kPeerRepeats)),
               locard);
    if (std::filesystem::exists(pcl)) {
      print_peer("pcl", locard::bench::run_peer(fmt::format("{} voxel {} {} {}",
                                                            locard::bench::quoted(pcl),
                                                            locard::bench::quoted(ply), voxel,
                                                            kPeerRepeats)),
                 locard);
    } else {
      fmt::print("  pcl    : not measured ({} not built: -DLOCARD_WITH_PCL=ON)\n", pcl.string());
    }
  }
  std::filesystem::remove_all(dir);
  return 0;
}
