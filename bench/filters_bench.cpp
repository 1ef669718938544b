// Voxel-grid down-sampling of a fused 7-Scenes cloud (30 frames spread over the sequence,
// back-projected with colour and put in the world frame by their ground-truth poses: ~8 M
// points), against Open3D (voxel_down_sample) and PCL (pcl::VoxelGrid) on the same cloud,
// through the peer harness (bench/harness): the same PLY file, voxel size, warm-up, repeats and
// thread count on every side. Every library averages positions and colours per voxel; each side
// reads the PLY outside the clock.
//
//   build/release/bench/filters_bench [--benchmark_filter=voxel_10mm] [--repeats=N]
// PCL is measured when <build>/bench/pcl/locard_pcl_peer exists (configure with
// -DLOCARD_WITH_PCL=ON) or LOCARD_PCL_PEER_DIR names its folder.

#include "bench_data.hpp"
#include "peer_harness.hpp"

#include <locard/io/ply.hpp>
#include <locard/preprocess/voxel_grid.hpp>

#include <benchmark/benchmark.h>
#include <fmt/format.h>

namespace {

namespace bench = locard::bench;
constexpr std::size_t kFrames = 30;

const locard::PointCloud& fused_cloud() {
  static const locard::PointCloud cloud = bench::fused_seven_scenes(kFrames);
  return cloud;
}

const std::filesystem::path& fused_ply() {
  static const std::filesystem::path path = [] {
    const auto p = bench::work_folder("filters") / "fused_7scenes.ply";
    locard::write_ply(p, fused_cloud());
    return p;
  }();
  return path;
}

void add_voxel_comparison(int voxel_mm) {
  const double voxel = voxel_mm / 1000.0;
  bench::add_comparison(
      fmt::format("voxel_{}mm", voxel_mm),
      fmt::format("voxel down-sampling, {} m voxels, fused 7-Scenes cloud ({} frames, with "
                  "colour)", voxel, kFrames),
      {.warmup = 1, .repeats = 5},
      [voxel] {
        bench::Workload w;
        w.kernel = "voxel_down_sample";
        w.inputs = {{"cloud", fused_ply().string()}};
        w.parameters = {{"voxel", voxel}};
        return w;
      })
      .side(bench::in_process_side("locard",
                                   [](const bench::Workload& w) {
                                     const auto r = locard::voxel_down_sample(
                                         fused_cloud(), w.parameters["voxel"].get<float>());
                                     benchmark::DoNotOptimize(r.cloud.positions.data());
                                     return nlohmann::json{{"points", fused_cloud().size()},
                                                           {"voxels", r.cloud.size()}};
                                   }))
      .side(bench::open3d_side("open3d_filters.py"))
      .side(bench::pcl_side("locard_pcl_peer"))
      .report([](const bench::Comparison& c) {
        for (const auto& side : c.sides())
          if (const auto* run = c.run_of(side->name()))
            fmt::print("  {:<8} {} points -> {} voxels\n", run->side,
                       run->output.value("points", 0), run->output.value("voxels", 0));
      });
}

}  // namespace

int main(int argc, char** argv) {
  add_voxel_comparison(10);
  add_voxel_comparison(50);
  return bench::run_main(argc, argv);
}
