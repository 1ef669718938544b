#include <locard/io/rgbd_sequence.hpp>

#include "io/sequence_detail.hpp"
#include "io/text_lines.hpp"

#include <locard/core/error.hpp>
#include <locard/io/image_io.hpp>

#include <algorithm>
#include <string>

namespace locard {
namespace {

namespace fs = std::filesystem;

bool is_seven_scenes_name(const std::string& name) {
  return name.starts_with("frame-") &&
         (name.ends_with(".pose.txt") || name.ends_with(".depth.png"));
}

bool contains_seven_scenes_file(const fs::path& folder) {
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(folder, ec))
    if (is_seven_scenes_name(entry.path().filename().string())) return true;
  return false;
}

bool contains_conf_file(const fs::path& folder) {
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(folder, ec))
    if (entry.is_regular_file(ec) && io_detail::lower_extension(entry.path()) == ".conf")
      return true;
  return false;
}

// PLY / PCD files directly in the folder (a set of range scans when there are two or more).
std::size_t count_scan_files(const fs::path& folder) {
  std::error_code ec;
  std::size_t n = 0;
  for (const auto& entry : fs::directory_iterator(folder, ec)) {
    const std::string ext = io_detail::lower_extension(entry.path());
    n += entry.is_regular_file(ec) && (ext == ".ply" || ext == ".pcd");
  }
  return n;
}

std::string frame_label(std::size_t i) { return " (frame " + std::to_string(i) + ")"; }

// Reads one image, adding the frame number to any error so the investigator can find it.
template <typename Reader>
auto read_frame_image(Reader reader, const fs::path& path, std::size_t i) {
  try {
    return reader(path);
  } catch (const InputError& e) {
    throw InputError(e.what() + frame_label(i));
  }
}

std::string size_text(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

}  // namespace

namespace io_detail {

void apply_overrides(RgbdSequence& sequence, const SequenceOptions& options) {
  if (options.intrinsics) {
    sequence.intrinsics = *options.intrinsics;
    sequence.intrinsics_source =
        "override" + (options.intrinsics->name.empty() ? "" : " " + options.intrinsics->name);
  }
  if (options.depth_scale) {
    if (!(*options.depth_scale > 0.0))
      throw InputError("depth scale override must be positive, got " +
                       std::to_string(*options.depth_scale));
    sequence.depth_scale = *options.depth_scale;
  }
}

std::vector<fs::path> list_files(const fs::path& folder,
                                 const std::vector<std::string>& extensions) {
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(folder)) {
    if (!entry.is_regular_file()) continue;
    const std::string ext = lower_extension(entry.path());
    if (std::find(extensions.begin(), extensions.end(), ext) != extensions.end())
      files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

void require_folder(const fs::path& folder) {
  if (!fs::exists(folder)) throw_input_error(folder, "folder not found");
  if (!fs::is_directory(folder)) throw_input_error(folder, "expected a folder");
}

}  // namespace io_detail

std::string_view to_string(DatasetFormat format) {
  switch (format) {
    case DatasetFormat::Tum: return "TUM RGB-D";
    case DatasetFormat::SevenScenes: return "7-Scenes";
    case DatasetFormat::Redwood: return "Redwood";
    case DatasetFormat::PlyCloud: return "PLY point cloud";
    case DatasetFormat::PcdCloud: return "PCD point cloud";
    case DatasetFormat::E57Cloud: return "E57 point cloud";
    case DatasetFormat::StanfordConf: return "Stanford .conf";
    case DatasetFormat::RangeScanFolder: return "folder of range scans";
    case DatasetFormat::Unknown: break;
  }
  return "unknown";
}

std::string_view to_string(DepthSensorKind kind) {
  switch (kind) {
    case DepthSensorKind::StructuredLight: return "structured_light";
    case DepthSensorKind::TimeOfFlight: return "time_of_flight";
    case DepthSensorKind::Synthetic: return "synthetic";
    case DepthSensorKind::Unknown: break;
  }
  return "unknown";
}

std::string_view to_string(CaptureKind kind) {
  switch (kind) {
    case CaptureKind::HandHeldVideo: return "hand_held_video";
    case CaptureKind::TripodTurn: return "tripod_turn";
    case CaptureKind::Unknown: break;
  }
  return "unknown";
}

DatasetFormat detect_format(const fs::path& path) {
  std::error_code ec;
  if (fs::is_regular_file(path, ec)) {
    const std::string ext = io_detail::lower_extension(path);
    if (ext == ".ply") return DatasetFormat::PlyCloud;
    if (ext == ".pcd") return DatasetFormat::PcdCloud;
    if (ext == ".e57") return DatasetFormat::E57Cloud;
    if (ext == ".conf") return DatasetFormat::StanfordConf;
    return DatasetFormat::Unknown;
  }
  if (!fs::is_directory(path, ec)) return DatasetFormat::Unknown;
  if (fs::is_regular_file(path / "rgb.txt", ec) && fs::is_regular_file(path / "depth.txt", ec))
    return DatasetFormat::Tum;
  if (io_detail::tum_association_file(path)) return DatasetFormat::Tum;
  if (contains_seven_scenes_file(path)) return DatasetFormat::SevenScenes;
  if (fs::is_directory(path / "color", ec) && fs::is_directory(path / "depth", ec))
    return DatasetFormat::Redwood;
  if (contains_conf_file(path)) return DatasetFormat::StanfordConf;
  if (count_scan_files(path) >= 2) return DatasetFormat::RangeScanFolder;
  return DatasetFormat::Unknown;
}

RgbdSequence open_rgbd_sequence(const fs::path& path, const SequenceOptions& options) {
  if (!fs::exists(path)) throw_input_error(path, "not found");
  const DatasetFormat format = detect_format(path);
  switch (format) {
    case DatasetFormat::Tum: return read_tum_sequence(path, options);
    case DatasetFormat::SevenScenes: return read_seven_scenes_sequence(path, options);
    case DatasetFormat::Redwood: return read_redwood_sequence(path, options);
    case DatasetFormat::PlyCloud:
    case DatasetFormat::PcdCloud:
    case DatasetFormat::E57Cloud:
    case DatasetFormat::StanfordConf:
    case DatasetFormat::RangeScanFolder:
      throw_input_error(path, "is a point-cloud input (" + std::string(to_string(format)) +
                                  "), not an RGB-D sequence");
    case DatasetFormat::Unknown: break;
  }
  throw_input_error(path,
                    "not a recognised RGB-D sequence: expected rgb.txt + depth.txt or associate.txt (TUM), "
                    "frame-*.depth.png / frame-*.pose.txt (7-Scenes) or color/ + depth/ "
                    "folders (Redwood)");
}

DepthImage RgbdSequence::load_depth(std::size_t i) const {
  if (i >= frames.size())
    throw_input_error(root, "frame " + std::to_string(i) + " requested, the sequence has " +
                                std::to_string(frames.size()) + " frames");
  DepthImage depth = read_frame_image(read_depth_image, frames[i].depth_path, i);
  if (invalid_depth_value)
    for (std::uint16_t& d : depth.data())
      if (d == *invalid_depth_value) d = 0;
  return depth;
}

RgbdFrame RgbdSequence::load_frame(std::size_t i) const {
  const FrameEntry& entry = frames[i];
  RgbdFrame frame;
  frame.depth = load_depth(i);
  if (!entry.color_path.empty()) {
    frame.color = read_frame_image(read_color_image, entry.color_path, i);
    if (frame.color.width() != frame.depth.width() || frame.color.height() != frame.depth.height())
      throw_input_error(entry.color_path,
                        "colour image is " + size_text(frame.color.width(), frame.color.height()) +
                            " but depth image " + entry.depth_path.string() + " is " +
                            size_text(frame.depth.width(), frame.depth.height()) +
                            "; they must match" + frame_label(i));
  }
  if (intrinsics.valid() &&
      (frame.depth.width() != intrinsics.width || frame.depth.height() != intrinsics.height))
    throw_input_error(entry.depth_path,
                      "depth image is " + size_text(frame.depth.width(), frame.depth.height()) +
                          " but the intrinsics (" + intrinsics_source + ") are for " +
                          size_text(intrinsics.width, intrinsics.height) + frame_label(i));
  frame.depth_scale = depth_scale;
  frame.intrinsics = intrinsics;
  frame.timestamp = entry.timestamp;
  frame.frame_index = entry.frame_index;
  frame.color_path = entry.color_path;
  frame.depth_path = entry.depth_path;
  return frame;
}

}  // namespace locard
