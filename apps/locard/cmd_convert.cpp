// `locard convert IN OUT`: cloud to cloud (PLY, PCD, E57; ascii/binary/compressed), an RGB-D
// sequence to one point cloud, each frame back-projected at its ground-truth pose, or a PLY
// mesh (a case's mesh/mesh.ply) to OBJ, GLB, glTF or FBX with the up axis chosen (--up).
#include "commands.hpp"

#include <locard/core/error.hpp>
#include <locard/core/progress.hpp>
#include <locard/io/mesh_export.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/point_cloud_io.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/preprocess/depth_to_points.hpp>

#include <algorithm>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <tbb/parallel_for.h>

namespace locard::cli {
namespace {

struct ConvertOptions {
  std::string input;
  std::string output;
  bool ascii = false;
  bool compressed = false;
  bool force = false;
  // sequence -> cloud
  int every = 1;
  int stride = 1;
  double min_depth = 0.1;
  double max_depth = 10.0;
  long first = 0;
  long count = -1;
  // mesh -> mesh
  std::string up = "y";  // parsed by parse_up_axis (CLI::IsMember checked it)
};

// OBJ, glTF and FBX outputs are meshes; PLY stays a cloud output (a mesh's PLY is its own).
bool is_mesh_export(const std::filesystem::path& path) {
  const auto format = mesh_format_from_path(path);
  return format && *format != MeshFormat::Ply;
}

int convert_mesh(const ConvertOptions& opt, bool quiet) {
  if (detect_format(opt.input) != DatasetFormat::PlyCloud)
    throw_input_error(opt.input, "a mesh export (.obj, .glb, .gltf, .fbx) needs a PLY mesh input");
  const TriangleMesh mesh = read_ply_mesh(opt.input);
  if (mesh.triangles.empty())
    throw_input_error(opt.input, "has no faces: not a mesh (write a cloud as .ply, .pcd or .e57)");
  MeshExportOptions options;
  options.up = parse_up_axis(opt.up).value_or(UpAxis::Y);
  std::vector<std::string> written;
  for (const auto& path : write_mesh(opt.output, mesh, options)) written.push_back(path.string());
  if (!quiet)
    fmt::print("wrote {} ({} vertices, {} triangles{}, {}-up)\n", fmt::join(written, ", "),
               mesh.vertex_count(), mesh.triangle_count(),
               mesh.vertex_colors.empty() ? "" : ", colours", opt.up);
  return 0;
}

PointCloud fuse_sequence(const ConvertOptions& opt, bool quiet) {
  const RgbdSequence seq = open_rgbd_sequence(opt.input);
  std::vector<std::size_t> picked;
  const long last = opt.count < 0 ? static_cast<long>(seq.frames.size())
                                  : std::min<long>(seq.frames.size(), opt.first + opt.count);
  for (long i = opt.first; i < last; i += opt.every) {
    if (!seq.frames[i].T_world_camera)
      throw_input_error(seq.frames[i].depth_path,
                        fmt::format("frame {} has no ground-truth pose; convert needs poses to "
                                    "merge frames (use `locard align` for unposed sequences)",
                                    seq.frames[i].frame_index));
    picked.push_back(static_cast<std::size_t>(i));
  }
  if (picked.empty()) throw_input_error(opt.input, "no frames selected");
  DepthToPointsOptions dopt;
  dopt.stride = opt.stride;
  dopt.min_depth_m = opt.min_depth;
  dopt.max_depth_m = opt.max_depth;
  std::vector<PointCloud> parts(picked.size());
  ProgressBar bar("back-projecting", picked.size(), ProgressBar::should_show(quiet));
  tbb::parallel_for(std::size_t{0}, picked.size(), [&](std::size_t j) {
    const RgbdFrame frame = seq.load_frame(picked[j]);
    parts[j] = depth_to_points(frame, dopt, *seq.frames[picked[j]].T_world_camera);
    bar.advance();
  });
  bar.finish();
  PointCloud merged;
  std::size_t total = 0;
  for (const auto& p : parts) total += p.size();
  merged.reserve(total, false, true);
  for (const auto& p : parts) merged.append(p);
  return merged;
}

// E57 data3D has no normals and one scalar (intensity): say what was left out.
void warn_e57_drops(const PointCloud& cloud) {
  std::vector<std::string> dropped;
  if (cloud.has_normals()) dropped.push_back("normals");
  for (const auto& s : cloud.scalars)
    if (s.name != "intensity") dropped.push_back("scalar field '" + s.name + "'");
  if (!dropped.empty())
    fmt::print(stderr, "convert: E57 keeps positions, colours and intensity; not written: {}\n",
               fmt::join(dropped, ", "));
}

}  // namespace

void register_convert(CLI::App& app, GlobalOptions& global) {
  auto opt = std::make_shared<ConvertOptions>();
  CLI::App* sub = app.add_subcommand(
      "convert",
      "Convert a point cloud between PLY, PCD and E57 (an E57's scans are merged into its "
      "frame; an E57 is written as one scan), or merge an RGB-D sequence with ground-truth "
      "poses into one coloured point cloud");
  sub->add_option("input", opt->input, "Input cloud (.ply, .pcd, .e57) or RGB-D sequence folder")
      ->required();
  sub->add_option("output", opt->output,
                  "Output cloud (.ply, .pcd or .e57), or mesh (.obj, .glb, .gltf, .fbx) from a "
                  "PLY mesh")
      ->required();
  sub->add_flag("--ascii", opt->ascii, "Write ascii instead of binary");
  sub->add_flag("--compressed", opt->compressed, "PCD: write binary_compressed (LZF)");
  sub->add_flag("--force", opt->force, "Overwrite an existing output file");
  sub->add_option("--every", opt->every, "Sequence input: use every N-th frame")
      ->check(CLI::PositiveNumber);
  sub->add_option("--first", opt->first, "Sequence input: first frame (index in the list)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--count", opt->count, "Sequence input: number of frames (default: all)");
  sub->add_option("--stride", opt->stride, "Sequence input: take every N-th pixel")
      ->check(CLI::PositiveNumber);
  sub->add_option("--min-depth", opt->min_depth, "Sequence input: nearest depth kept (m)");
  sub->add_option("--max-depth", opt->max_depth, "Sequence input: farthest depth kept (m)");
  sub->add_option("--up", opt->up,
                  "Mesh output: the axis that points up in OBJ and FBX (y: Blender, Unity; z: "
                  "CloudCompare, surveying tools); glTF is always y-up")
      ->check(CLI::IsMember({"y", "z"}))
      ->capture_default_str();
  set_runner(sub, [opt, &global]() {
    if (!is_point_cloud_file(opt->output) && !is_mesh_export(opt->output))
      throw_input_error(opt->output, "output must end in .ply, .pcd, .e57, .obj, .glb, .gltf or .fbx");
    if (std::filesystem::exists(opt->output) && !opt->force)
      throw_input_error(opt->output, "output exists; pass --force to overwrite it");
    if (!std::filesystem::exists(opt->input)) throw_input_error(opt->input, "no such file or folder");
    if (is_mesh_export(opt->output)) return convert_mesh(*opt, global.quiet);
    PointCloud cloud;
    const DatasetFormat format = detect_format(opt->input);
    if (format == DatasetFormat::PlyCloud || format == DatasetFormat::PcdCloud ||
        format == DatasetFormat::E57Cloud)
      cloud = read_point_cloud(opt->input);
    else if (format == DatasetFormat::Tum || format == DatasetFormat::SevenScenes ||
             format == DatasetFormat::Redwood)
      cloud = fuse_sequence(*opt, global.quiet);
    else
      throw_input_error(opt->input, "not a point cloud or RGB-D sequence Locard can read");
    const auto non_finite = std::count_if(cloud.positions.begin(), cloud.positions.end(),
                                          [](const Eigen::Vector3f& p) { return !p.allFinite(); });
    write_point_cloud(opt->output, cloud, {.ascii = opt->ascii, .compressed = opt->compressed});
    if (detect_format(opt->output) == DatasetFormat::E57Cloud) warn_e57_drops(cloud);
    if (non_finite)  // a warning even with --quiet: the output holds them too
      fmt::print(stderr, "convert: {} of {} points have NaN or infinite coordinates; written "
                         "as they are\n", non_finite, cloud.size());
    if (!global.quiet)
      fmt::print("wrote {} ({} points{}{})\n", opt->output, cloud.size(),
                 cloud.has_colors() ? ", colours" : "", cloud.has_normals() ? ", normals" : "");
    return 0;
  });
}

}  // namespace locard::cli
