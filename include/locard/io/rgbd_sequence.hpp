#pragma once
// Recorded RGB-D sequences, detected automatically from a folder:
//  - TUM RGB-D: rgb.txt, depth.txt (+ groundtruth.txt), or an associate.py list
//    (associate.txt: "t rgb/F t depth/F" either order, optionally with a pose per line); depth
//    scale 5000; colour and depth associated by nearest timestamp within a tolerance.
//  - 7-Scenes: frame-NNNNNN.{color.jpg|color.png, depth.png (mm), pose.txt (camera-to-world)}.
//  - Redwood / Open3D: color/, depth/, *.log trajectories, camera intrinsics JSON; also the
//    ICL-NUIM sample layout (color/, depth/, pose.txt "tx ty tz qx qy qz qw" per frame).
// Every reader fills `traits` from the data (docs/sensors.md lists the evidence).
// A sequence is a cheap index (paths, timestamps, poses); images are read by load_frame().

#include <locard/core/camera_intrinsics.hpp>
#include <locard/core/pose.hpp>
#include <locard/core/rgbd_frame.hpp>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace locard {

enum class DatasetFormat {
  Unknown,
  Tum,           // TUM RGB-D folder (also what `locard scan-sim` writes)
  SevenScenes,   // 7-Scenes folder
  Redwood,       // Redwood / Open3D folder
  PlyCloud,      // a single .ply file
  PcdCloud,      // a single .pcd file
  E57Cloud,      // a single .e57 file (one or more laser scans)
  StanfordConf,  // a Stanford .conf alignment file (or a folder holding one)
  RangeScanFolder,  // a folder of two or more .ply / .pcd range scans (io/range_scans.hpp)
};

std::string_view to_string(DatasetFormat format);

// What is at `path`; Unknown if nothing matches (callers report what was looked for).
DatasetFormat detect_format(const std::filesystem::path& path);

// What the data is, as typed facts the readers record (never guessed from a file or folder
// name). Every stage that picks defaults (align, reconstruct, mesh, the viewer) reads these.
enum class DepthSensorKind {
  Unknown,
  StructuredLight,  // Kinect v1, Asus Xtion, PrimeSense: noise grows with z^2
  TimeOfFlight,     // Kinect v2, Azure Kinect
  Synthetic,        // rendered depth (ICL-NUIM), exact up to the stated noise
};
enum class CaptureKind {
  Unknown,
  HandHeldVideo,  // a continuous stream: consecutive frames a fraction of a second apart
  TripodTurn,     // a set of views turned about a nearly fixed centre, in rings of pitch
};
std::string_view to_string(DepthSensorKind kind);
std::string_view to_string(CaptureKind kind);

struct SequenceTraits {
  DepthSensorKind sensor = DepthSensorKind::Unknown;
  CaptureKind capture = CaptureKind::Unknown;
  bool color_registered_to_depth = true;  // colour pixel (u, v) sees what depth pixel (u, v) sees
  // Tripod turn: views per pitch ring, in capture order (empty when unknown). A ring's first and
  // last views overlap; view k of ring r overlaps view k of ring r + 1 (same yaw).
  std::vector<std::size_t> ring_sizes;
  std::string source;  // where these facts came from, for reports ("capture.json", ...)
};

struct FrameEntry {
  std::int64_t frame_index = -1;
  double timestamp = 0.0;
  std::filesystem::path color_path;  // may be empty (depth-only)
  std::filesystem::path depth_path;
  std::optional<Isometry3d> T_world_camera;  // ground truth at this frame, when known
};

struct SequenceOptions {
  double max_time_difference = 0.02;           // TUM colour/depth/ground-truth association (s)
  std::optional<CameraIntrinsics> intrinsics;  // override what the dataset says
  std::optional<double> depth_scale;           // override (raw units per metre)
};

struct RgbdSequence {
  DatasetFormat format = DatasetFormat::Unknown;
  std::filesystem::path root;
  CameraIntrinsics intrinsics;
  std::string intrinsics_source;  // "camera-intrinsics.txt", "preset tum_freiburg1", ...
  double depth_scale = 1000.0;
  std::string ground_truth_source;  // file(s) the ground truth came from; empty when none
  std::size_t dropped_frames = 0;   // TUM: depth frames without a colour match in tolerance
  // TUM: listed frames after the last one whose depth image exists (a partial copy of a longer
  // recording), left out of `frames`.
  std::size_t absent_tail_frames = 0;
  // A raw value the dataset uses for "no measurement" besides 0 (7-Scenes: 65535). Loading
  // turns it into 0 so no kernel mistakes it for a 65 m reading.
  std::optional<std::uint16_t> invalid_depth_value;
  SequenceTraits traits;
  std::vector<FrameEntry> frames;  // frames with images, in capture order
  Trajectory ground_truth;         // every ground-truth pose the dataset has (may be more
                                   // poses than frames, e.g. 1000 poses for 374 7-Scenes frames)

  bool has_ground_truth() const { return !ground_truth.empty(); }
  // Reads and checks frame `i`: images exist and decode, depth is 16-bit, colour and depth
  // sizes agree with each other and the intrinsics. Throws InputError naming file and frame.
  RgbdFrame load_frame(std::size_t i) const;
  // Only the depth image of frame `i`, with the same checks and invalid-value handling.
  DepthImage load_depth(std::size_t i) const;
};

RgbdSequence open_rgbd_sequence(const std::filesystem::path& path,
                                const SequenceOptions& options = {});
RgbdSequence read_tum_sequence(const std::filesystem::path& folder,
                               const SequenceOptions& options = {});
RgbdSequence read_seven_scenes_sequence(const std::filesystem::path& folder,
                                        const SequenceOptions& options = {});
RgbdSequence read_redwood_sequence(const std::filesystem::path& folder,
                                   const SequenceOptions& options = {});

// Intrinsics files: Locard/our simulator's intrinsics.json ({"width","height","fx","fy","cx",
// "cy", optional "depth_scale", "name"}), Open3D's PinholeCameraIntrinsic JSON
// ({"width","height","intrinsic_matrix": column-major 3x3}) and a plain 3x3 K text file
// (7-Scenes camera-intrinsics.txt; width/height then come from the first image).
CameraIntrinsics read_intrinsics_json(const std::filesystem::path& path);
// As read_intrinsics_json, plus the depth scale when the file states one (Locard's format).
struct IntrinsicsFile {
  CameraIntrinsics intrinsics;
  std::optional<double> depth_scale;
};
IntrinsicsFile read_intrinsics_json_with_scale(const std::filesystem::path& path);
// A plain 3x3 K, row-major, whitespace-separated; the image size is given by the caller.
CameraIntrinsics read_intrinsics_matrix_txt(const std::filesystem::path& path, int width,
                                            int height);
void write_intrinsics_json(const std::filesystem::path& path, const CameraIntrinsics& intrinsics,
                           double depth_scale);

}  // namespace locard
