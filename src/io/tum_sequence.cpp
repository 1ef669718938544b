#include <locard/io/rgbd_sequence.hpp>

#include "io/sequence_detail.hpp"
#include "io/text_lines.hpp"

#include <locard/core/error.hpp>
#include <locard/io/trajectory_io.hpp>

#include <cctype>
#include <optional>
#include <string>
#include <vector>

namespace locard {
namespace {

namespace fs = std::filesystem;
using io_detail::DataLines;

// TUM stores depth in units of 1/5000 m (vision.in.tum.de/data/datasets/rgbd-dataset/file_formats).
constexpr double kTumDepthScale = 5000.0;

struct ListEntry {
  double timestamp = 0.0;
  fs::path file;  // relative to the sequence folder, as written
};

// rgb.txt / depth.txt: "timestamp filename" per line, in time order.
std::vector<ListEntry> read_image_list(const fs::path& path) {
  DataLines lines(path);
  io_detail::TimeOrderCheck order;
  std::vector<ListEntry> entries;
  std::vector<std::string_view> tokens;
  while (lines.next(tokens)) {
    if (tokens.size() != 2)
      lines.fail("expected 'timestamp filename', found " + std::to_string(tokens.size()) +
                 " values");
    const auto t = io_detail::parse_number(tokens[0]);
    if (!t) lines.fail("cannot read timestamp '" + std::string(tokens[0]) + "'");
    order.check(lines, *t);
    entries.push_back({*t, fs::path(std::string(tokens[1]))});
  }
  return entries;
}

std::string folder_name(const fs::path& folder) {
  fs::path p = fs::absolute(folder).lexically_normal();
  if (p.filename().empty()) p = p.parent_path();
  std::string name = p.filename().string();
  for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return name;
}

// "freiburg1".."freiburg3" anywhere, or "fr1".."fr3" as a separate word ("tum-fr1-xyz").
std::optional<char> freiburg_camera(const std::string& name) {
  for (std::size_t i = name.find("freiburg"); i != std::string::npos;
       i = name.find("freiburg", i + 1)) {
    const std::size_t d = i + 8;
    if (d < name.size() && name[d] >= '1' && name[d] <= '3') return name[d];
  }
  const auto is_word = [&](std::size_t k) {
    return k < name.size() && std::isalnum(static_cast<unsigned char>(name[k]));
  };
  for (std::size_t i = name.find("fr"); i != std::string::npos; i = name.find("fr", i + 1)) {
    const std::size_t d = i + 2;
    if ((i == 0 || !is_word(i - 1)) && d < name.size() && name[d] >= '1' && name[d] <= '3' &&
        !is_word(d + 1))
      return name[d];
  }
  return std::nullopt;
}

void choose_intrinsics(RgbdSequence& sequence) {
  const fs::path json = sequence.root / "intrinsics.json";
  if (fs::is_regular_file(json)) {
    const IntrinsicsFile file = read_intrinsics_json_with_scale(json);
    sequence.intrinsics = file.intrinsics;
    sequence.intrinsics_source = "intrinsics.json";
    if (file.depth_scale) sequence.depth_scale = *file.depth_scale;
    return;
  }
  const std::string name = folder_name(sequence.root);
  if (const auto camera = freiburg_camera(name)) {
    const std::string preset = std::string("tum_freiburg") + *camera;
    sequence.intrinsics = CameraIntrinsics::preset(preset);
    sequence.intrinsics_source = "preset " + preset + " (folder name '" + name + "')";
    return;
  }
  sequence.intrinsics = CameraIntrinsics::preset("kinect_v1");
  sequence.intrinsics_source =
      "preset kinect_v1 (assumed: no intrinsics.json and no freiburg1/2/3 in the folder name)";
}

}  // namespace

RgbdSequence read_tum_sequence(const fs::path& folder, const SequenceOptions& options) {
  io_detail::require_folder(folder);
  if (!(options.max_time_difference >= 0.0))
    throw InputError("max_time_difference must be >= 0 seconds");
  RgbdSequence sequence;
  sequence.format = DatasetFormat::Tum;
  sequence.root = folder;
  sequence.depth_scale = kTumDepthScale;
  choose_intrinsics(sequence);
  io_detail::apply_overrides(sequence, options);

  const std::vector<ListEntry> colors = read_image_list(folder / "rgb.txt");
  const std::vector<ListEntry> depths = read_image_list(folder / "depth.txt");
  if (fs::is_regular_file(folder / "groundtruth.txt")) {
    sequence.ground_truth = read_tum_trajectory(folder / "groundtruth.txt");
    sequence.ground_truth_source = "groundtruth.txt";
  }

  std::vector<double> color_times, truth_times;
  for (const auto& c : colors) color_times.push_back(c.timestamp);
  for (const auto& p : sequence.ground_truth) truth_times.push_back(p.timestamp);

  // Depth is the primary stream: each depth image takes the nearest colour image (which may
  // then serve two depth images), as the TUM tools associate within a tolerance.
  for (std::size_t k = 0; k < depths.size(); ++k) {
    const double t = depths[k].timestamp;
    const auto c = io_detail::nearest_within(color_times, t, options.max_time_difference);
    if (!c) {
      ++sequence.dropped_frames;
      continue;
    }
    FrameEntry frame;
    frame.frame_index = static_cast<std::int64_t>(k);
    frame.timestamp = t;
    frame.depth_path = folder / depths[k].file;
    frame.color_path = folder / colors[*c].file;
    if (const auto g = io_detail::nearest_within(truth_times, t, options.max_time_difference))
      frame.T_world_camera = sequence.ground_truth[*g].T_world_camera;
    sequence.frames.push_back(std::move(frame));
  }
  return sequence;
}

}  // namespace locard
