#pragma once
// `locard reconstruct INPUT -o CASE_DIR`: the whole pipeline in one call, into a case folder
// (docs/case-format.md):
//   ingest     hash every input file (sequence images, index files, intrinsics, ground truth)
//   align      sequential registration + loop closure + pose graph (sequential_alignment.hpp);
//              for range scans, multiway registration (scan_alignment.hpp) and a screened
//              Poisson surface trimmed by point density (docs/laser-scans.md)
//              -> alignment/trajectory.txt, pose_graph.json, pose_covariance.json,
//                 stage_report.json/.svg
//   mesh       TSDF fusion at the final poses, small pieces removed -> mesh/mesh.{ply,glb,obj,
//              fbx}, mesh.json; the registered cloud -> cloud/registered.ply
//   export e57 the registered views, one E57 scan each with its pose -> cloud/registered.e57
//   measure    the reference file (INPUT/measurements.json when the scan has one, or
//              --reference) -> measurements/table.json, table.csv
//   report     rendered views, plots and tables -> report/report.html (+ report.pdf)
// Each stage appends one line to log.jsonl and rewrites manifest.json. case.json records what,
// when, the inputs with their hashes, every parameter, the software version and the seeds.
//
// World frame: the first registered view's camera frame, unless that view has a ground-truth
// pose (a simulated scan, a surveyed start position): then the whole model is moved rigidly so
// that this one view sits at its known pose (the gauge of the pose graph; the other poses stay
// estimated), giving the scene's z-up frame.

#include <locard/alignment/sequential_alignment.hpp>
#include <locard/core/progress.hpp>
#include <locard/forensics/report.hpp>
#include <locard/io/mesh_export.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/registration/icp.hpp>
#include <locard/surface/tsdf_volume.hpp>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace locard::forensics {

// Where the registration of range scans starts.
enum class ScanPoseSource { Input, Global };
std::string_view to_string(ScanPoseSource source);  // "input", "global"
std::optional<ScanPoseSource> parse_scan_pose_source(std::string_view name);

// The case's world frame: the first view's ground-truth pose where the data has one, or the
// first camera's frame regardless.
enum class WorldFrameChoice { Auto, FirstCamera };
std::string_view to_string(WorldFrameChoice choice);  // "auto", "first-camera"
std::optional<WorldFrameChoice> parse_world_frame_choice(std::string_view name);

// "ply,glb,obj,fbx" and back (InputError naming an unknown format).
std::string mesh_formats_text(const std::vector<MeshFormat>& formats);
std::vector<MeshFormat> parse_mesh_formats(std::string_view text);

struct ReconstructParameters {
  // Alignment: the options `locard align` takes (AlignmentOptions{}'s values; defaults_for()
  // sets the data's: mode, odometry ICP, depth range, ring sizes). Its depth range is the
  // case's: fusion and coverage use it too. case.json's "parameters" and a --config file
  // hold these of its fields: mode, odometry_icp (odometry_method; never point-to-point),
  // align_voxel_m (voxel_size), stride, min/max_depth_m, first_frame, max_frames,
  // loop_closure, loop_max_angle_deg, loop_max_distance_m, loop_min_fitness, seed.
  AlignmentOptions alignment;
  // Range scans (a .conf, a folder of scans, an E57 of several; docs/laser-scans.md):
  // Input: start from the poses the input gives (feature registration for scans without
  // one); Global: ignore them, feature registration for every pair.
  ScanPoseSource scan_poses = ScanPoseSource::Input;
  double scan_voxel_m = 0.0;  // surface sampling; 0: twice the scans' median point spacing
  // Surface: TSDF fusion (TsdfOptions{}'s voxel; recorded as mesh_voxel_m and truncation_m).
  // A truncation of 0 means 4 voxels; the depth range is the alignment's.
  TsdfOptions fusion = {.voxel_size = TsdfOptions{}.voxel_size, .truncation = 0.0};
  std::size_t min_component = 500;
  std::vector<MeshFormat> formats = {MeshFormat::Ply, MeshFormat::Glb, MeshFormat::Obj,
                                     MeshFormat::Fbx};  // JSON: "ply,glb,obj,fbx"
  UpAxis up = UpAxis::Y;  // the up axis of the OBJ and FBX exports (mesh_export.hpp)
  double cloud_voxel_m = 0.005;
  // Gauge: Auto (ground truth of the first view when known), FirstCamera
  WorldFrameChoice world_frame = WorldFrameChoice::Auto;
  // Measurements
  std::filesystem::path reference;  // empty: INPUT/measurements.json when present
  double snap_radius_m = 0.03;
  // Report
  bool pdf = true;
  int render_width = 640;
  int render_height = 400;
  PaperSize paper = PaperSize::A4;  // the PDF's page
  std::string title;  // default: "Case <folder name>"

  // Every field as a JSON object (text) and back, enums by their names ("cumulative",
  // "point-to-plane", "ply,glb", ...); unknown keys, wrong types and unknown names in a
  // --config file are an InputError naming the key and the file.
  std::string to_json() const;
  static ReconstructParameters from_json_file(const std::filesystem::path& path,
                                              const ReconstructParameters& defaults);
  // Defaults for what the data is (alignment_defaults.hpp, docs/sensors.md): the alignment
  // options are default_alignment_options(traits); the rest as above.
  static ReconstructParameters defaults_for(const SequenceTraits& traits);
};

struct StageCallbacks {
  // Called at the start of each stage with its name and work count; returns the progress
  // callback for it (may be empty).
  std::function<ProgressCallback(const std::string& stage, std::size_t total)> begin;
  std::function<void(const std::string& stage)> end;
  std::function<void(const std::string& message)> log;  // human-readable notes, warnings
};

struct ReconstructSummary {
  std::filesystem::path case_dir;
  std::filesystem::path report_html;
  std::optional<std::filesystem::path> report_pdf;
  std::size_t frames = 0;
  std::size_t registered = 0;
  std::size_t usable = 0;     // frames with enough depth to register
  std::size_t verified = 0;   // registered and passed the self-check (the frames fused)
  std::vector<std::int64_t> flagged;  // registered, failed the self-check, left out
  bool enough_verified = true;  // verified >= min_verified_share of usable
  std::size_t vertices = 0;
  std::size_t triangles = 0;
  std::size_t measurements = 0;
  std::size_t measurements_within = 0;
  std::size_t measurements_not_measured = 0;  // reference points the model does not cover
  std::size_t measurements_not_snapped = 0;   // rows with an end no feature fixed (see SnapFeature)
  // The floor the scan observed (floor_coverage.hpp): share of the floor seen, and what to do
  // about the rest; empty when the case has no floor plane to judge.
  std::optional<double> floor_seen_share;
  std::vector<std::string> coverage_advice;
  double seconds = 0.0;
  std::vector<std::pair<std::string, double>> stage_seconds;
};

// Throws InputError for a bad input (exit 2 in the CLI) before anything is written; a case
// folder that is not empty is refused unless `force`.
ReconstructSummary reconstruct_case(const std::filesystem::path& input,
                                    const std::filesystem::path& case_dir,
                                    const ReconstructParameters& parameters, bool force,
                                    const StageCallbacks& callbacks = {});

}  // namespace locard::forensics
