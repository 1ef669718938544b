// E57 write and read of 8 M coloured points (one scan: single-float xyz, 8-bit RGB), the size
// of one terrestrial scan. Issue 16 asks for each under 2 s on 2 cores. The file goes to the
// temp folder (page cache, so this measures the codec and the copy, not the disk).
//
//   build/release/bench/e57_bench [--benchmark_repetitions=N]
#include <locard/io/e57.hpp>

#include <benchmark/benchmark.h>

#include <filesystem>
#include <random>
#include <unistd.h>

namespace {

constexpr std::size_t kPoints = 8'000'000;

const std::vector<locard::E57Scan>& coloured_scan() {
  static const std::vector<locard::E57Scan> scans = [] {
    std::vector<locard::E57Scan> v(1);
    locard::E57Scan& s = v[0];
    s.name = "bench";
    std::mt19937 rng(8);
    std::uniform_real_distribution<float> u(-20.0f, 20.0f);
    s.cloud.positions.resize(kPoints);
    s.cloud.colors.resize(kPoints);
    for (std::size_t i = 0; i < kPoints; ++i) {
      s.cloud.positions[i] = {u(rng), u(rng), u(rng)};
      const auto c = static_cast<std::uint32_t>(rng());
      s.cloud.colors[i] = {static_cast<std::uint8_t>(c), static_cast<std::uint8_t>(c >> 8),
                           static_cast<std::uint8_t>(c >> 16)};
    }
    return v;
  }();
  return scans;
}

std::filesystem::path bench_file() {
  return std::filesystem::temp_directory_path() /
         ("locard-e57-bench-" + std::to_string(::getpid()) + ".e57");
}

void BM_E57Write8MColoured(benchmark::State& state) {
  const std::vector<locard::E57Scan>& scans = coloured_scan();
  const auto path = bench_file();
  for (auto _ : state) locard::write_e57(path, scans);
  state.counters["points_per_s"] = benchmark::Counter(
      static_cast<double>(state.iterations() * kPoints), benchmark::Counter::kIsRate);
  state.counters["file_MB"] = static_cast<double>(std::filesystem::file_size(path)) / 1e6;
  std::filesystem::remove(path);
}
BENCHMARK(BM_E57Write8MColoured)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

void BM_E57Read8MColoured(benchmark::State& state) {
  const auto path = bench_file();
  locard::write_e57(path, coloured_scan());
  for (auto _ : state) {
    const locard::E57File file = locard::read_e57(path);
    if (file.scans.at(0).cloud.size() != kPoints) state.SkipWithError("wrong point count");
    benchmark::DoNotOptimize(file.scans[0].cloud.positions.data());
  }
  state.counters["points_per_s"] = benchmark::Counter(
      static_cast<double>(state.iterations() * kPoints), benchmark::Counter::kIsRate);
  std::filesystem::remove(path);
}
BENCHMARK(BM_E57Read8MColoured)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

}  // namespace

BENCHMARK_MAIN();
