#include <locard/io/rgbd_sequence.hpp>

#include "io/sequence_detail.hpp"
#include "io/text_lines.hpp"

#include <locard/core/error.hpp>
#include <locard/io/trajectory_io.hpp>

#include <fmt/format.h>

#include <array>
#include <cctype>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

namespace locard {
namespace {

namespace fs = std::filesystem;
using io_detail::DataLines;

// TUM stores depth in units of 1/5000 m (vision.in.tum.de/data/datasets/rgbd-dataset/file_formats).
constexpr double kTumDepthScale = 5000.0;
// Names under which associate.py's output is kept beside rgb/ and depth/.
constexpr std::array<const char*, 3> kAssociationFiles = {"associate.txt", "associations.txt",
                                                          "association.txt"};

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

// ---- associate.txt: TUM's associate.py output, "t_a a/FILE t_b b/FILE" per line, rgb or depth
// first, optionally followed by a ground-truth pose "t tx ty tz qx qy qz qw" (associate.py run
// again with groundtruth.txt).
struct Association {
  double depth_time = 0.0;
  fs::path depth;
  double color_time = 0.0;
  fs::path color;
  std::optional<StampedPose> truth;
};

enum class Stream { Color, Depth, Unknown };

// Which stream a listed path belongs to: its folder ("rgb", "color", "colour", "depth"), else a
// JPEG extension (colour; depth is never JPEG).
Stream stream_of(const fs::path& file) {
  std::string first = file.begin() == file.end() ? std::string() : file.begin()->string();
  for (char& c : first) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (first == "depth") return Stream::Depth;
  if (first == "rgb" || first == "color" || first == "colour") return Stream::Color;
  const std::string ext = io_detail::lower_extension(file);
  if (ext == ".jpg" || ext == ".jpeg") return Stream::Color;
  return Stream::Unknown;
}

std::vector<Association> read_association_list(const fs::path& path) {
  DataLines lines(path);
  io_detail::TimeOrderCheck depth_order, truth_order;
  std::vector<Association> out;
  std::vector<std::string_view> tokens;
  while (lines.next(tokens)) {
    if (tokens.size() != 4 && tokens.size() != 12)
      lines.fail("expected 't_rgb rgb/FILE t_depth depth/FILE' (either order), optionally "
                 "followed by 't tx ty tz qx qy qz qw', found " +
                 std::to_string(tokens.size()) + " values");
    std::array<double, 10> v{};
    for (std::size_t i = 0, k = 0; i < tokens.size(); ++i) {
      if (i == 1 || i == 3) continue;
      const auto x = io_detail::parse_number(tokens[i]);
      if (!x) lines.fail("cannot read number '" + std::string(tokens[i]) + "'");
      v[k++] = *x;
    }
    const fs::path a{std::string(tokens[1])}, b{std::string(tokens[3])};
    const Stream sa = stream_of(a), sb = stream_of(b);
    const bool depth_first = (sa == Stream::Depth && sb != Stream::Depth) ||
                             (sa == Stream::Unknown && sb == Stream::Color);
    const bool color_first = (sa == Stream::Color && sb != Stream::Color) ||
                             (sa == Stream::Unknown && sb == Stream::Depth);
    if (!depth_first && !color_first)
      lines.fail("cannot tell which of '" + a.string() + "' and '" + b.string() +
                 "' is the colour and which the depth image (expected one under rgb/ and one "
                 "under depth/)");
    Association entry;
    entry.depth_time = depth_first ? v[0] : v[1];
    entry.depth = depth_first ? a : b;
    entry.color_time = depth_first ? v[1] : v[0];
    entry.color = depth_first ? b : a;
    depth_order.check(lines, entry.depth_time);
    if (tokens.size() == 12) {
      const double q_norm = std::sqrt(v[6] * v[6] + v[7] * v[7] + v[8] * v[8] + v[9] * v[9]);
      if (std::abs(q_norm - 1.0) > 0.01)
        lines.fail(fmt::format("quaternion (qx qy qz qw) has norm {:.6g}, expected 1", q_norm));
      truth_order.check(lines, v[2]);
      StampedPose pose;
      pose.frame_index = static_cast<std::int64_t>(out.size());
      pose.timestamp = v[2];
      pose.T_world_camera = isometry_from_translation_quaternion({v[3], v[4], v[5]}, v[6], v[7],
                                                                 v[8], v[9]);
      entry.truth = pose;
    }
    out.push_back(std::move(entry));
  }
  return out;
}

// rgb.txt + depth.txt (+ groundtruth.txt): depth is the primary stream; each depth image takes
// the nearest colour image (which may then serve two depth images), as the TUM tools associate
// within a tolerance.
void index_from_lists(RgbdSequence& sequence, const SequenceOptions& options) {
  const fs::path& folder = sequence.root;
  const std::vector<ListEntry> colors = read_image_list(folder / "rgb.txt");
  const std::vector<ListEntry> depths = read_image_list(folder / "depth.txt");
  if (fs::is_regular_file(folder / "groundtruth.txt")) {
    sequence.ground_truth = read_tum_trajectory(folder / "groundtruth.txt");
    sequence.ground_truth_source = "groundtruth.txt";
  }
  std::vector<double> color_times, truth_times;
  for (const auto& c : colors) color_times.push_back(c.timestamp);
  for (const auto& p : sequence.ground_truth) truth_times.push_back(p.timestamp);
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
}

// An association list: already paired. Ground truth from groundtruth.txt when present (every
// pose, associated within the tolerance), else from the poses on the lines.
void index_from_association(RgbdSequence& sequence, const fs::path& list,
                            const SequenceOptions& options) {
  const fs::path& folder = sequence.root;
  const std::vector<Association> entries = read_association_list(list);
  const bool truth_file = fs::is_regular_file(folder / "groundtruth.txt");
  std::vector<double> truth_times;
  if (truth_file) {
    sequence.ground_truth = read_tum_trajectory(folder / "groundtruth.txt");
    sequence.ground_truth_source = "groundtruth.txt";
    for (const auto& p : sequence.ground_truth) truth_times.push_back(p.timestamp);
  }
  for (std::size_t k = 0; k < entries.size(); ++k) {
    const Association& e = entries[k];
    FrameEntry frame;
    frame.frame_index = static_cast<std::int64_t>(k);
    frame.timestamp = e.depth_time;
    frame.depth_path = folder / e.depth;
    frame.color_path = folder / e.color;
    if (truth_file) {
      if (const auto g = io_detail::nearest_within(truth_times, e.depth_time,
                                                   options.max_time_difference))
        frame.T_world_camera = sequence.ground_truth[*g].T_world_camera;
    } else if (e.truth) {
      frame.T_world_camera = e.truth->T_world_camera;
      sequence.ground_truth.push_back(*e.truth);
    }
    sequence.frames.push_back(std::move(frame));
  }
  if (!truth_file && !sequence.ground_truth.empty())
    sequence.ground_truth_source =
        list.filename().string() + " (the pose associated with each frame)";
}

// A partial copy of a longer recording (the lists name every frame, the images stop early):
// the listed frames after the last one whose depth image exists are left out and counted.
// A frame missing in the middle stays, so loading it names the file; a folder with no image at
// all (an index-only copy) keeps its whole index for the same reason.
void cut_absent_tail(RgbdSequence& sequence) {
  std::size_t keep = sequence.frames.size();
  while (keep > 0 && !fs::exists(sequence.frames[keep - 1].depth_path)) --keep;
  if (keep == 0) return;
  sequence.absent_tail_frames = sequence.frames.size() - keep;
  sequence.frames.resize(keep);
}

void choose_traits(RgbdSequence& sequence, std::size_t listed_depth_frames) {
  if (auto t = io_detail::read_capture_json(sequence.root)) {
    std::size_t in_rings = 0;
    for (std::size_t n : t->ring_sizes) in_rings += n;
    if (!t->ring_sizes.empty() && in_rings != listed_depth_frames)
      throw_input_error(sequence.root / "capture.json",
                        fmt::format("\"ring_sizes\" add up to {} views but the sequence lists {} "
                                    "depth frames",
                                    in_rings, listed_depth_frames));
    sequence.traits = std::move(*t);
    return;
  }
  if (auto t = io_detail::traits_from_simulation_json(sequence.root)) {
    sequence.traits = std::move(*t);
    return;
  }
  // TUM RGB-D itself (vision.in.tum.de/data/datasets/rgbd-dataset/file_formats): Microsoft
  // Kinect / Asus Xtion, both PrimeSense structured light, recorded as a 30 Hz stream with
  // depth registered to colour by the OpenNI driver.
  SequenceTraits& t = sequence.traits;
  t.sensor = DepthSensorKind::StructuredLight;
  t.color_registered_to_depth = true;
  t.capture = io_detail::capture_from_timestamps(sequence.frames);
  const auto dt = io_detail::median_frame_interval(sequence.frames);
  t.source = fmt::format("TUM RGB-D layout without capture.json: structured-light sensor with "
                         "depth registered to colour (the TUM file format); {}",
                         dt ? fmt::format("median frame interval {:.3f} s", *dt)
                            : std::string("fewer than two frames"));
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

  const bool lists =
      fs::is_regular_file(folder / "rgb.txt") && fs::is_regular_file(folder / "depth.txt");
  if (lists) {
    index_from_lists(sequence, options);
  } else if (const auto list = io_detail::tum_association_file(folder)) {
    index_from_association(sequence, *list, options);
  } else {
    throw_input_error(folder, "expected rgb.txt + depth.txt or an association list (" +
                                  io_detail::tum_association_names() + ")");
  }
  const std::size_t listed = sequence.frames.size() + sequence.dropped_frames;
  cut_absent_tail(sequence);
  io_detail::flip_negative_fy(sequence);
  choose_traits(sequence, listed);
  return sequence;
}

namespace io_detail {

std::optional<fs::path> tum_association_file(const fs::path& folder) {
  for (const char* name : kAssociationFiles)
    if (fs::is_regular_file(folder / name)) return folder / name;
  return std::nullopt;
}

std::string tum_association_names() {
  std::string out;
  for (const char* name : kAssociationFiles) out += (out.empty() ? "" : ", ") + std::string(name);
  return out;
}

}  // namespace io_detail

}  // namespace locard
