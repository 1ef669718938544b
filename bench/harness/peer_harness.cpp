#include "peer_harness.hpp"

#include <benchmark/benchmark.h>
#include <fmt/format.h>
#include <tbb/task_arena.h>

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace locard::bench {
namespace fs = std::filesystem;
namespace {

struct Overrides {
  std::optional<int> repeats, warmup, threads;
};
Overrides g_overrides;

std::vector<std::unique_ptr<Comparison>>& registry() {
  static std::vector<std::unique_ptr<Comparison>> comparisons;
  return comparisons;
}

double process_cpu_seconds() {
  rusage usage{};
  ::getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

std::string shell_quoted(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string last_lines(const fs::path& file, std::size_t count) {
  std::ifstream in(file);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) lines.push_back(line);
  std::string out;
  for (std::size_t i = lines.size() > count ? lines.size() - count : 0; i < lines.size(); ++i)
    out += (out.empty() ? "" : " | ") + lines[i];
  return out;
}

// Peers may print progress; the protocol's answer is the last line that starts with '{'.
std::string last_json_line(const std::string& out) {
  std::istringstream in(out);
  std::string answer;
  for (std::string line; std::getline(in, line);)
    if (!line.empty() && line.front() == '{') answer = line;
  return answer;
}

class InProcessSide final : public Side {
 public:
  InProcessSide(std::string name, Kernel kernel)
      : name_(std::move(name)), kernel_(std::move(kernel)) {}
  std::string name() const override { return name_; }

  SideRun run(const Workload& w) const override {
    SideRun r;
    r.side = name_;
    r.version = name_ + " (this build)";
    tbb::task_arena arena(w.threads > 0 ? w.threads : tbb::task_arena::automatic);
    arena.execute([&] {
      for (int i = 0; i < w.warmup; ++i) kernel_(w);
      for (int i = 0; i < w.repeats; ++i) {
        const double cpu = process_cpu_seconds();
        const auto start = std::chrono::steady_clock::now();
        r.output = kernel_(w);
        r.timings.wall_s.push_back(
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        r.timings.cpu_s.push_back(process_cpu_seconds() - cpu);
      }
    });
    return r;
  }

 private:
  std::string name_;
  Kernel kernel_;
};

class ProgramSide final : public Side {
 public:
  ProgramSide(std::string name, std::vector<std::string> command)
      : name_(std::move(name)), command_(std::move(command)) {}
  std::string name() const override { return name_; }

  SideRun run(const Workload& w) const override {
    SideRun r;
    r.side = name_;
    if (command_.empty() || !fs::exists(command_.back())) {
      r.not_measured = fmt::format("{} not found", command_.empty() ? "" : command_.back());
      return r;
    }
    const fs::path folder = work_folder("peers");
    const fs::path task = folder / fmt::format("{}-{}.task.json", w.kernel, name_);
    const fs::path errors = folder / fmt::format("{}-{}.stderr.txt", w.kernel, name_);
    std::ofstream(task) << task_json(w).dump(2) << '\n';
    // The peer's OpenMP pool gets the thread count Locard's TBB arena gets.
    std::string line = fmt::format("OMP_NUM_THREADS={} ", w.threads);
    for (const std::string& part : command_) line += shell_quoted(part) + ' ';
    line += shell_quoted(task.string()) + " 2>" + shell_quoted(errors.string());
    std::string out;
    const int status = capture(line, out);
    const nlohmann::json j = nlohmann::json::parse(last_json_line(out), nullptr, false);
    if (status != 0 || j.is_discarded() || !j.is_object()) {
      r.not_measured = fmt::format("{} failed (exit {}): {}", command_.back(), status,
                                   last_lines(errors, 3));
      return r;
    }
    return from_protocol(w, j, std::move(r));
  }

 private:
  static nlohmann::json task_json(const Workload& w) {
    return {{"kernel", w.kernel},   {"inputs", w.inputs}, {"parameters", w.parameters},
            {"warmup", w.warmup},   {"repeats", w.repeats}, {"threads", w.threads}};
  }

  static int capture(const std::string& command, std::string& out) {
    FILE* pipe = ::popen(command.c_str(), "r");
    if (!pipe) return -1;
    std::array<char, 4096> buffer{};
    std::size_t n;
    while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0) out.append(buffer.data(), n);
    return ::pclose(pipe);
  }

  // Holds the peer to the workload: the same kernel and exactly `repeats` timed passes.
  static SideRun from_protocol(const Workload& w, const nlohmann::json& j, SideRun r) {
    r.version = j.value("peer", std::string("?"));
    const auto seconds = j.value("seconds", std::vector<double>{});
    const auto cpu = j.value("cpu_seconds", std::vector<double>{});
    if (j.value("kernel", std::string()) != w.kernel) {
      r.not_measured = fmt::format("peer ran kernel '{}', not '{}'", j.value("kernel", ""), w.kernel);
    } else if (seconds.size() != static_cast<std::size_t>(w.repeats) || cpu.size() != seconds.size()) {
      r.not_measured = fmt::format("peer returned {} timings for {} repeats", seconds.size(),
                                   w.repeats);
    }
    r.timings.wall_s = seconds;
    r.timings.cpu_s = cpu;
    r.output = j.value("output", nlohmann::json::object());
    return r;
  }

  std::string name_;
  std::vector<std::string> command_;
};

void register_benchmarks() {
  for (auto& comparison : registry()) {
    Comparison* c = comparison.get();
    for (std::size_t i = 0; i < c->sides().size(); ++i) {
      const std::string name = c->name() + "/" + c->sides()[i]->name();
      const int repeats = g_overrides.repeats.value_or(-1);
      auto* b = benchmark::RegisterBenchmark(name.c_str(), [c, i](benchmark::State& state) {
        const SideRun& r = c->run_side(i);
        if (!r.measured()) {
          state.SkipWithError(r.not_measured->c_str());
          for (auto _ : state) {
          }
          return;
        }
        std::size_t k = 0;
        for (auto _ : state) state.SetIterationTime(r.timings.wall_s.at(k++ % r.timings.wall_s.size()));
        state.counters["cpu_ms"] = 1e3 * r.timings.median_cpu();
      });
      b->UseManualTime()->Unit(benchmark::kMillisecond);
      b->Iterations(repeats > 0 ? repeats : c->declared_repeats());
    }
  }
}

}  // namespace

nlohmann::json row_major(const Isometry3d& T) {
  nlohmann::json out = nlohmann::json::array();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out.push_back(T.matrix()(r, c));
  return out;
}

Isometry3d from_row_major(const nlohmann::json& values, std::size_t offset) {
  Isometry3d T = Isometry3d::Identity();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      T.matrix()(r, c) = values.at(offset + static_cast<std::size_t>(4 * r + c)).get<double>();
  return T;
}

nlohmann::json trajectory_rows(const Trajectory& trajectory) {
  nlohmann::json rows = nlohmann::json::array();
  for (const StampedPose& p : trajectory) {
    nlohmann::json row = {p.frame_index};
    for (const auto& v : row_major(p.T_world_camera)) row.push_back(v);
    rows.push_back(std::move(row));
  }
  return rows;
}

Trajectory trajectory_from_rows(const nlohmann::json& rows) {
  Trajectory t;
  for (const nlohmann::json& row : rows) {
    if (row.size() != 17) continue;
    StampedPose p;
    p.frame_index = row[0].get<std::int64_t>();
    p.T_world_camera = from_row_major(row, 1);
    t.push_back(p);
  }
  return t;
}

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

double Timings::median_wall() const { return median(wall_s); }
double Timings::median_cpu() const { return median(cpu_s); }
double Timings::best_wall() const {
  return wall_s.empty() ? 0.0 : *std::min_element(wall_s.begin(), wall_s.end());
}

std::unique_ptr<Side> in_process_side(std::string name, Kernel kernel) {
  return std::make_unique<InProcessSide>(std::move(name), std::move(kernel));
}

std::unique_ptr<Side> program_side(std::string name, std::vector<std::string> command) {
  return std::make_unique<ProgramSide>(std::move(name), std::move(command));
}

std::unique_ptr<Side> open3d_side(const std::string& script) {
  const fs::path path = fs::path(LOCARD_BENCH_SOURCE_DIR) / "peers" / script;
  return program_side("open3d", {"/usr/bin/python3", path.string()});
}

std::unique_ptr<Side> pcl_side(const std::string& program) {
  const char* dir = std::getenv("LOCARD_PCL_PEER_DIR");
  // Beside this benchmark program (resolved from /proc, so it works before run_main too).
  const fs::path path =
      (dir ? fs::path(dir) : fs::read_symlink("/proc/self/exe").parent_path() / "pcl") / program;
  return program_side("pcl", {path.string()});
}

Comparison::Comparison(std::string name, std::string title, Counts counts, Prepare prepare)
    : name_(std::move(name)), title_(std::move(title)), counts_(counts),
      prepare_(std::move(prepare)) {}

Comparison& Comparison::side(std::unique_ptr<Side> side) {
  sides_.push_back(std::move(side));
  runs_.emplace_back();
  return *this;
}

Comparison& Comparison::report(Report report) {
  report_ = std::move(report);
  return *this;
}

const Workload& Comparison::workload() {
  if (!workload_) {
    Workload w = prepare_();
    w.warmup = g_overrides.warmup.value_or(counts_.warmup);
    w.repeats = g_overrides.repeats.value_or(counts_.repeats);
    w.threads = g_overrides.threads.value_or(tbb::this_task_arena::max_concurrency());
    workload_ = std::move(w);
  }
  return *workload_;
}

const SideRun& Comparison::run_side(std::size_t index) {
  if (!runs_.at(index)) runs_[index] = sides_[index]->run(workload());
  return *runs_[index];
}

const SideRun* Comparison::run_of(const std::string& side) const {
  for (std::size_t i = 0; i < sides_.size(); ++i)
    if (sides_[i]->name() == side && runs_[i] && runs_[i]->measured()) return &*runs_[i];
  return nullptr;
}

void Comparison::print() const {
  if (std::none_of(runs_.begin(), runs_.end(), [](const auto& r) { return r.has_value(); }))
    return;
  const Workload& w = *workload_;
  fmt::print("\n{} [{}]\n  {} warm-up + {} timed passes on every side, {} threads\n", title_,
             name_, w.warmup, w.repeats, w.threads);
  fmt::print("  {:<8} {:>13} {:>13} {:>13}  {}\n", "side", "median wall", "best wall",
             "median CPU", "median wall vs the first side");
  const SideRun* reference = runs_.front() && runs_.front()->measured() ? &*runs_.front() : nullptr;
  for (const auto& run : runs_) {
    if (!run) continue;
    if (!run->measured()) {
      fmt::print("  {:<8} not measured: {}\n", run->side, *run->not_measured);
      continue;
    }
    const Timings& t = run->timings;
    std::string ratio;
    if (reference && &*run != reference) {
      const double x = t.median_wall() / reference->timings.median_wall();
      ratio = fmt::format("{} is {:.2f}x {} ({})", reference->side, x >= 1 ? x : 1 / x,
                          x >= 1 ? "faster" : "slower", run->version);
    } else {
      ratio = run->version;
    }
    fmt::print("  {:<8} {:>10.1f} ms {:>10.1f} ms {:>10.1f} ms  {}\n", run->side,
               1e3 * t.median_wall(), 1e3 * t.best_wall(), 1e3 * t.median_cpu(), ratio);
  }
  if (report_) report_(*this);
}

Comparison& add_comparison(std::string name, std::string title, Counts counts,
                           Comparison::Prepare prepare) {
  registry().push_back(std::make_unique<Comparison>(std::move(name), std::move(title), counts,
                                                    std::move(prepare)));
  return *registry().back();
}

fs::path work_folder(const std::string& bench_name) {
  const fs::path folder = fs::temp_directory_path() /
                          fmt::format("locard-bench-{}", ::getpid()) / bench_name;
  fs::create_directories(folder);
  return folder;
}

int run_main(int argc, char** argv) {
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = [&](const std::string& flag) -> std::optional<int> {
      if (arg.rfind(flag + "=", 0) != 0) return std::nullopt;
      return std::stoi(arg.substr(flag.size() + 1));
    };
    if (auto v = value("--repeats")) g_overrides.repeats = std::max(1, *v);
    else if (auto v2 = value("--warmup")) g_overrides.warmup = std::max(0, *v2);
    else if (auto v3 = value("--threads")) g_overrides.threads = std::max(1, *v3);
    else rest.push_back(argv[i]);
  }
  int count = static_cast<int>(rest.size());
  benchmark::Initialize(&count, rest.data());
  if (benchmark::ReportUnrecognizedArguments(count, rest.data())) return 1;
  register_benchmarks();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  for (const auto& c : registry()) c->print();
  std::error_code ignored;
  fs::remove_all(fs::temp_directory_path() / fmt::format("locard-bench-{}", ::getpid()), ignored);
  return 0;
}

}  // namespace locard::bench
