// Loads and back-projects the 374-frame 7-Scenes subset (colour JPEG + 16-bit depth PNG ->
// coloured camera-frame points, depth 0-10 m) against Open3D (read_image,
// RGBDImage.create_from_color_and_depth, PointCloud.create_from_rgbd_image) through the peer
// harness (bench/harness): the same frame files,
// intrinsics, depth scale and range, warm-up, repeats and thread count on every side. Decoding
// is the workload, so each timed pass reads every image; only listing the frames is outside the
// clock. Locard decodes one frame per oneTBB task; Open3D's Python calls hold the GIL, so its
// peer goes frame by frame, as an Open3D user would.
// Quality, scored here for every side against Locard's: the point count of every frame (must be
// equal) and, for every `checked_every`-th frame, the sums of the point coordinates (metres)
// and colours (0-255), compared as the difference of the means per point.
//
//   build/release/bench/load_backproject_bench [--repeats=N] [--warmup=N]
#include "peer_harness.hpp"

#include <locard/io/rgbd_sequence.hpp>
#include <locard/preprocess/depth_to_points.hpp>

#include <benchmark/benchmark.h>
#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace {

namespace bench = locard::bench;

const std::filesystem::path kData =
    std::filesystem::path(LOCARD_SHARED_DATA) / "7scenes-tsdf-fusion" / "data";
constexpr int kCheckedEvery = 37;  // frames 0, 37, ... (11 of 374) get coordinate/colour sums

// Opened by the workload's preparation (outside the clock) with the workload's intrinsics and
// depth scale; the Locard side loads its frames.
std::optional<locard::RgbdSequence> g_sequence;

bench::Workload prepare() {
  bench::Workload w;
  w.kernel = "load_backproject";
  // 7-Scenes' pinhole intrinsics (camera-intrinsics.txt), depth in millimetres, 0-10 m kept.
  w.parameters = {{"width", 640},          {"height", 480},    {"fx", 585.0},
                  {"fy", 585.0},           {"cx", 320.0},      {"cy", 240.0},
                  {"depth_scale", 1000.0}, {"depth_min", 0.0}, {"depth_max", 10.0},
                  {"checked_every", kCheckedEvery}};
  const nlohmann::json& p = w.parameters;
  locard::SequenceOptions options;
  locard::CameraIntrinsics intrinsics;
  intrinsics.width = p["width"].get<int>();
  intrinsics.height = p["height"].get<int>();
  intrinsics.fx = p["fx"].get<double>();
  intrinsics.fy = p["fy"].get<double>();
  intrinsics.cx = p["cx"].get<double>();
  intrinsics.cy = p["cy"].get<double>();
  intrinsics.name = "benchmark workload";
  options.intrinsics = intrinsics;
  options.depth_scale = p["depth_scale"].get<double>();
  g_sequence = locard::open_rgbd_sequence(kData, options);
  nlohmann::json frames = nlohmann::json::array();
  for (const locard::FrameEntry& f : g_sequence->frames)
    frames.push_back({{"color", f.color_path.string()}, {"depth", f.depth_path.string()}});
  w.inputs = {{"frames", std::move(frames)}};
  return w;
}

// One timed pass: every frame decoded and back-projected, one frame per task.
nlohmann::json load_backproject(const bench::Workload& w) {
  const locard::RgbdSequence& seq = *g_sequence;
  locard::DepthToPointsOptions options;
  options.min_depth_m = w.parameters["depth_min"].get<double>();
  options.max_depth_m = w.parameters["depth_max"].get<double>();
  const std::size_t every = w.parameters["checked_every"].get<std::size_t>();
  const std::size_t n = seq.frames.size();
  std::vector<std::size_t> points(n, 0);
  std::vector<std::vector<double>> sums((n + every - 1) / every);
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
    const locard::RgbdFrame frame = seq.load_frame(i);
    const locard::PointCloud cloud = locard::depth_to_points(frame, options);
    points[i] = cloud.size();
    benchmark::DoNotOptimize(cloud.positions.data());
    if (i % every != 0) return;
    std::vector<double> s(6, 0.0);
    for (const Eigen::Vector3f& q : cloud.positions)
      for (int k = 0; k < 3; ++k) s[k] += q[k];
    for (const locard::Rgb8& c : cloud.colors) {
      s[3] += c.r;
      s[4] += c.g;
      s[5] += c.b;
    }
    sums[i / every] = std::move(s);
  });
  std::size_t total = 0;
  for (std::size_t count : points) total += count;
  return {{"frames", n},
          {"points", total},
          {"frame_points", points},
          {"checked_sums", sums}};
}

// A side's output value, or T{} when it is missing or of another shape (so one odd peer answer
// cannot stop the report).
template <typename T>
T read(const nlohmann::json& output, const char* key) {
  try {
    return output.value(key, T{});
  } catch (const nlohmann::json::exception&) {
    return T{};
  }
}

// The one evaluator: every side against the first measured side (Locard's when it ran).
void report(const bench::Comparison& c) {
  const bench::SideRun* reference = nullptr;
  for (const auto& side : c.sides())
    if ((reference = c.run_of(side->name()))) break;
  if (!reference) return;
  using Sums = std::vector<std::vector<double>>;
  const auto ref_points = read<std::vector<std::size_t>>(reference->output, "frame_points");
  const auto ref_sums = read<Sums>(reference->output, "checked_sums");
  const std::size_t every = kCheckedEvery;  // as the workload says
  fmt::print("  {:<8} {:>7} {:>13}  {}\n", "side", "frames", "points",
             fmt::format("vs {}: frames with other counts; largest difference of a frame's mean "
                         "xyz / rgb ({} frames checked)", reference->side, ref_sums.size()));
  for (const auto& side : c.sides()) {
    const bench::SideRun* run = c.run_of(side->name());
    if (!run) continue;
    const auto frame_points = read<std::vector<std::size_t>>(run->output, "frame_points");
    const auto sums = read<Sums>(run->output, "checked_sums");
    std::string against;
    if (run != reference) {
      std::size_t differing = 0;
      for (std::size_t i = 0; i < std::max(frame_points.size(), ref_points.size()); ++i)
        differing += i >= frame_points.size() || i >= ref_points.size() ||
                     frame_points[i] != ref_points[i];
      // Largest difference of a checked frame's mean point (m) and mean colour (0-255).
      double xyz = 0, rgb = 0;
      bool complete = sums.size() == ref_sums.size() && ref_points.size() == frame_points.size();
      for (std::size_t i = 0; complete && i < sums.size(); ++i) {
        complete = sums[i].size() == 6 && ref_sums[i].size() == 6 && i * every < ref_points.size();
        if (!complete) break;
        const double count = static_cast<double>(std::max<std::size_t>(1, ref_points[i * every]));
        for (std::size_t k = 0; k < 6; ++k) {
          const double d = std::abs(sums[i][k] - ref_sums[i][k]) / count;
          double& largest = k < 3 ? xyz : rgb;
          if (!(d <= largest)) largest = d;  // NaN sticks
        }
      }
      against = complete ? fmt::format("{} frames differ, means {:.1e} m / {:.1e}", differing,
                                       xyz, rgb)
                         : fmt::format("{} frames differ, sums missing", differing);
      if (differing || !complete || !(xyz <= 1e-6) || !(rgb <= 1e-6)) against += "  <- MISMATCH";
    }
    fmt::print("  {:<8} {:>7} {:>13}  {}\n", run->side, read<std::size_t>(run->output, "frames"),
               read<std::size_t>(run->output, "points"), against);
  }
}

}  // namespace

int main(int argc, char** argv) {
  bench::add_comparison("load_backproject",
                        "load + back-project, 7-Scenes subset (colour JPEG + depth PNG -> "
                        "coloured camera-frame points)",
                        {.warmup = 1, .repeats = 3}, prepare)
      .side(bench::in_process_side("locard", load_backproject))
      .side(bench::open3d_side("open3d_load_backproject.py"))
      .report(report);
  return bench::run_main(argc, argv);
}
