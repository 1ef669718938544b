// `locard register SOURCE TARGET`: pairwise registration of two point clouds. Prints the 4x4
// T_target_source (maps source points into the target frame), its fitness and inlier RMSE,
// and can write the source cloud moved into the target frame.
//
// Pipeline: an initial estimate (feature-based global alignment, the identity, or a matrix
// file), then ICP coarse to fine over three scales derived from the final correspondence
// distance d: (voxel 2d, gate 4d), (voxel d, gate 2d), (full resolution, gate d).
// Exit status: 0 registered, 2 bad input, 3 the registration failed (the result, with its
// fitness and the reason, is still printed; no output file is written).
#include "commands.hpp"

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/io/point_cloud_io.hpp>
#include <locard/registration/global_registration.hpp>
#include <locard/registration/icp.hpp>
#include <locard/io/matrix_json.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

namespace locard::cli {
namespace {

struct RegisterOptions {
  std::string source;
  std::string target;
  std::string init = "global";
  std::string method = "point-to-plane";
  double voxel = 0.0;         // 0: automatic
  double max_distance = 0.0;  // 0: voxel / 2
  int levels = 3;
  int max_iterations = 30;
  std::string kernel = "none";
  double kernel_scale = 0.0;  // 0: the final correspondence distance
  double min_fitness = 0.1;
  std::uint64_t seed = 0;
  std::string output;
  std::string transform_out;
  bool ascii = false;
  bool force = false;
  bool json = false;
};

// A 4x4 (or 3x4) rigid transform as whitespace-separated numbers, row by row; '#' starts a
// comment. The rotation must be orthonormal to 1e-4 (a court-facing tool refuses to guess).
Isometry3d read_matrix_file(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw_input_error(path, "cannot open the initial transform file");
  std::vector<double> values;
  std::string line;
  long line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    line = line.substr(0, line.find('#'));
    std::istringstream fields(line);
    std::string field;
    while (fields >> field) {
      char* end = nullptr;
      const double v = std::strtod(field.c_str(), &end);
      if (end == field.c_str() || *end != '\0' || !std::isfinite(v))
        throw_input_error(path, fmt::format("'{}' is not a finite number", field), line_no);
      values.push_back(v);
    }
  }
  if (values.size() != 16 && values.size() != 12)
    throw_input_error(path, fmt::format("expected a 4x4 or 3x4 matrix (16 or 12 numbers, row "
                                        "by row), found {} numbers",
                                        values.size()));
  Isometry3d T = Isometry3d::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) T.matrix()(r, c) = values[4 * r + c];
  if (values.size() == 16) {
    const Eigen::RowVector4d last(values[12], values[13], values[14], values[15]);
    if ((last - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-9)
      throw_input_error(path, fmt::format("the last row must be 0 0 0 1, found {} {} {} {}",
                                          last(0), last(1), last(2), last(3)));
  }
  const Eigen::Matrix3d R = T.linear();
  const double err = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (err > 1e-4 || R.determinant() < 0.0)
    throw_input_error(path, fmt::format("the 3x3 block is not a rotation (|R^T R - I| = {:.2g}, "
                                        "det = {:.6f}); a rigid transform is expected",
                                        err, R.determinant()));
  return T;
}

std::string matrix_text(const Isometry3d& T, const char* indent) {
  std::string out;
  for (int r = 0; r < 4; ++r)
    out += fmt::format("{}{: .9f} {: .9f} {: .9f} {: .9f}\n", indent, T.matrix()(r, 0),
                       T.matrix()(r, 1), T.matrix()(r, 2), T.matrix()(r, 3));
  return out;
}

// Largest extent of the finite points' bounding box (0 when there are none).
double extent(const PointCloud& cloud) {
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
  Eigen::Vector3f hi = -lo;
  for (const auto& p : cloud.positions)
    if (p.allFinite()) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  return hi.x() >= lo.x() ? static_cast<double>((hi - lo).maxCoeff()) : 0.0;
}

PointCloud read_cloud(const std::string& path, const char* which) {
  if (!std::filesystem::exists(path)) throw_input_error(path, "no such file");
  if (!is_point_cloud_file(path))
    throw_input_error(path, fmt::format("the {} must be a .ply, .pcd or .e57 point cloud", which));
  PointCloud cloud = read_point_cloud(path);
  if (cloud.empty()) throw_input_error(path, fmt::format("the {} cloud has no points", which));
  return cloud;
}

// The registration's result: JSON (--json) or text for a person.
void print_registration(const RegisterOptions& opt, const IcpResult& result,
                        RobustKernelType kernel, double kernel_scale, double distance,
                        const nlohmann::json& init_json, const std::string& init_text) {
  if (opt.json) {
    nlohmann::json levels = nlohmann::json::array();
    for (const IcpLevelReport& l : result.levels)
      levels.push_back({{"voxel_size", l.voxel_size},
                        {"max_correspondence_distance", l.max_correspondence_distance},
                        {"source_points", l.source_points},
                        {"target_points", l.target_points},
                        {"iterations", l.iterations},
                        {"converged", l.converged},
                        {"fitness", l.fitness},
                        {"inlier_rmse", l.inlier_rmse}});
    nlohmann::json j = {{"source", opt.source},
                        {"target", opt.target},
                        {"success", result.success},
                        {"reason", result.reason},
                        {"T_target_source", matrix_json(result.T_target_source.matrix())},
                        {"fitness", result.fitness},
                        {"inlier_rmse", result.inlier_rmse},
                        {"correspondences", result.correspondences},
                        {"max_correspondence_distance", distance},
                        {"iterations", result.iterations},
                        {"converged", result.converged},
                        {"method", std::string(to_string(result.method))},
                        {"kernel", std::string(to_string(kernel))},
                        {"target_normals_estimated", result.target_normals_estimated},
                        {"source_non_finite", result.source_non_finite},
                        {"target_non_finite", result.target_non_finite},
                        {"information", matrix_json(result.information)},
                        {"initial", init_json},
                        {"levels", levels}};
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    fmt::print("T_target_source (maps {} into the frame of {}):\n{}", opt.source, opt.target,
               matrix_text(result.T_target_source, "  "));
    fmt::print("fitness:       {:.6f} ({} of {} source points within {:.4g} m)\n",
               result.fitness, result.correspondences, result.source_points, distance);
    fmt::print("inlier RMSE:   {:.6g} m\n", result.inlier_rmse);
    fmt::print("iterations:    {} ({})\n", result.iterations,
               result.converged ? "converged" : "iteration limit reached");
    fmt::print("method:        {}{}{}\n", to_string(result.method),
               kernel == RobustKernelType::None
                   ? std::string()
                   : fmt::format(", {} kernel (scale {:.4g})", to_string(kernel),
                                 kernel_scale),
               result.target_normals_estimated ? ", target normals estimated" : "");
    fmt::print("initial:       {}\n", init_text);
    if (result.source_non_finite || result.target_non_finite)
      fmt::print("dropped:       {} source and {} target points with NaN/Inf coordinates\n",
                 result.source_non_finite, result.target_non_finite);
  }
}

int run_register(const RegisterOptions& opt, const GlobalOptions& global) {
  const auto method = parse_icp_method(opt.method);
  if (!method)
    throw InputError(fmt::format("--method must be point-to-point, point-to-plane or colored, "
                                 "got '{}'",
                                 opt.method));
  const auto kernel = parse_robust_kernel(opt.kernel);
  if (!kernel)
    throw InputError(fmt::format("--kernel must be none, huber, tukey or geman-mcclure, got "
                                 "'{}'",
                                 opt.kernel));
  for (const std::string* out : {&opt.output, &opt.transform_out}) {
    if (out->empty()) continue;
    if (std::filesystem::exists(*out) && !opt.force)
      throw_input_error(*out, "output exists; pass --force to overwrite it");
  }
  if (!opt.output.empty() && !is_point_cloud_file(opt.output))
    throw_input_error(opt.output, "the aligned cloud must be written as .ply, .pcd or .e57");

  const PointCloud source = read_cloud(opt.source, "source");
  const PointCloud target = read_cloud(opt.target, "target");
  const double voxel =
      opt.voxel > 0.0 ? opt.voxel : std::max(extent(source), extent(target)) / 40.0;
  if (!(voxel > 0.0))
    throw InputError(fmt::format("{}: every point of both clouds is at the same place or "
                                 "non-finite; there is nothing to register",
                                 opt.source));
  const double distance = opt.max_distance > 0.0 ? opt.max_distance : voxel / 2.0;

  // --- initial estimate ---------------------------------------------------------------------
  Isometry3d init = Isometry3d::Identity();
  nlohmann::json init_json = {{"kind", opt.init}};
  std::string init_text = opt.init;
  if (opt.init == "global") {
    GlobalRegistrationOptions g;
    g.voxel_size = voxel;
    g.ransac.seed = opt.seed;
    const GlobalRegistrationResult gr = global_registration(source, target, g);
    const RansacResult& r = gr.ransac;
    init_json.update({{"voxel_size", voxel},
                      {"seed", r.seed},
                      {"success", r.success},
                      {"reason", r.reason},
                      {"matches", gr.matches},
                      {"inlier_correspondences", r.inlier_correspondences},
                      {"hypotheses", r.hypotheses},
                      {"fitness", r.fitness},
                      {"inlier_rmse", r.inlier_rmse},
                      {"T_target_source", matrix_json(r.T_target_source.matrix())}});
    init_text = fmt::format(
        "global (voxel {:.4g} m, RANSAC seed {}: {} of {} feature matches agree, {} "
        "hypotheses, fitness {:.4f})",
        voxel, r.seed, r.inlier_correspondences, gr.matches, r.hypotheses, r.fitness);
    if (!r.success) {
      if (opt.json) {
        std::printf("%s\n", nlohmann::json{{"source", opt.source},
                                           {"target", opt.target},
                                           {"success", false},
                                           {"reason", "global alignment failed: " + r.reason},
                                           {"initial", init_json}}
                                .dump(2)
                                .c_str());
      } else {
        fmt::print("initial alignment: {}\n", init_text);
      }
      std::fprintf(stderr, "locard: registration failed: global alignment: %s\n",
                   r.reason.c_str());
      return 3;
    }
    init = r.T_target_source;
  } else if (opt.init != "identity") {
    init = read_matrix_file(opt.init);
    init_json = {{"kind", "file"}, {"path", opt.init}};
    init_text = "from " + opt.init;
  }

  // --- ICP, coarse to fine -------------------------------------------------------------------
  IcpOptions icp_opt;
  icp_opt.method = *method;
  icp_opt.kernel.type = *kernel;
  icp_opt.kernel.scale = opt.kernel_scale > 0.0 ? opt.kernel_scale : distance;
  icp_opt.min_fitness = opt.min_fitness;
  std::vector<IcpScale> scales;
  for (int level = opt.levels - 1; level >= 0; --level) {
    const double gate = distance * std::pow(2.0, level);
    scales.push_back({level == 0 ? 0.0 : gate / 2.0, gate, opt.max_iterations});
  }
  const IcpResult result = icp_multiscale(source, target, init, icp_opt, scales);

  print_registration(opt, result, *kernel, icp_opt.kernel.scale, distance, init_json, init_text);
  if (!result.success) {
    std::fprintf(stderr, "locard: registration failed: %s\n", result.reason.c_str());
    return 3;
  }

  if (!opt.transform_out.empty()) {
    AtomicFile file(opt.transform_out, false);
    file.stream() << "# T_target_source: " << opt.source << " -> frame of " << opt.target
                  << "\n"
                  << matrix_text(result.T_target_source, "");
    file.commit();
  }
  if (!opt.output.empty()) {
    const PointCloud aligned = transformed(source, result.T_target_source);
    write_point_cloud(opt.output, aligned, {.ascii = opt.ascii});
    if (!global.quiet && !opt.json)
      fmt::print("wrote {} ({} points in the target frame)\n", opt.output, aligned.size());
  }
  return 0;
}

}  // namespace

void register_register(CLI::App& app, GlobalOptions& global) {
  auto opt = std::make_shared<RegisterOptions>();
  CLI::App* sub = app.add_subcommand(
      "register",
      "Register SOURCE onto TARGET: prints the 4x4 T_target_source (maps source points into "
      "the target frame), fitness and inlier RMSE. Exit status 3 when the registration fails");
  sub->add_option("source", opt->source, "Source cloud (.ply, .pcd), the one that moves")
      ->required();
  sub->add_option("target", opt->target, "Target cloud (.ply, .pcd), the fixed frame")
      ->required();
  sub->add_option("--init", opt->init,
                  "Initial estimate: global (FPFH + RANSAC), identity, or a file with a 4x4 "
                  "T_target_source, row by row")
      ->capture_default_str();
  sub->add_option("--method", opt->method, "ICP: point-to-point, point-to-plane or colored")
      ->capture_default_str();
  sub->add_option("--voxel", opt->voxel,
                  "Voxel size in metres for the features (default: largest extent / 40)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--max-distance", opt->max_distance,
                  "Final ICP correspondence distance in metres (default: voxel / 2); the "
                  "coarser levels use 2x and 4x")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--levels", opt->levels, "ICP scales, coarse to fine (1 to 3)")
      ->check(CLI::Range(1, 3))
      ->capture_default_str();
  sub->add_option("--max-iterations", opt->max_iterations, "ICP iterations per level at most")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  sub->add_option("--kernel", opt->kernel, "Robust kernel: none, huber, tukey, geman-mcclure")
      ->capture_default_str();
  sub->add_option("--kernel-scale", opt->kernel_scale,
                  "Kernel scale in metres (default: the final correspondence distance)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--min-fitness", opt->min_fitness,
                  "Fail when fewer than this fraction of source points end within the final "
                  "correspondence distance")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  sub->add_option("--seed", opt->seed, "RANSAC seed (same seed, same result)")
      ->capture_default_str();
  sub->add_option("-o,--output", opt->output,
                  "Write the source cloud moved into the target frame (.ply, .pcd)");
  sub->add_option("--transform-out", opt->transform_out,
                  "Write T_target_source as a 4x4 text matrix (readable by --init)");
  sub->add_flag("--ascii", opt->ascii, "Write the aligned cloud as ascii");
  sub->add_flag("--force", opt->force, "Overwrite existing output files");
  sub->add_flag("--json", opt->json, "Print machine-readable JSON");
  set_runner(sub, [opt, &global]() { return run_register(*opt, global); });
}

}  // namespace locard::cli
