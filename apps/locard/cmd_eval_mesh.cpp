// `locard eval-mesh GT.ply MESH.ply`: accuracy (mesh vertices to the ground-truth surface) and
// completeness (ground-truth surface within a threshold of the mesh). When the ground truth
// sits in a scan folder with poses (as `locard scan-sim` writes it), or --views names one,
// completeness counts only the surface the scanner saw.
#include "commands.hpp"

#include <locard/core/error.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/surface/mesh_evaluation.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>

namespace locard::cli {
namespace {

namespace fs = std::filesystem;

struct EvalMeshOptions {
  std::string ground_truth;
  std::string mesh;
  std::string views;
  std::string samples;
  bool all_surface = false;
  double threshold = 0.02;
  double spacing = 0.01;
  std::size_t view_step = 1;
  std::uint64_t seed = 1;
  bool json = false;
};

TriangleMesh read_mesh_file(const std::string& path, const char* which) {
  if (!fs::exists(path)) throw_input_error(path, "no such file");
  TriangleMesh mesh = read_ply_mesh(path);
  if (mesh.triangles.empty())
    throw_input_error(path, fmt::format("the {} has no triangles", which));
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
    if (!mesh.vertices[i].allFinite())
      throw_input_error(path, fmt::format("vertex {} of the {} is not a finite number ({}, {}, {})",
                                          i, which, mesh.vertices[i].x(), mesh.vertices[i].y(),
                                          mesh.vertices[i].z()));
  return mesh;
}

int run_eval_mesh(const EvalMeshOptions& o) {
  const TriangleMesh gt = read_mesh_file(o.ground_truth, "ground-truth mesh");
  const TriangleMesh mesh = read_mesh_file(o.mesh, "mesh");
  MeshEvaluationOptions options;
  options.completeness_threshold = o.threshold;
  options.sample_spacing = o.spacing;
  options.seed = o.seed;
  options.keep_samples = !o.samples.empty();
  fs::path views = o.views;
  if (views.empty() && !o.all_surface) {
    const fs::path folder = fs::path(o.ground_truth).parent_path();
    const DatasetFormat f = detect_format(folder.empty() ? fs::path(".") : folder);
    if (f == DatasetFormat::Tum || f == DatasetFormat::SevenScenes || f == DatasetFormat::Redwood)
      views = folder.empty() ? fs::path(".") : folder;
  }
  std::string counted = "the whole ground-truth surface";
  if (!views.empty() && !o.all_surface) {
    const RgbdSequence seq = open_rgbd_sequence(views);
    for (std::size_t i = 0; i < seq.frames.size(); i += std::max<std::size_t>(1, o.view_step)) {
      if (!seq.frames[i].T_world_camera) continue;
      EvaluationView view;
      view.depth = seq.load_depth(i);
      view.depth_scale = seq.depth_scale;
      view.intrinsics = seq.intrinsics;
      view.T_world_camera = *seq.frames[i].T_world_camera;
      options.views.push_back(std::move(view));
    }
    if (options.views.empty()) throw_input_error(views, "no frame with a ground-truth pose");
    counted = fmt::format("the surface seen by {} views of {}", options.views.size(),
                          views.string());
  }
  const MeshEvaluation r = [&] {
    try {
      return evaluate_mesh(gt, mesh, options);
    } catch (const InputError& e) {  // what the ground truth asks for (its sampling budget)
      throw_input_error(o.ground_truth, e.what());
    }
  }();
  if (!o.samples.empty()) write_ply(o.samples, r.samples);
  if (o.json) {
    std::printf("%s\n", nlohmann::json{{"ground_truth", o.ground_truth},
                                       {"mesh", o.mesh},
                                       {"mesh_vertices", r.mesh_vertices},
                                       {"accuracy_mean", r.accuracy_mean},
                                       {"accuracy_median", r.accuracy_median},
                                       {"accuracy_p90", r.accuracy_p90},
                                       {"accuracy_max", r.accuracy_max},
                                       {"completeness", r.completeness},
                                       {"completeness_threshold", o.threshold},
                                       {"completeness_mean_distance",
                                        r.completeness_mean_distance},
                                       {"gt_samples", r.gt_samples},
                                       {"counted_samples", r.counted_samples},
                                       {"counted", counted},
                                       {"seed", o.seed}}
                            .dump(2)
                            .c_str());
    return 0;
  }
  fmt::print("accuracy:     mean {:.2f} mm, median {:.2f} mm, 90% {:.2f} mm, max {:.2f} mm "
             "({} mesh vertices to the ground-truth surface)\n",
             1e3 * r.accuracy_mean, 1e3 * r.accuracy_median, 1e3 * r.accuracy_p90,
             1e3 * r.accuracy_max, r.mesh_vertices);
  fmt::print("completeness: {:.2f}% of the ground truth within {:.1f} mm of the mesh (mean "
             "distance {:.2f} mm; {} of {} samples counted: {})\n",
             100.0 * r.completeness, 1e3 * o.threshold, 1e3 * r.completeness_mean_distance,
             r.counted_samples, r.gt_samples, counted);
  return 0;
}

}  // namespace

void register_eval_mesh(CLI::App& app, GlobalOptions& /*global*/) {
  auto opt = std::make_shared<EvalMeshOptions>();
  CLI::App* sub = app.add_subcommand(
      "eval-mesh", "Compare a mesh with a ground-truth mesh: accuracy (mean distance of the "
                   "mesh's vertices to the ground truth) and completeness (share of the ground "
                   "truth within a threshold of the mesh)");
  sub->add_option("ground_truth", opt->ground_truth, "Ground-truth mesh (.ply)")->required();
  sub->add_option("mesh", opt->mesh, "Reconstructed mesh (.ply)")->required();
  sub->add_option("--views", opt->views,
                  "RGB-D folder with poses whose depth decides which ground truth was visible "
                  "(default: the ground truth's folder when it is one)");
  sub->add_flag("--all-surface", opt->all_surface,
                "Count the whole ground-truth surface for completeness");
  sub->add_option("--threshold", opt->threshold, "Completeness distance in metres")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  sub->add_option("--spacing", opt->spacing, "Ground-truth sample spacing in metres")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  sub->add_option("--view-step", opt->view_step, "Use every n-th view for visibility")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  sub->add_option("--seed", opt->seed, "Sampling seed")->capture_default_str();
  sub->add_option("--samples", opt->samples,
                  "Write the counted ground-truth samples as a PLY cloud with their distance "
                  "to the mesh and the number of views that saw them (where the mesh misses)");
  sub->add_flag("--json", opt->json, "Print machine-readable JSON");
  set_runner(sub, [opt]() { return run_eval_mesh(*opt); });
}

}  // namespace locard::cli
