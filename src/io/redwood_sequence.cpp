#include <locard/io/rgbd_sequence.hpp>

#include "io/sequence_detail.hpp"
#include "io/text_lines.hpp"

#include <locard/core/error.hpp>
#include <locard/io/trajectory_io.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

namespace locard {
namespace {

namespace fs = std::filesystem;

constexpr double kRedwoodDepthScale = 1000.0;  // millimetres
// Intrinsics files are tiny; skip large JSON (pose graphs, scene descriptions) unread.
constexpr std::uintmax_t kMaxIntrinsicsJsonBytes = 64 * 1024;

struct Pair {
  fs::path depth;
  fs::path color;
};

// rgbd.match: "depth/00000.png color/00000.jpg" per line (Open3D's order; a line that names
// color/ first is taken the other way round).
std::vector<Pair> read_match_file(const fs::path& folder) {
  io_detail::DataLines lines(folder / "rgbd.match", false);
  std::vector<Pair> pairs;
  std::vector<std::string_view> tokens;
  while (lines.next(tokens)) {
    if (tokens.size() != 2)
      lines.fail("expected 'depth/NAME.png color/NAME.jpg', found " +
                 std::to_string(tokens.size()) + " values");
    fs::path depth{std::string(tokens[0])};
    fs::path color{std::string(tokens[1])};
    if (depth.begin() != depth.end() && *depth.begin() == "color") std::swap(depth, color);
    pairs.push_back({folder / depth, folder / color});
  }
  return pairs;
}

std::vector<Pair> pair_by_order(const fs::path& folder) {
  const auto colors = io_detail::list_files(folder / "color", {".jpg", ".jpeg", ".png"});
  const auto depths = io_detail::list_files(folder / "depth", {".png"});
  if (!colors.empty() && colors.size() != depths.size())
    throw_input_error(folder, "color/ holds " + std::to_string(colors.size()) +
                                  " images but depth/ holds " + std::to_string(depths.size()) +
                                  "; pairing by sorted name needs equal counts (or an rgbd.match)");
  std::vector<Pair> pairs;
  for (std::size_t i = 0; i < depths.size(); ++i)
    pairs.push_back({depths[i], colors.empty() ? fs::path() : colors[i]});
  return pairs;
}

// True for a small JSON object that carries camera intrinsics (Open3D's or ours).
bool is_intrinsics_json(const fs::path& path) {
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  if (ec || size > kMaxIntrinsicsJsonBytes) return false;
  std::ifstream in(path);
  const auto j = nlohmann::json::parse(in, nullptr, false);  // no exceptions: unrelated files
  return j.is_object() && (j.contains("intrinsic_matrix") || j.contains("fx"));
}

// The camera JSON sits beside color/ and depth/ or, as in Open3D's test data, one folder up.
void choose_intrinsics(RgbdSequence& sequence) {
  for (const fs::path& dir : {sequence.root, sequence.root.parent_path()}) {
    if (dir.empty() || !fs::is_directory(dir)) continue;
    for (const auto& json : io_detail::list_files(dir, {".json"})) {
      if (!is_intrinsics_json(json)) continue;
      sequence.intrinsics = read_intrinsics_json(json);
      sequence.intrinsics_source =
          dir == sequence.root ? json.filename().string() : "../" + json.filename().string();
      return;
    }
  }
  sequence.intrinsics = CameraIntrinsics::preset("kinect_v1");
  sequence.intrinsics_source = "preset kinect_v1 (assumed: no camera intrinsics JSON found)";
}

// Ground truth: a .log trajectory with one entry per frame, numbered 0..n-1. Open3D's test
// data holds two that qualify: odometry.log and trajectory.log. Their frame-to-frame motions
// agree within about 2 mm, in different world frames. odometry.log is preferred: it is what
// Open3D's own TSDF-integration tutorial and tests fuse these frames with, and the data's
// SOURCE.md lists it as the frames' reference poses; trajectory.log serves Open3D's
// trajectory-IO examples. Other names follow alphabetically.
void choose_ground_truth(RgbdSequence& sequence) {
  auto logs = io_detail::list_files(sequence.root, {".log"});
  std::stable_partition(logs.begin(), logs.end(),
                        [](const fs::path& p) { return p.filename() == "odometry.log"; });
  for (const auto& log : logs) {
    Trajectory trajectory = read_redwood_log(log);
    if (trajectory.size() != sequence.frames.size()) continue;
    bool numbered = true;
    for (std::size_t i = 0; i < trajectory.size(); ++i)
      numbered = numbered && trajectory[i].frame_index == static_cast<std::int64_t>(i);
    if (!numbered) continue;
    for (std::size_t i = 0; i < trajectory.size(); ++i)
      sequence.frames[i].T_world_camera = trajectory[i].T_world_camera;
    sequence.ground_truth = std::move(trajectory);
    sequence.ground_truth_source = log.filename().string();
    return;
  }
}

}  // namespace

RgbdSequence read_redwood_sequence(const fs::path& folder, const SequenceOptions& options) {
  io_detail::require_folder(folder);
  io_detail::require_folder(folder / "depth");
  RgbdSequence sequence;
  sequence.format = DatasetFormat::Redwood;
  sequence.root = folder;
  sequence.depth_scale = kRedwoodDepthScale;

  const auto pairs =
      fs::is_regular_file(folder / "rgbd.match") ? read_match_file(folder) : pair_by_order(folder);
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    FrameEntry frame;
    frame.frame_index = static_cast<std::int64_t>(i);
    frame.timestamp = static_cast<double>(i) / io_detail::kAssumedFrameRate;
    frame.depth_path = pairs[i].depth;
    frame.color_path = pairs[i].color;
    sequence.frames.push_back(std::move(frame));
  }
  if (!options.intrinsics) choose_intrinsics(sequence);
  io_detail::apply_overrides(sequence, options);
  choose_ground_truth(sequence);
  return sequence;
}

}  // namespace locard
