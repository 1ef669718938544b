// Time to simulate the built-in bedroom scan (50 Kinect v2 views, as in the reference paper):
// in memory (ray casting + sensor model + colour), and written to disk as a TUM folder.
// The issue asks for a few seconds at most on 2 cores.
#include <locard/sim/scan_simulator.hpp>
#include <locard/sim/scan_writer.hpp>

#include <benchmark/benchmark.h>

#include <filesystem>
#include <unistd.h>

namespace {

using namespace locard::sim;

void BM_BuildBedroomSceneAndBvh(benchmark::State& state) {
  const Scene scene = builtin_scene("bedroom");
  for (auto _ : state) {
    ScanSimulator sim(scene);
    benchmark::DoNotOptimize(sim.view_count());
  }
}
BENCHMARK(BM_BuildBedroomSceneAndBvh)->Unit(benchmark::kMillisecond);

void BM_RenderOneView(benchmark::State& state) {
  Scene scene = builtin_scene("bedroom");
  scene.scanner.noise = state.range(0) != 0;
  const ScanSimulator sim(scene);
  std::size_t view = 0;
  for (auto _ : state) {
    SensorFrame frame = sim.render(view++ % sim.view_count());
    benchmark::DoNotOptimize(frame.depth.data().data());
  }
  state.counters["rays/s"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * 512 * 424 * (scene.scanner.noise ? 2 : 1),
      benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderOneView)->Arg(1)->Arg(0)->ArgName("noise")->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_SimulateBedroomScan50InMemory(benchmark::State& state) {
  const Scene scene = builtin_scene("bedroom");
  for (auto _ : state) {
    const ScanSimulator sim(scene);
    std::size_t valid = 0;
    for (std::size_t i = 0; i < sim.view_count(); ++i) {
      const SensorFrame frame = sim.render(i);
      for (std::uint16_t d : frame.depth.data()) valid += d != 0;
    }
    benchmark::DoNotOptimize(valid);
  }
  state.counters["views"] = 50;
}
BENCHMARK(BM_SimulateBedroomScan50InMemory)->Unit(benchmark::kMillisecond)->UseRealTime()
    ->Iterations(1);

void BM_SimulateBedroomScan50ToDisk(benchmark::State& state) {
  const Scene scene = builtin_scene("bedroom");
  const auto folder = std::filesystem::temp_directory_path() /
                      ("locard-scan-sim-bench-" + std::to_string(::getpid()));
  for (auto _ : state) {
    std::filesystem::remove_all(folder);
    ScanWriteOptions options;
    const ScanWriteSummary summary = write_simulated_scan(scene, folder, options);
    benchmark::DoNotOptimize(summary.valid_depth_pixels);
  }
  std::filesystem::remove_all(folder);
}
BENCHMARK(BM_SimulateBedroomScan50ToDisk)->Unit(benchmark::kMillisecond)->UseRealTime()
    ->Iterations(2);

}  // namespace

BENCHMARK_MAIN();
