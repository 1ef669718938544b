#include <locard/io/rgbd_sequence.hpp>

#include "io/sequence_detail.hpp"
#include "io/text_lines.hpp"

#include <locard/core/error.hpp>
#include <locard/io/image_io.hpp>

#include <fmt/format.h>

#include <map>
#include <optional>
#include <string>

namespace locard {
namespace {

namespace fs = std::filesystem;

constexpr double kSevenScenesDepthScale = 1000.0;  // millimetres
// Pose files carry 8 significant digits; a rotation further than this from orthonormal is
// not a pose.
constexpr double kRotationTolerance = 1e-3;

struct FrameFiles {
  fs::path color_jpg;
  fs::path color_png;
  fs::path depth;
  fs::path pose;
};

// "frame-000123.depth.png" -> 123 and "depth.png".
std::optional<std::pair<std::int64_t, std::string>> parse_frame_name(const std::string& name) {
  if (!name.starts_with("frame-")) return std::nullopt;
  const std::size_t dot = name.find('.', 6);
  if (dot == std::string::npos || dot == 6) return std::nullopt;
  const auto index = io_detail::parse_integer(std::string_view(name).substr(6, dot - 6));
  if (!index || *index < 0) return std::nullopt;
  return std::make_pair(*index, name.substr(dot + 1));
}

Isometry3d read_pose_file(const fs::path& path) {
  const std::string text = io_detail::read_text_file(path);
  const auto tokens = io_detail::split_tokens(text);
  if (tokens.size() != 16)
    throw_input_error(path, "expected a 4x4 camera-to-world matrix (16 numbers), found " +
                                std::to_string(tokens.size()) + " values");
  Eigen::Matrix4d m;
  for (std::size_t i = 0; i < 16; ++i) {
    const auto value = io_detail::parse_number(tokens[i]);
    if (!value)
      throw_input_error(path, "cannot read matrix value '" + std::string(tokens[i]) + "'");
    m(static_cast<Eigen::Index>(i / 4), static_cast<Eigen::Index>(i % 4)) = *value;
  }
  if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-9)
    throw_input_error(path, "last matrix row must be '0 0 0 1'");
  const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > kRotationTolerance)
    throw_input_error(path, "matrix is not a rigid transform (rotation not orthonormal)");
  // An orthonormal matrix with determinant -1 is a reflection: the camera's world mirrored.
  if (R.determinant() < 0.0)
    throw_input_error(path, "matrix is a reflection (rotation determinant -1), not a rigid "
                            "transform");
  Isometry3d T;
  T.matrix() = m;
  return T;
}

void choose_intrinsics(RgbdSequence& sequence) {
  const fs::path k_file = sequence.root / "camera-intrinsics.txt";
  if (!fs::is_regular_file(k_file)) {
    sequence.intrinsics = CameraIntrinsics::preset("seven_scenes");
    sequence.intrinsics_source = "preset seven_scenes (no camera-intrinsics.txt)";
    return;
  }
  // K does not say the image size; the first depth image does.
  if (sequence.frames.empty()) {
    const auto preset = CameraIntrinsics::preset("seven_scenes");
    sequence.intrinsics = read_intrinsics_matrix_txt(k_file, preset.width, preset.height);
    sequence.intrinsics_source = "camera-intrinsics.txt (size of preset seven_scenes: no frames)";
    return;
  }
  const ImageFileInfo info = read_image_info(sequence.frames.front().depth_path);
  sequence.intrinsics = read_intrinsics_matrix_txt(k_file, info.width, info.height);
  sequence.intrinsics_source = "camera-intrinsics.txt";
}

// 7-Scenes (Shotton et al. 2013; the data's SOURCE.md): a hand-held Kinect v1 (structured
// light) recorded at 30 Hz, its colour camera not registered to the depth camera. The capture
// kind is checked against the reference poses when frames have them: a stream moves a few
// centimetres between frames.
void choose_traits(RgbdSequence& sequence) {
  SequenceTraits& t = sequence.traits;
  t.sensor = DepthSensorKind::StructuredLight;
  t.color_registered_to_depth = false;
  const auto step = io_detail::median_ground_truth_step(sequence.frames);
  const bool video = !step || (step->translation_m < io_detail::kMaxVideoStepM &&
                               step->rotation_deg < io_detail::kMaxVideoStepDeg);
  t.capture = video ? CaptureKind::HandHeldVideo : CaptureKind::Unknown;
  t.source = "7-Scenes layout (frame-*.depth.png in mm, frame-*.pose.txt): hand-held Kinect v1 "
             "structured light, colour camera not registered to depth";
  if (step)
    t.source += fmt::format("; median ground-truth step {:.3f} m, {:.2f} deg", step->translation_m,
                            step->rotation_deg);
}

}  // namespace

RgbdSequence read_seven_scenes_sequence(const fs::path& folder, const SequenceOptions& options) {
  io_detail::require_folder(folder);
  RgbdSequence sequence;
  sequence.format = DatasetFormat::SevenScenes;
  sequence.root = folder;
  sequence.depth_scale = kSevenScenesDepthScale;
  // 7-Scenes marks pixels without a measurement with 65535 as well as 0 (19 frames of the
  // shared subset have such pixels); no Kinect v1 reading comes near 65.535 m.
  sequence.invalid_depth_value = 65535;

  std::map<std::int64_t, FrameFiles> files;  // ordered by frame number
  for (const auto& entry : fs::directory_iterator(folder)) {
    const auto parsed = parse_frame_name(entry.path().filename().string());
    if (!parsed) continue;
    FrameFiles& f = files[parsed->first];
    if (parsed->second == "color.jpg")
      f.color_jpg = entry.path();
    else if (parsed->second == "color.png")
      f.color_png = entry.path();
    else if (parsed->second == "depth.png")
      f.depth = entry.path();
    else if (parsed->second == "pose.txt")
      f.pose = entry.path();
  }

  // No timestamps in 7-Scenes: frames were captured at 30 Hz.
  for (const auto& [index, f] : files) {
    const double timestamp = static_cast<double>(index) / io_detail::kAssumedFrameRate;
    std::optional<Isometry3d> pose;
    if (!f.pose.empty()) {
      pose = read_pose_file(f.pose);
      sequence.ground_truth.push_back({index, timestamp, *pose});
    }
    const fs::path& color = f.color_png.empty() ? f.color_jpg : f.color_png;  // lossless first
    if (f.depth.empty() || color.empty()) continue;
    FrameEntry frame;
    frame.frame_index = index;
    frame.timestamp = timestamp;
    frame.color_path = color;
    frame.depth_path = f.depth;
    frame.T_world_camera = pose;
    sequence.frames.push_back(std::move(frame));
  }
  if (!sequence.ground_truth.empty()) sequence.ground_truth_source = "frame-*.pose.txt";

  if (!options.intrinsics) choose_intrinsics(sequence);
  io_detail::apply_overrides(sequence, options);
  io_detail::flip_negative_fy(sequence);
  choose_traits(sequence);
  return sequence;
}

}  // namespace locard
