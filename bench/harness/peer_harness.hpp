#pragma once
// One harness for every benchmark that compares Locard with a peer (Open3D, PCL).
//
// A *workload* is what every side gets: the same input files, the same parameters, the same
// warm-up and repeat count and the same thread count. A *side* runs the workload: Locard in
// this process, a peer as a separate program that reads the workload from a task file
// (bench/peers/peer_protocol.py for Python peers, bench/pcl/peer_protocol.hpp for C++ ones). Every side
// prepares its data outside the clock (reading files), runs `warmup` untimed passes, then
// `repeats` timed passes, and returns one wall and one CPU time per pass plus the last pass's
// output (transforms, counts) for the benchmark to score with one evaluator.
//
// Each side is registered as a Google Benchmark with `repeats` iterations on manual time
// (name "<comparison>/<side>"), so --benchmark_filter selects comparisons and sides, and the
// benchmark table shows every side with the same iteration count. After the run, every
// comparison prints its ratio table (median over the repeats, peer / Locard) and its own
// quality lines.
//
// Model: small_gicp's bench/ (one driver, the same loop for every library).
#include <locard/core/pose.hpp>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace locard::bench {

struct Workload {
  std::string kernel;         // what a peer program dispatches on ("voxel_down_sample", ...)
  nlohmann::json inputs;      // file paths, the same for every side
  nlohmann::json parameters;  // every number both sides use
  int warmup = 1;
  int repeats = 3;
  int threads = 0;  // 0: this machine's cores (set by the harness, passed to every peer)
};

// Wall and CPU (user + system, all threads) seconds of each timed pass.
struct Timings {
  std::vector<double> wall_s;
  std::vector<double> cpu_s;
  double median_wall() const;
  double median_cpu() const;
  double best_wall() const;
};

struct SideRun {
  std::string side;                         // "locard", "open3d", "pcl"
  std::string version;                      // as the side reports it ("open3d 0.16.1")
  std::optional<std::string> not_measured;  // why, when the side could not run
  Timings timings;
  nlohmann::json output;  // the last timed pass's output
  bool measured() const { return !not_measured; }
};

// One implementation of a workload.
class Side {
 public:
  virtual ~Side() = default;
  virtual std::string name() const = 0;
  virtual SideRun run(const Workload& workload) const = 0;
};

// Locard, in this process: `kernel` is called warmup + repeats times; its returned JSON of the
// last call is the output.
using Kernel = std::function<nlohmann::json(const Workload&)>;
std::unique_ptr<Side> in_process_side(std::string name, Kernel kernel);

// A program speaking the protocol: `command` + the task file's path as the last argument;
// its last stdout line is {"peer", "kernel", "seconds": [...], "cpu_seconds": [...], "output"}.
std::unique_ptr<Side> program_side(std::string name, std::vector<std::string> command);
// bench/peers/<script> under Debian's /usr/bin/python3 (python3-open3d).
std::unique_ptr<Side> open3d_side(const std::string& script);
// <build>/bench/pcl/<program> (configure with -DLOCARD_WITH_PCL=ON), or LOCARD_PCL_PEER_DIR.
std::unique_ptr<Side> pcl_side(const std::string& program);

// Warm-up and timed passes a comparison declares (every side gets the same).
struct Counts {
  int warmup = 1;
  int repeats = 3;
};

class Comparison {
 public:
  using Prepare = std::function<Workload()>;
  using Report = std::function<void(const Comparison&)>;

  Comparison(std::string name, std::string title, Counts counts, Prepare prepare);

  Comparison& side(std::unique_ptr<Side> side);  // the first one is the reference (Locard)
  Comparison& report(Report report);             // quality lines printed after the table

  const std::string& name() const { return name_; }
  int declared_repeats() const { return counts_.repeats; }
  const Workload& workload();       // prepared on first use (inputs written then)
  // The workload the sides ran (for report callbacks); null before any side ran.
  const Workload* prepared() const { return workload_ ? &*workload_ : nullptr; }
  const SideRun* run_of(const std::string& side) const;  // null if not run (filtered out)
  const std::vector<std::unique_ptr<Side>>& sides() const { return sides_; }

  // Runs one side (once; later calls return the same run).
  const SideRun& run_side(std::size_t index);
  void print() const;

 private:
  std::string name_, title_;
  Counts counts_;
  Prepare prepare_;
  std::optional<Workload> workload_;
  std::vector<std::unique_ptr<Side>> sides_;
  std::vector<std::optional<SideRun>> runs_;
  Report report_;
};

// Adds a comparison to the program's registry; registered with Google Benchmark by run_main.
Comparison& add_comparison(std::string name, std::string title, Counts counts,
                           Comparison::Prepare prepare);

// Google Benchmark's main plus the comparisons' tables: every side of every comparison whose
// "<name>/<side>" passes --benchmark_filter runs; then each comparison prints. Extra options:
//   --repeats=N  --warmup=N   override every workload's counts (the same on every side)
int run_main(int argc, char** argv);

// A scratch folder for one benchmark's inputs (removed by run_main at exit).
std::filesystem::path work_folder(const std::string& bench_name);

// Poses between the sides: 4x4 row-major, 16 numbers (numpy's reshape(-1) on the peers' side);
// a trajectory is rows [frame_index, 16 numbers]. Rows of another length are skipped.
nlohmann::json row_major(const Isometry3d& T);
Isometry3d from_row_major(const nlohmann::json& values, std::size_t offset = 0);
nlohmann::json trajectory_rows(const Trajectory& trajectory);
Trajectory trajectory_from_rows(const nlohmann::json& rows);

// Median of a list of seconds (0 when empty).
double median(std::vector<double> values);

}  // namespace locard::bench
