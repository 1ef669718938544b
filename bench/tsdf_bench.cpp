// TSDF fusion of the 7-Scenes subset (374 frames at their ground-truth poses) + coloured
// marching cubes, against Open3D's ScalableTSDFVolume (integrate + extract_triangle_mesh) on
// the same frames, poses, voxel size, truncation and depth range, in the same run. Images are
// decoded outside the clock in both; the time is integration + extraction.
// Peak memory: ru_maxrss of a child process that does one full fusion (ours, forked before any
// thread starts) and of the Python child (Open3D), each with its resident size before the
// volume was created.
//
//   build/release/bench/tsdf_bench [--benchmark_repetitions=N]
//   LOCARD_TSDF_STEP=4 build/release/bench/tsdf_bench   # every 4th frame, for a quick look
#include "bench_peers.hpp"

#include <locard/io/rgbd_sequence.hpp>
#include <locard/surface/tsdf_volume.hpp>

#include <benchmark/benchmark.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <limits>

namespace {

using locard::bench::kSevenScenes;
constexpr double kVoxel = 4.0 / 512.0;  // Open3D's examples: 4 m / 512 voxels
constexpr double kTruncation = 0.04;
constexpr double kMaxDepth = 4.0;

std::size_t frame_step() {
  const char* s = std::getenv("LOCARD_TSDF_STEP");
  return s ? std::max(1, std::atoi(s)) : 1;
}

struct RunResult {
  double integrate_s = 0.0;
  double extract_s = 0.0;
  std::size_t frames = 0, vertices = 0, triangles = 0, blocks = 0, volume_bytes = 0;
};

RunResult fuse_once(const locard::RgbdSequence& seq) {
  using clock = std::chrono::steady_clock;
  locard::TsdfVolume volume(
      {.voxel_size = kVoxel, .truncation = kTruncation, .max_depth_m = kMaxDepth});
  RunResult r;
  for (std::size_t i = 0; i < seq.frames.size(); i += frame_step()) {
    const locard::RgbdFrame frame = seq.load_frame(i);
    const auto start = clock::now();
    volume.integrate(frame, *seq.frames[i].T_world_camera);
    r.integrate_s += std::chrono::duration<double>(clock::now() - start).count();
    ++r.frames;
  }
  const auto start = clock::now();
  const locard::TriangleMesh mesh = volume.extract_mesh();
  r.extract_s = std::chrono::duration<double>(clock::now() - start).count();
  r.vertices = mesh.vertex_count();
  r.triangles = mesh.triangle_count();
  r.blocks = volume.stats().blocks;
  r.volume_bytes = volume.stats().memory_bytes;
  return r;
}

RunResult g_best{std::numeric_limits<double>::infinity()};

void BM_TsdfFusion7Scenes(benchmark::State& state) {
  const locard::RgbdSequence seq = locard::open_rgbd_sequence(kSevenScenes);
  for (auto _ : state) {
    const RunResult r = fuse_once(seq);
    state.SetIterationTime(r.integrate_s + r.extract_s);
    if (r.integrate_s + r.extract_s < g_best.integrate_s + g_best.extract_s) g_best = r;
  }
  state.counters["frames"] = static_cast<double>(g_best.frames);
  state.counters["triangles"] = static_cast<double>(g_best.triangles);
}
BENCHMARK(BM_TsdfFusion7Scenes)->Unit(benchmark::kMillisecond)->UseManualTime()->Iterations(1);

long current_rss_kib() {
  FILE* f = std::fopen("/proc/self/statm", "r");
  long pages = 0, resident = 0;
  if (f) {
    if (std::fscanf(f, "%ld %ld", &pages, &resident) != 2) resident = 0;
    std::fclose(f);
  }
  return resident * (::sysconf(_SC_PAGESIZE) / 1024);
}

// One fusion in a forked child: its ru_maxrss is our peak memory. Returns {peak, before} KiB.
std::pair<long, long> measure_peak_memory() {
  int fds[2];
  if (::pipe(fds) != 0) return {0, 0};
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    const locard::RgbdSequence seq = locard::open_rgbd_sequence(kSevenScenes);
    const long before = current_rss_kib();
    (void)fuse_once(seq);
    if (::write(fds[1], &before, sizeof(before)) != sizeof(before)) ::_exit(1);
    ::_exit(0);
  }
  ::close(fds[1]);
  long before = 0;
  if (::read(fds[0], &before, sizeof(before)) != sizeof(before)) before = 0;
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  rusage usage{};
  ::getrusage(RUSAGE_CHILDREN, &usage);
  return {usage.ru_maxrss, before};
}

}  // namespace

int main(int argc, char** argv) {
  const auto [peak_kib, before_kib] = measure_peak_memory();  // before any thread exists
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();

  const double ours = g_best.integrate_s + g_best.extract_s;
  fmt::print("\nTSDF fusion, 7-Scenes subset: {} frames, voxel {:.4f} m, truncation {} m, depth "
             "<= {} m, ground-truth poses\n",
             g_best.frames, kVoxel, kTruncation, kMaxDepth);
  fmt::print("  locard : {:7.3f} s (integrate {:.3f} s, extract {:.3f} s), {} vertices, {} "
             "triangles, {} blocks of 8^3 ({:.0f} MiB)\n",
             ours, g_best.integrate_s, g_best.extract_s, g_best.vertices, g_best.triangles,
             g_best.blocks, g_best.volume_bytes / 1048576.0);
  fmt::print("           peak RSS {:.0f} MiB (resident before fusion {:.0f} MiB)\n",
             peak_kib / 1024.0, before_kib / 1024.0);
  const std::string command =
      fmt::format("/usr/bin/python3 {} {} {} {} {} {}",
                  locard::bench::quoted(std::filesystem::path(__FILE__).parent_path() / "peers" /
                                        "open3d_tsdf.py"),
                  locard::bench::quoted(kSevenScenes), kVoxel, kTruncation, kMaxDepth,
                  frame_step());
  const nlohmann::json peer = locard::bench::run_peer(command);
  if (peer.is_discarded()) {
    fmt::print("  open3d : not measured (/usr/bin/python3 with python3-open3d is needed)\n");
    return 0;
  }
  const double theirs = peer["seconds"].get<double>();
  fmt::print("  {:7}: {:7.3f} s (integrate {:.3f} s, extract {:.3f} s), {} vertices, {} "
             "triangles\n",
             "open3d", theirs, peer["integrate_seconds"].get<double>(),
             peer["extract_seconds"].get<double>(), peer["vertices"].get<std::size_t>(),
             peer["triangles"].get<std::size_t>());
  fmt::print("           peak RSS {:.0f} MiB (resident before the volume {:.0f} MiB)\n",
             peer["max_rss_kib"].get<double>() / 1024.0,
             peer["rss_before_kib"].get<double>() / 1024.0);
  fmt::print("  ratio  : {:.2f}x Open3D ({}), peak memory above baseline {:.0f} vs {:.0f} MiB\n",
             theirs / ours, peer["peer"].get<std::string>(), (peak_kib - before_kib) / 1024.0,
             (peer["max_rss_kib"].get<double>() - peer["rss_before_kib"].get<double>()) / 1024.0);
  return 0;
}
