// `locard mesh DIR -o OUT`: fuses an RGB-D sequence into a coloured mesh (TSDF + marching
// cubes), cleans it up, optionally fills small holes (flagged), and exports it with the
// registered point cloud beside it.
// --method delaunay|poisson: the paper's path for clouds without depth images. The input is an
// RGB-D sequence (back-projected at its poses and merged), a point-cloud file (PLY/PCD) or a
// folder of them (already in one frame, e.g. per-view clouds from `locard align`); the merged
// cloud is voxel-averaged, outliers removed, normals estimated, segmented by region growing
// ("segment" in cloud.ply), then triangulated (advancing front on the Delaunay
// triangulation, or Poisson trimmed by point density).
//
// Poses, first found: --trajectory FILE (TUM format, as `locard align` writes), a
// trajectory.txt in DIR, or the sequence's ground truth. Exit status 2 on bad input.
#include "commands.hpp"

#include <locard/alignment/alignment_defaults.hpp>
#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/core/progress.hpp>
#include <locard/io/mesh_export.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/point_cloud_io.hpp>
#include <locard/preprocess/depth_to_points.hpp>
#include <locard/preprocess/voxel_grid.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/io/trajectory_io.hpp>
#include <locard/surface/fusion.hpp>
#include <locard/surface/mesh_cleanup.hpp>
#include <locard/surface/point_cloud_meshing.hpp>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <map>
#include <sstream>

namespace locard::cli {
namespace {

namespace fs = std::filesystem;

struct MeshOptions {
  std::string input;
  std::string output;
  std::string trajectory;
  std::string method = "tsdf";
  double voxel = 0.01;
  double truncation = 0.0;  // 0: 4 voxels
  std::optional<double> max_depth;  // unset: from the sequence's depth sensor (alignment_defaults)
  double min_depth = 0.1;
  std::size_t step = 1;
  std::size_t max_frames = 0;
  std::size_t min_component = 500;
  std::size_t fill_holes = 0;
  std::size_t target_triangles = 0;
  std::string formats = "ply,obj,glb,fbx";
  std::string up = "y";  // OBJ and FBX; parsed by parse_up_axis (CLI::IsMember checked it)
  bool show_inferred = false;
  bool no_cloud = false;
  bool force = false;
};

std::vector<MeshFormat> parse_formats(const std::string& list) {
  std::vector<MeshFormat> out;
  std::stringstream in(list);
  std::string name;
  while (std::getline(in, name, ',')) {
    const auto f = parse_mesh_format(name);
    if (!f)
      throw InputError(fmt::format("--format: unknown format '{}' (ply, obj, glb, gltf, fbx)",
                                   name));
    out.push_back(*f);
  }
  if (out.empty()) throw InputError("--format: at least one format is needed");
  return out;
}

struct SequencePoses {
  std::vector<std::optional<Isometry3d>> poses;
  std::string source;
};

SequencePoses load_poses(const MeshOptions& o, const RgbdSequence& sequence) {
  std::string pose_source;
  std::vector<std::optional<Isometry3d>> poses;
  fs::path trajectory = o.trajectory;
  if (trajectory.empty() && fs::exists(fs::path(o.input) / "trajectory.txt"))
    trajectory = fs::path(o.input) / "trajectory.txt";
  if (!trajectory.empty()) {
    if (fs::is_directory(trajectory)) trajectory /= "trajectory.txt";
    poses = match_poses(sequence, read_tum_trajectory(trajectory));
    pose_source = trajectory.string();
  } else if (sequence.has_ground_truth()) {
    poses = ground_truth_poses(sequence);
    pose_source = "ground truth (" + sequence.ground_truth_source + ")";
  } else {
    throw_input_error(o.input, "the sequence has no ground-truth poses; pass --trajectory "
                               "FILE (TUM format, e.g. from `locard align`)");
  }
  return {std::move(poses), std::move(pose_source)};
}

void write_meshes(const MeshOptions& o, const std::vector<MeshFormat>& formats,
                  const TriangleMesh& mesh, MeshExportOptions export_options,
                  std::vector<std::string>& written) {
  fs::create_directories(o.output);
  export_options.up = parse_up_axis(o.up).value_or(UpAxis::Y);
  for (MeshFormat f : formats) {
    const fs::path path = fs::path(o.output) / fmt::format("mesh.{}", to_string(f));
    for (const fs::path& file : write_mesh(path, mesh, export_options))  // OBJ: + .mtl, .png
      written.push_back(file.filename().string());
  }
}

// The merged cloud of a point-cloud file, a folder of them, or an RGB-D sequence at its poses;
// `viewpoint` is the mean camera centre (sequence) or the cloud's centroid.
PointCloud merged_cloud(const MeshOptions& o, const GlobalOptions& global, std::string& source,
                        Eigen::Vector3f& viewpoint) {
  const float voxel = static_cast<float>(o.voxel);
  PointCloud cloud;
  std::vector<fs::path> files;
  if (fs::is_regular_file(o.input)) {
    files.push_back(o.input);
  } else if (const DatasetFormat f = detect_format(o.input);
             f == DatasetFormat::Unknown || f == DatasetFormat::RangeScanFolder) {
    for (const auto& entry : fs::directory_iterator(o.input))
      if (entry.is_regular_file() && is_point_cloud_file(entry.path()))
        files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    if (files.empty())
      throw_input_error(o.input, "neither an RGB-D sequence nor a folder of point clouds "
                                 "(.ply, .pcd)");
  }
  if (!files.empty()) {
    for (const fs::path& f : files) {
      cloud.append(read_point_cloud(f));
      cloud = voxel_down_sample(cloud, voxel).cloud;
    }
    source = files.size() == 1 ? files[0].string()
                               : fmt::format("{} point clouds in {}", files.size(), o.input);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3f& p : cloud.positions) sum += p.cast<double>();
    viewpoint = (sum / std::max<double>(1.0, static_cast<double>(cloud.size()))).cast<float>();
    cloud.normals.clear();
    return cloud;
  }
  const RgbdSequence sequence = open_rgbd_sequence(o.input);
  if (sequence.frames.empty()) throw_input_error(o.input, "the sequence has no frames");
  const SequencePoses poses = load_poses(o, sequence);
  DepthToPointsOptions points;
  points.min_depth_m = std::max(o.min_depth, 0.001);
  points.max_depth_m = o.max_depth.value_or(default_max_depth_m(sequence.traits.sensor));
  Eigen::Vector3d centres = Eigen::Vector3d::Zero();
  std::size_t used = 0;
  ProgressBar bar("mesh", sequence.frames.size(), ProgressBar::should_show(global.quiet));
  for (std::size_t i = 0; i < sequence.frames.size(); i += o.step) {
    if (o.max_frames && used >= o.max_frames) break;
    if (!poses.poses[i]) continue;
    cloud.append(depth_to_points(sequence.load_frame(i), points, *poses.poses[i]));
    centres += poses.poses[i]->translation();
    if (++used % 8 == 0) cloud = voxel_down_sample(cloud, voxel).cloud;
    bar.callback()(i + 1, sequence.frames.size());
  }
  bar.finish();
  if (used == 0) throw_input_error(o.input, "no frame has a pose");
  cloud = voxel_down_sample(cloud, voxel).cloud;
  cloud.normals.clear();
  viewpoint = (centres / static_cast<double>(used)).cast<float>();
  source = fmt::format("{} frames of {} ({})", used, o.input, poses.source);
  return cloud;
}

int run_cloud_mesh(const MeshOptions& o, const GlobalOptions& global,
                   const std::vector<MeshFormat>& formats,
                   std::chrono::steady_clock::time_point start) {
  std::string source;
  CloudMeshingOptions options;
  const PointCloud merged = merged_cloud(o, global, source, options.viewpoint);
  options.method = o.method == "poisson" ? CloudSurfaceMethod::Poisson : CloudSurfaceMethod::Delaunay;
  // Neighbourhoods scale with the sampling: about 3 voxels for normals and segments.
  options.normal_radius = std::max(0.05f, static_cast<float>(3.0 * o.voxel));
  options.segmentation.radius = options.normal_radius;
  CloudMeshingResult r;
  try {
    r = mesh_point_cloud(merged, options);
  } catch (const InputError& e) {
    throw_input_error(o.input, e.what());  // the input's geometry cannot be meshed this way
  }
  TriangleMesh& mesh = r.mesh;
  const std::size_t raw_triangles = mesh.triangle_count();
  const ComponentReport components = remove_small_components(mesh, o.min_component);
  std::vector<std::string> written;
  write_meshes(o, formats, mesh, {}, written);
  if (!o.no_cloud) {
    write_ply(fs::path(o.output) / "cloud.ply", r.cloud);
    written.push_back("cloud.ply");
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  nlohmann::json report = {{"input", o.input},
                           {"source", source},
                           {"method", o.method},
                           {"voxel_size", o.voxel},
                           {"viewpoint", {options.viewpoint.x(), options.viewpoint.y(),
                                          options.viewpoint.z()}},
                           {"merged_points", merged.size()},
                           {"outliers_removed", r.outliers.rejected},
                           {"points", r.cloud.size()},
                           {"segments", r.segmentation.sizes.size()},
                           {"segment_sizes", r.segmentation.sizes},
                           {"raw_triangles", raw_triangles},
                           {"removed_components", components.removed_components},
                           {"removed_triangles", components.removed_triangles},
                           {"vertices", mesh.vertex_count()},
                           {"triangles", mesh.triangle_count()},
                           {"files", written},
                           {"seconds", seconds}};
  {
    AtomicFile file(fs::path(o.output) / "mesh.json", false);
    file.stream() << report.dump(2) << "\n";
    file.commit();
  }
  if (!global.quiet) {
    fmt::print("mesh: {} points from {} ({} outliers removed), {} segments\n", r.cloud.size(),
               source, r.outliers.rejected, r.segmentation.sizes.size());
    fmt::print("mesh ({}): {} vertices, {} triangles ({} small components with {} triangles "
               "removed)\n",
               o.method, mesh.vertex_count(), mesh.triangle_count(),
               components.removed_components, components.removed_triangles);
    fmt::print("mesh: wrote {} in {} ({:.1f} s)\n", fmt::join(written, ", "), o.output, seconds);
  }
  return 0;
}

int run_mesh(const MeshOptions& o, const GlobalOptions& global) {
  const auto start = std::chrono::steady_clock::now();
  if (o.method != "tsdf" && o.method != "delaunay" && o.method != "poisson")
    throw InputError(fmt::format("--method {}: expected tsdf, delaunay or poisson", o.method));
  const std::vector<MeshFormat> formats = parse_formats(o.formats);
  if (!fs::exists(o.input)) throw_input_error(o.input, "no such file or folder");
  if (fs::exists(o.output) && !fs::is_directory(o.output))
    throw_input_error(o.output, "exists and is not a folder");
  if (fs::is_directory(o.output) && !fs::is_empty(o.output) && !o.force)
    throw_input_error(o.output, "folder is not empty; pass --force to write into it");
  if (o.method != "tsdf") return run_cloud_mesh(o, global, formats, start);

  const RgbdSequence sequence = open_rgbd_sequence(o.input);
  if (sequence.frames.empty()) throw_input_error(o.input, "the sequence has no frames");
  const SequencePoses sequence_poses = load_poses(o, sequence);
  const auto& poses = sequence_poses.poses;
  const std::string& pose_source = sequence_poses.source;

  FusionOptions fusion;
  fusion.tsdf.voxel_size = o.voxel;
  fusion.tsdf.truncation = o.truncation > 0.0 ? o.truncation : 4.0 * o.voxel;
  fusion.tsdf.max_depth_m = o.max_depth.value_or(default_max_depth_m(sequence.traits.sensor));
  fusion.tsdf.min_depth_m = o.min_depth;
  fusion.frame_step = o.step;
  fusion.max_frames = o.max_frames;
  fusion.cloud_voxel = o.no_cloud ? 0.0 : o.voxel / 2.0;
  ProgressBar bar("mesh", sequence.frames.size(), ProgressBar::should_show(global.quiet));
  fusion.progress = bar.callback();
  FusionResult fused = fuse_sequence(sequence, poses, fusion);
  bar.finish();

  TriangleMesh& mesh = fused.mesh;
  const std::size_t raw_triangles = mesh.triangle_count();
  const ComponentReport components = remove_small_components(mesh, o.min_component);
  DecimationReport decimation{mesh.triangle_count(), mesh.triangle_count()};
  if (o.target_triangles > 0) decimation = decimate(mesh, o.target_triangles);
  MeshExportOptions export_options;
  HoleFillReport holes;
  if (o.fill_holes > 0) {
    holes = fill_holes(mesh, o.fill_holes);
    export_options.inferred_triangles = holes.inferred_triangles;
    export_options.show_inferred = o.show_inferred;
  }

  std::vector<std::string> written;
  write_meshes(o, formats, mesh, export_options, written);
  if (!fused.cloud.empty()) {
    write_ply(fs::path(o.output) / "cloud.ply", fused.cloud);
    written.push_back("cloud.ply");
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  nlohmann::json report = {
      {"input", o.input},
      {"format", std::string(to_string(sequence.format))},
      {"poses", pose_source},
      {"method", o.method},
      {"voxel_size", fusion.tsdf.voxel_size},
      {"truncation", fusion.tsdf.truncation},
      {"depth_range", {fusion.tsdf.min_depth_m, fusion.tsdf.max_depth_m}},
      {"frames_fused", fused.frames_fused},
      {"frames_without_pose", fused.frames_without_pose},
      {"blocks", fused.stats.blocks},
      {"volume_bytes", fused.stats.memory_bytes},
      {"raw_triangles", raw_triangles},
      {"components", components.components},
      {"removed_components", components.removed_components},
      {"removed_triangles", components.removed_triangles},
      {"decimated_to", decimation.triangles_after},
      {"filled_holes", holes.filled_loops},
      {"inferred_triangles", holes.added_triangles},
      {"vertices", mesh.vertex_count()},
      {"triangles", mesh.triangle_count()},
      {"cloud_points", fused.cloud.size()},
      {"files", written},
      {"seconds", seconds}};
  {
    AtomicFile file(fs::path(o.output) / "mesh.json", false);
    file.stream() << report.dump(2) << "\n";
    file.commit();
  }
  if (!global.quiet) {
    fmt::print("mesh: fused {} frames of {} ({}) at voxel {:.4g} m, truncation {:.4g} m\n",
               fused.frames_fused, o.input, pose_source, fusion.tsdf.voxel_size,
               fusion.tsdf.truncation);
    fmt::print("mesh: {} vertices, {} triangles ({} small components with {} triangles "
               "removed{}{})\n",
               mesh.vertex_count(), mesh.triangle_count(), components.removed_components,
               components.removed_triangles,
               o.target_triangles ? fmt::format(", decimated from {}", decimation.triangles_before)
                                  : std::string(),
               o.fill_holes ? fmt::format(", {} holes filled with {} inferred triangles",
                                          holes.filled_loops, holes.added_triangles)
                            : std::string());
    fmt::print("mesh: wrote {} in {} ({:.1f} s)\n", fmt::join(written, ", "), o.output, seconds);
  }
  return 0;
}

}  // namespace

void register_mesh(CLI::App& app, GlobalOptions& global) {
  auto opt = std::make_shared<MeshOptions>();
  CLI::App* sub = app.add_subcommand(
      "mesh", "Fuse an RGB-D sequence into a coloured mesh (TSDF + marching cubes; or mesh a "
              "merged point cloud: --method delaunay|poisson) and export it as PLY, OBJ, GLB "
              "and FBX with the registered point cloud beside it");
  sub->add_option("input", opt->input,
                  "RGB-D sequence folder (TUM, 7-Scenes, Redwood, `locard scan-sim` output); "
                  "for delaunay/poisson also a point cloud (.ply, .pcd) or a folder of them")
      ->required();
  sub->add_option("-o,--output", opt->output, "Output folder")->required();
  sub->add_option("--trajectory", opt->trajectory,
                  "Camera poses, TUM format (T_world_camera per timestamp), or a folder with "
                  "trajectory.txt (the output of `locard align`); default: DIR/trajectory.txt, "
                  "else the sequence's ground truth");
  sub->add_option("--method", opt->method,
                  "Surface method: tsdf (RGB-D), delaunay (advancing front on the merged "
                  "cloud), poisson (CGAL Poisson, trimmed by point density); --voxel is the "
                  "cloud's sampling for the last two")
      ->check(CLI::IsMember({"tsdf", "delaunay", "poisson"}))
      ->capture_default_str();
  sub->add_option("--voxel", opt->voxel, "Voxel size in metres")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  sub->add_option("--truncation", opt->truncation, "Truncation in metres (default 4 voxels)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--max-depth", opt->max_depth,
                  "Ignore depth beyond this (m); default: from the data (structured light 3, "
                  "time of flight 4.5, synthetic 8)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--min-depth", opt->min_depth, "Ignore depth closer than this (m)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  sub->add_option("--step", opt->step, "Fuse every n-th frame")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  sub->add_option("--max-frames", opt->max_frames, "Fuse at most this many frames (0: all)");
  sub->add_option("--min-component", opt->min_component,
                  "Drop connected pieces with fewer triangles")
      ->capture_default_str();
  sub->add_option("--fill-holes", opt->fill_holes,
                  "Fill holes whose rim has at most this many edges (0: none); filled "
                  "triangles are flagged as inferred in every export");
  sub->add_flag("--show-inferred", opt->show_inferred,
                "Colour inferred (filled) triangles magenta in the exports");
  sub->add_option("--target-triangles", opt->target_triangles,
                  "Decimate to about this many triangles (0: keep all)");
  sub->add_option("--format", opt->formats, "Comma-separated: ply, obj, glb, gltf, fbx")
      ->capture_default_str();
  sub->add_option("--up", opt->up,
                  "The axis that points up in OBJ and FBX (y: Blender, Unity; z: CloudCompare, "
                  "surveying tools); glTF is always y-up, PLY keeps Locard's z-up frame")
      ->check(CLI::IsMember({"y", "z"}))
      ->capture_default_str();
  sub->add_flag("--no-cloud", opt->no_cloud, "Do not write the registered point cloud");
  sub->add_flag("--force", opt->force, "Write into a non-empty output folder");
  set_runner(sub, [opt, &global]() { return run_mesh(*opt, global); });
}

}  // namespace locard::cli
