#include <locard/io/rgbd_sequence.hpp>

#include "io/sequence_detail.hpp"
#include "io/text_lines.hpp"

#include <locard/core/error.hpp>
#include <locard/io/trajectory_io.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

namespace locard {
namespace {

namespace fs = std::filesystem;

constexpr double kRedwoodDepthScale = 1000.0;  // millimetres
// The ICL-NUIM frames in the layout color/N.png, depth/N.png, pose.txt (as slambook2 ships
// the living-room sample): ICL-NUIM's TUM-format release, depth in 1/5000 m, and its published
// camera, whose fy is negative (image y up; see io_detail::flip_negative_fy).
constexpr double kIclNuimDepthScale = 5000.0;
// A frame at least this share valid is rendered depth: a real sensor leaves holes (shadows,
// edges, dark or shiny surfaces, range limits) in every frame.
constexpr double kSyntheticValidShare = 0.999;
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
// False when none was found (then the kinect_v1 preset is assumed).
bool choose_intrinsics(RgbdSequence& sequence) {
  for (const fs::path& dir : {sequence.root, sequence.root.parent_path()}) {
    if (dir.empty() || !fs::is_directory(dir)) continue;
    for (const auto& json : io_detail::list_files(dir, {".json"})) {
      if (!is_intrinsics_json(json)) continue;
      sequence.intrinsics = read_intrinsics_json(json);
      sequence.intrinsics_source =
          dir == sequence.root ? json.filename().string() : "../" + json.filename().string();
      return true;
    }
  }
  sequence.intrinsics = CameraIntrinsics::preset("kinect_v1");
  sequence.intrinsics_source = "preset kinect_v1 (assumed: no camera intrinsics JSON found)";
  return false;
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

// pose.txt: "tx ty tz qx qy qz qw" per line, camera-to-world, one line per frame in order.
Trajectory read_pose_list(const fs::path& path, const std::vector<FrameEntry>& frames) {
  io_detail::DataLines lines(path);
  Trajectory trajectory;
  std::vector<std::string_view> tokens;
  while (lines.next(tokens)) {
    if (tokens.size() != 7)
      lines.fail("expected 7 values 'tx ty tz qx qy qz qw', found " +
                 std::to_string(tokens.size()));
    double v[7];
    for (std::size_t i = 0; i < 7; ++i) {
      const auto x = io_detail::parse_number(tokens[i]);
      if (!x) lines.fail("cannot read number '" + std::string(tokens[i]) + "'");
      v[i] = *x;
    }
    const double q_norm = std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]);
    if (std::abs(q_norm - 1.0) > 0.01)
      lines.fail("quaternion (qx qy qz qw) has norm " + std::to_string(q_norm) + ", expected 1");
    if (trajectory.size() >= frames.size())
      lines.fail("more poses than the " + std::to_string(frames.size()) + " frames in depth/");
    StampedPose pose;
    pose.frame_index = static_cast<std::int64_t>(trajectory.size());
    pose.timestamp = frames[trajectory.size()].timestamp;
    pose.T_world_camera =
        isometry_from_translation_quaternion({v[0], v[1], v[2]}, v[3], v[4], v[5], v[6]);
    trajectory.push_back(pose);
  }
  if (trajectory.size() != frames.size())
    throw_input_error(path, "has " + std::to_string(trajectory.size()) + " poses for " +
                                std::to_string(frames.size()) + " frames in depth/");
  return trajectory;
}

// Colour and depth from one (registered) camera in both layouts. Rendered depth is recognised
// by the data (no holes in the first frame), not by a name; the capture kind by the ground
// truth's motion between consecutive frames when there is ground truth (Redwood's numbered
// frames are one 30 Hz stream; ICL-NUIM's five samples are tens of degrees apart).
void choose_traits(RgbdSequence& sequence, bool icl_layout) {
  SequenceTraits& t = sequence.traits;
  t.color_registered_to_depth = true;
  double valid = 0.0;
  if (!sequence.frames.empty() && fs::is_regular_file(sequence.frames.front().depth_path))
    valid = io_detail::valid_depth_share(sequence.frames.front().depth_path);
  t.sensor = valid >= kSyntheticValidShare ? DepthSensorKind::Synthetic
                                           : DepthSensorKind::StructuredLight;
  const auto step = io_detail::median_ground_truth_step(sequence.frames);
  const bool video = !step || (step->translation_m < io_detail::kMaxVideoStepM &&
                               step->rotation_deg < io_detail::kMaxVideoStepDeg);
  t.capture = video ? CaptureKind::HandHeldVideo : CaptureKind::Unknown;
  t.source = fmt::format(
      "{}: colour registered to depth; first depth frame {:.1f}% valid ({}){}",
      icl_layout ? "color/ + depth/ + pose.txt layout (ICL-NUIM sample)"
                 : "color/ + depth/ layout (Redwood / Open3D, PrimeSense video)",
      100.0 * valid, t.sensor == DepthSensorKind::Synthetic ? "no holes: rendered" : "a sensor's holes",
      step ? fmt::format("; median ground-truth step {:.3f} m, {:.2f} deg", step->translation_m,
                         step->rotation_deg)
           : std::string("; no ground truth: one numbered stream"));
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
  const bool intrinsics_file = !options.intrinsics && choose_intrinsics(sequence);
  choose_ground_truth(sequence);
  const bool icl_layout =
      sequence.ground_truth.empty() && fs::is_regular_file(folder / "pose.txt");
  if (icl_layout) {
    sequence.depth_scale = kIclNuimDepthScale;
    if (!options.intrinsics && !intrinsics_file) {
      CameraIntrinsics k;
      k.width = 640;
      k.height = 480;
      k.fx = 481.20;
      k.fy = -480.00;
      k.cx = 319.5;
      k.cy = 239.5;
      k.name = "icl_nuim";
      sequence.intrinsics = k;
      sequence.intrinsics_source =
          "ICL-NUIM published camera (color/ + depth/ + pose.txt layout, no intrinsics JSON)";
    }
    sequence.ground_truth = read_pose_list(folder / "pose.txt", sequence.frames);
    sequence.ground_truth_source = "pose.txt";
    for (std::size_t i = 0; i < sequence.frames.size(); ++i)
      sequence.frames[i].T_world_camera = sequence.ground_truth[i].T_world_camera;
  }
  io_detail::apply_overrides(sequence, options);
  io_detail::flip_negative_fy(sequence);
  choose_traits(sequence, icl_layout);
  return sequence;
}

}  // namespace locard
