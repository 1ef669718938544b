// TSDF fusion of the 7-Scenes subset (374 frames at their ground-truth poses) + coloured
// marching cubes, against Open3D's ScalableTSDFVolume (integrate + extract_triangle_mesh),
// through the peer harness (bench/harness): the same frames, poses, voxel size, truncation and
// depth range, warm-up, repeats and threads on both sides. Each side decodes every image
// before the clock (prepare); a timed pass is a fresh volume, every integration, and the
// extraction.
// Peak memory above the decoded frames: ru_maxrss of a child process that does one pass (ours,
// forked before any thread starts) and of the Python peer, each less its resident size before
// the volume was created.
//
//   build/release/bench/tsdf_bench [--repeats=N]
//   LOCARD_TSDF_STEP=4 build/release/bench/tsdf_bench   # every 4th frame, for a quick look
#include "bench_data.hpp"
#include "peer_harness.hpp"

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

namespace {

namespace bench = locard::bench;
using bench::kSevenScenes;
constexpr double kVoxel = 4.0 / 512.0;  // Open3D's examples: 4 m / 512 voxels
constexpr double kTruncation = 0.04;
constexpr double kMaxDepth = 4.0;

std::size_t frame_step() {
  const char* s = std::getenv("LOCARD_TSDF_STEP");
  return s ? static_cast<std::size_t>(std::max(1, std::atoi(s))) : 1;
}

struct DecodedFrames {
  std::vector<locard::RgbdFrame> frames;
  std::vector<locard::Isometry3d> poses;
};

DecodedFrames decode_frames() {
  const locard::RgbdSequence seq = locard::open_rgbd_sequence(kSevenScenes);
  DecodedFrames d;
  for (std::size_t i = 0; i < seq.frames.size(); i += frame_step()) {
    d.frames.push_back(seq.load_frame(i));
    d.poses.push_back(*seq.frames[i].T_world_camera);
  }
  return d;
}

const DecodedFrames& decoded() {
  static const DecodedFrames d = decode_frames();
  return d;
}

nlohmann::json fuse(const DecodedFrames& d) {
  using clock = std::chrono::steady_clock;
  locard::TsdfVolume volume(
      {.voxel_size = kVoxel, .truncation = kTruncation, .max_depth_m = kMaxDepth});
  const auto start = clock::now();
  for (std::size_t i = 0; i < d.frames.size(); ++i) volume.integrate(d.frames[i], d.poses[i]);
  const auto integrated = clock::now();
  const locard::TriangleMesh mesh = volume.extract_mesh();
  const auto end = clock::now();
  return {{"frames", d.frames.size()},
          {"integrate_seconds", std::chrono::duration<double>(integrated - start).count()},
          {"extract_seconds", std::chrono::duration<double>(end - integrated).count()},
          {"vertices", mesh.vertex_count()},
          {"triangles", mesh.triangle_count()},
          {"volume_mib", volume.stats().memory_bytes / 1048576.0}};
}

long current_rss_kib() {
  FILE* f = std::fopen("/proc/self/statm", "r");
  long pages = 0, resident = 0;
  if (f) {
    if (std::fscanf(f, "%ld %ld", &pages, &resident) != 2) resident = 0;
    std::fclose(f);
  }
  return resident * (::sysconf(_SC_PAGESIZE) / 1024);
}

// One pass in a forked child (before any thread exists): {peak, before the volume} KiB.
std::pair<long, long> measure_peak_memory() {
  int fds[2];
  if (::pipe(fds) != 0) return {0, 0};
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    const DecodedFrames d = decode_frames();
    const long before = current_rss_kib();
    (void)fuse(d);
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

std::pair<long, long> g_locard_memory_kib;

bench::Workload tsdf_workload() {
  const locard::RgbdSequence seq = locard::open_rgbd_sequence(kSevenScenes);
  bench::Workload w;
  w.kernel = "tsdf_fusion";
  nlohmann::json frames = nlohmann::json::array();
  for (std::size_t i = 0; i < seq.frames.size(); i += frame_step()) {
    const auto& e = seq.frames[i];
    frames.push_back({{"color", e.color_path.string()}, {"depth", e.depth_path.string()},
                      {"T_world_camera", bench::row_major(*e.T_world_camera)}});
  }
  w.inputs = {{"frames", frames},
              {"intrinsics",
               {{"width", seq.intrinsics.width}, {"height", seq.intrinsics.height},
                {"fx", seq.intrinsics.fx}, {"fy", seq.intrinsics.fy},
                {"cx", seq.intrinsics.cx}, {"cy", seq.intrinsics.cy}}},
              {"depth_scale", seq.depth_scale}};
  w.parameters = {{"voxel", kVoxel}, {"truncation", kTruncation}, {"max_depth_m", kMaxDepth}};
  (void)decoded();  // Locard's decoding, outside the clock as the peer's
  return w;
}

void report(const bench::Comparison& c) {
  for (const auto& side : c.sides()) {
    const bench::SideRun* run = c.run_of(side->name());
    if (!run) continue;
    const nlohmann::json& o = run->output;
    fmt::print("  {:<8} {} frames: integrate {:.3f} s, extract {:.3f} s; {} vertices, {} "
               "triangles\n",
               run->side, o.value("frames", 0), o.value("integrate_seconds", 0.0),
               o.value("extract_seconds", 0.0), o.value("vertices", 0), o.value("triangles", 0));
  }
  const auto [peak, before] = g_locard_memory_kib;
  fmt::print("  peak memory above the decoded frames: locard {:.0f} MiB (forked pass)", (peak - before) / 1024.0);
  if (const bench::SideRun* o3d = c.run_of("open3d"))
    fmt::print(", open3d {:.0f} MiB (its process, over its passes)",
               (o3d->output.value("max_rss_kib", 0.0) - o3d->output.value("rss_before_kib", 0.0)) / 1024.0);
  fmt::print("\n");
}

}  // namespace

int main(int argc, char** argv) {
  g_locard_memory_kib = measure_peak_memory();  // before any thread exists
  bench::add_comparison("tsdf_7scenes",
                        fmt::format("TSDF fusion + marching cubes, 7-Scenes subset at the "
                                    "reference poses (voxel {:.4f} m, truncation {} m, depth <= {} m)",
                                    kVoxel, kTruncation, kMaxDepth),
                        {.warmup = 1, .repeats = 3}, tsdf_workload)
      .side(bench::in_process_side("locard",
                                   [](const bench::Workload&) { return fuse(decoded()); }))
      .side(bench::open3d_side("open3d_tsdf.py"))
      .report(report);
  return bench::run_main(argc, argv);
}
