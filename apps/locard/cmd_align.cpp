// `locard align SEQUENCE -o DIR`: whole-sequence alignment (sequential registration, loop
// closure, pose graph; see include/locard/alignment/sequential_alignment.hpp). Writes
//   trajectory.txt     TUM format, registered frames only (one file per piece when the
//                      sequence falls apart: trajectory_piece<k>.txt)
//   pose_graph.json    nodes, kept edges with information matrices, rejected loop edges
//   stage_report.json  errors after SVD / ICP / loop closure, loop closures, frame status
//   stage_report.svg   the plot (the paper's Fig. 4)
//   fused.ply          the registered frames fused into one coloured cloud (fused_piece<k>.ply)
// Frames that could not be registered are listed by index on stderr and in the report.
// Every registered frame is checked against the other frames (ViewCheckOptions); flagged frames
// are listed on stderr with the reason and left out of the trajectory and the fused cloud.
// Exit status: 0 aligned, 2 bad input, 3 fewer than two frames could be registered,
// 4 (kExitTooFewVerified) fewer than min_verified_share of the usable frames verified (the
// outputs are still written, with the flagged frames left out).
#include "commands.hpp"

#include <locard/alignment/alignment_defaults.hpp>
#include <locard/alignment/pose_graph.hpp>
#include <locard/alignment/scan_alignment.hpp>
#include <locard/alignment/sequential_alignment.hpp>
#include <locard/alignment/stage_report.hpp>
#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/core/progress.hpp>
#include <locard/io/point_cloud_io.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/io/stanford_conf.hpp>
#include <locard/io/trajectory_io.hpp>
#include <locard/preprocess/voxel_grid.hpp>
#include <locard/io/matrix_json.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

namespace locard::cli {
namespace {

struct AlignCliOptions {
  std::string sequence;
  std::string output;
  // Unset: from the sequence's traits (default_alignment_options, alignment_defaults.hpp).
  std::optional<std::string> mode;
  std::optional<std::string> odometry_icp;
  std::optional<std::string> tripod_icp;
  std::optional<double> max_depth;
  // The flags below are bound to these fields: their defaults are AlignmentOptions{}'s, the
  // one place they are written (sequential_alignment.hpp).
  AlignmentOptions tuning;
  bool no_loop_closure = false;
  bool force = false;
};

nlohmann::json edge_json(const PoseGraphEdge& e, const AlignmentResult& r) {
  return {{"source_frame", r.frames[r.node_frames[e.source]].frame_index},
          {"target_frame", r.frames[r.node_frames[e.target]].frame_index},
          {"source_node", e.source},
          {"target_node", e.target},
          {"kind", e.uncertain ? "loop" : "odometry"},
          {"T_target_source", pose_json(e.T_target_source)},
          {"information", matrix_json(e.information)},
          {"line_process_weight", e.confidence},
          {"chi2", e.chi2}};
}

void write_pose_graph_json(const std::filesystem::path& path, const AlignmentResult& r) {
  nlohmann::json nodes = nlohmann::json::array();
  for (std::size_t k = 0; k < r.graph.nodes.size(); ++k) {
    const FrameAlignment& f = r.frames[r.node_frames[k]];
    nodes.push_back({{"node", k},
                     {"frame_index", f.frame_index},
                     {"timestamp", f.timestamp},
                     {"piece", f.piece},
                     {"T_world_camera", pose_json(r.graph.nodes[k])}});
  }
  nlohmann::json edges = nlohmann::json::array();
  for (const PoseGraphEdge& e : r.graph.edges) edges.push_back(edge_json(e, r));
  nlohmann::json rejected = nlohmann::json::array();
  for (const RejectedEdge& e : r.pose_graph.rejected) {
    nlohmann::json j = edge_json(e.edge, r);
    j["reason"] = e.reason;
    rejected.push_back(j);
  }
  nlohmann::json j = {{"convention",
                       "T_world_camera maps camera points to the world; an edge's T_target_source "
                       "maps source-camera points into the target camera; information is 6x6, "
                       "rotation then translation, in the target frame"},
                      {"nodes", nodes},
                      {"edges", edges},
                      {"rejected_edges", rejected}};
  AtomicFile file(path, false);
  file.stream() << j.dump(1) << '\n';
  file.commit();
}

// The range scans of a Stanford .conf, or of a folder holding one (the first by name) or only
// PLY/PCD scans (then each in its sensor's frame). Empty when `path` is neither.
struct ScanSet {
  std::vector<std::string> names;
  std::vector<std::filesystem::path> files;
  std::optional<StanfordConf> conf;
};

std::optional<ScanSet> find_scan_set(const std::filesystem::path& path, DatasetFormat format) {
  namespace fs = std::filesystem;
  fs::path conf_path;
  ScanSet set;
  if (format == DatasetFormat::StanfordConf) {
    conf_path = path;
  } else if (format == DatasetFormat::RangeScanFolder) {
    std::vector<fs::path> confs, clouds;
    for (const auto& e : fs::directory_iterator(path)) {
      if (e.path().extension() == ".conf") confs.push_back(e.path());
      else if (is_point_cloud_file(e.path())) clouds.push_back(e.path());
    }
    if (!confs.empty()) {
      conf_path = *std::min_element(confs.begin(), confs.end());
    } else if (clouds.size() >= 2) {
      std::sort(clouds.begin(), clouds.end());
      for (const fs::path& c : clouds) {
        set.names.push_back(c.filename().string());
        set.files.push_back(c);
      }
      return set;
    }
  }
  if (conf_path.empty()) return std::nullopt;
  set.conf = read_stanford_conf(conf_path);
  for (const RangeScan& scan : set.conf->scans) {
    set.names.push_back(scan.name);
    set.files.push_back(scan.file);
  }
  return set;
}

// A set of range scans: multiway registration from identity (scan_alignment.hpp). Writes
//   aligned.conf       the estimated poses in the .conf convention (T_world_scan = [R(q)^T | t]),
//                      in the frame of the first scan
//   scan_alignment.json per-scan poses (and errors against the input .conf when there is one),
//                      the pairs with their verification
//   fused.ply          the placed scans in one cloud (voxel grid of half the alignment's voxel)
int run_align_scans(const AlignCliOptions& opt, const GlobalOptions& global, const ScanSet& set) {
  namespace fs = std::filesystem;
  const std::vector<std::string>& names = set.names;
  const std::vector<fs::path>& files = set.files;
  const std::optional<StanfordConf>& conf = set.conf;
  if (files.size() < 2)
    throw_input_error(opt.sequence, fmt::format("expected at least two scans, found {}",
                                                files.size()));
  if (fs::exists(opt.output) && !fs::is_empty(opt.output) && !opt.force)
    throw_input_error(opt.output, "output folder is not empty; pass --force to write into it");
  std::vector<PointCloud> scans;
  for (const fs::path& f : files) scans.push_back(read_point_cloud(f));
  ScanAlignmentOptions o;
  o.seed = opt.tuning.seed;
  const ScanAlignmentResult r = align_scans(scans, o);

  fs::create_directories(opt.output);
  const fs::path out(opt.output);
  nlohmann::json jscans = nlohmann::json::array();
  std::string conf_text;
  double worst_deg = 0.0, worst_m = 0.0;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    nlohmann::json j = {{"name", names[i]}, {"placed", r.placed[i] != 0}};
    if (!r.placed[i]) {
      fmt::print(stderr, "locard: scan {} could not be connected to the others\n", names[i]);
      jscans.push_back(j);
      continue;
    }
    j["T_world_scan"] = pose_json(r.T_world_scan[i]);
    const Eigen::Quaterniond q(Eigen::Matrix3d(r.T_world_scan[i].linear().transpose()));
    const Eigen::Vector3d t = r.T_world_scan[i].translation();
    conf_text += fmt::format("bmesh {} {:.9g} {:.9g} {:.9g} {:.9g} {:.9g} {:.9g} {:.9g}\n", names[i],
                             t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
    if (conf) {
      // bun.conf's frame through the first scan.
      const Isometry3d estimate = conf->scans[0].T_world_scan * r.T_world_scan[i];
      const double dr = rotation_difference_deg(conf->scans[i].T_world_scan, estimate);
      const double dt = translation_difference_m(conf->scans[i].T_world_scan, estimate);
      j["error_deg"] = dr;
      j["error_m"] = dt;
      worst_deg = std::max(worst_deg, dr);
      worst_m = std::max(worst_m, dt);
      if (!global.quiet)
        fmt::print("align: {:<14} {:.3f} deg, {:.3f} mm from the input .conf\n", names[i], dr,
                   1000.0 * dt);
    }
    jscans.push_back(j);
  }
  nlohmann::json jpairs = nlohmann::json::array();
  std::size_t verified = 0, kept = 0;
  for (const ScanPair& p : r.pairs) {
    verified += p.verified;
    kept += p.kept;
    jpairs.push_back({{"source", names[p.source]},
                      {"target", names[p.target]},
                      {"verified", p.verified},
                      {"spanning_tree", p.in_tree},
                      {"kept", p.kept},
                      {"fitness", p.fitness},
                      {"inlier_rmse", p.inlier_rmse},
                      {"reason", p.reason},
                      {"T_target_source", pose_json(p.T_target_source)}});
  }
  {
    AtomicFile file(out / "aligned.conf", false);
    file.stream() << conf_text;
    file.commit();
  }
  {
    nlohmann::json j = {{"convention", "T_world_scan maps scan points into the first scan's "
                                       "frame; aligned.conf uses the Stanford convention "
                                       "[R(q)^T | t]"},
                        {"seed", opt.tuning.seed},
                        {"scans", jscans},
                        {"pairs", jpairs},
                        {"seconds", r.seconds}};
    AtomicFile file(out / "scan_alignment.json", false);
    file.stream() << j.dump(1) << '\n';
    file.commit();
  }
  PointCloud fused;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    if (!r.placed[i]) continue;
    fused.append(transformed(
        voxel_down_sample(scans[i], static_cast<float>(o.voxel_size / 2.0)).cloud,
        r.T_world_scan[i]));
  }
  if (!fused.empty()) write_point_cloud(out / "fused.ply", fused);
  std::size_t placed = 0;
  for (char p : r.placed) placed += p != 0;
  if (!global.quiet) {
    fmt::print("align: {} of {} scans placed; {} of {} pairs verified, {} kept{}; {:.1f} s; "
               "wrote {}\n",
               placed, scans.size(), verified, r.pairs.size(), kept,
               conf ? fmt::format("; worst {:.3f} deg, {:.3f} mm from the input .conf", worst_deg,
                                  1000.0 * worst_m)
                    : std::string(),
               r.seconds, opt.output);
  }
  return placed >= 2 ? 0 : 3;
}

int run_align(const AlignCliOptions& opt, const GlobalOptions& global) {
  namespace fs = std::filesystem;
  if (fs::exists(opt.output) && !fs::is_directory(opt.output))
    throw_input_error(opt.output, "the output must be a folder; a file is in the way");
  const bool input_exists = fs::exists(opt.sequence);
  const DatasetFormat format = input_exists ? detect_format(opt.sequence) : DatasetFormat::Unknown;
  if (const auto set = find_scan_set(opt.sequence, format))
    return run_align_scans(opt, global, *set);
  std::optional<AlignmentMode> mode;
  if (opt.mode) {
    mode = parse_alignment_mode(*opt.mode);
    if (!mode)
      throw InputError(fmt::format("--mode must be cumulative or odometry, got '{}'", *opt.mode));
  }
  std::optional<IcpMethod> odometry_icp;
  if (opt.odometry_icp) {
    odometry_icp = parse_icp_method(*opt.odometry_icp);
    if (!odometry_icp || *odometry_icp == IcpMethod::PointToPoint)
      throw InputError(fmt::format("--odometry-icp must be colored or point-to-plane, got '{}'",
                                   *opt.odometry_icp));
  }
  std::optional<IcpMethod> tripod_icp;
  if (opt.tripod_icp) {
    tripod_icp = parse_icp_method(*opt.tripod_icp);
    if (!tripod_icp || *tripod_icp == IcpMethod::PointToPoint)
      throw InputError(fmt::format("--tripod-icp must be colored or point-to-plane, got '{}'",
                                   *opt.tripod_icp));
  }
  if (!input_exists) throw_input_error(opt.sequence, "no such file or folder");
  if (format != DatasetFormat::Tum && format != DatasetFormat::SevenScenes &&
      format != DatasetFormat::Redwood)
    throw_input_error(opt.sequence,
                      fmt::format("expected an RGB-D sequence folder (TUM, 7-Scenes or Redwood), "
                                  "a Stanford .conf or a folder of range scans, found {}",
                                  to_string(format)));
  if (fs::exists(opt.output) && !fs::is_empty(opt.output) && !opt.force)
    throw_input_error(opt.output, "output folder is not empty; pass --force to write into it");
  const RgbdSequence sequence = open_rgbd_sequence(opt.sequence);

  // Defaults from what the data is; the flags the user gave override them.
  AlignmentOptions o = default_alignment_options(sequence.traits, opt.tuning);
  if (mode) o.mode = *mode;
  if (odometry_icp) o.odometry_method = *odometry_icp;
  if (tripod_icp) o.tripod_method = *tripod_icp;
  if (opt.max_depth) o.max_depth_m = *opt.max_depth;
  if (!global.quiet)
    fmt::print("align: data: {} ({}); {} mode{}, {} ICP for odometry, depth to {:.1f} m\n",
               describe(sequence.traits), sequence.traits.source, to_string(o.mode),
               opt.mode ? " (--mode)" : "", to_string(o.odometry_method), o.max_depth_m);
  o.loop_closure = !opt.no_loop_closure;
  o.pose_graph.max_correspondence_distance = 1.5 * o.voxel_size;
  const std::size_t total =
      o.max_frames ? std::min(o.max_frames, sequence.frames.size() - std::min(o.first_frame, sequence.frames.size()))
                 : sequence.frames.size();
  ProgressBar bar("align", total, ProgressBar::should_show(global.quiet));
  o.progress = bar.callback();
  const AlignmentResult result = align_sequence(sequence, o);
  bar.finish();

  fs::create_directories(opt.output);
  const fs::path out(opt.output);
  const StageReport report = make_stage_report(result, sequence);
  write_stage_report_json(out / "stage_report.json", result, report);
  write_stage_report_svg(out / "stage_report.svg", result, report);
  write_pose_graph_json(out / "pose_graph.json", result);
  for (std::size_t p = 0; p < std::max<std::size_t>(result.pieces, 1); ++p) {
    const std::string suffix = result.pieces > 1 ? fmt::format("_piece{}", p) : "";
    write_tum_trajectory(out / ("trajectory" + suffix + ".txt"),
                         result.trajectory(static_cast<long>(p)));
    const PointCloud fused =
        fuse_aligned_frames(sequence, result, o.voxel_size / 2.0, static_cast<long>(p));
    if (!fused.empty()) write_point_cloud(out / ("fused" + suffix + ".ply"), fused);
  }

  std::size_t registered = 0, accepted_loops = 0;
  for (const FrameAlignment& f : result.frames) registered += f.status == FrameStatus::Registered;
  for (const LoopCandidate& c : result.loops) accepted_loops += c.accepted;
  for (const FrameAlignment& f : result.frames)
    if (f.status != FrameStatus::Registered)
      std::fprintf(stderr, "locard: frame %lld not registered (%s): %s\n",
                   static_cast<long long>(f.frame_index), std::string(to_string(f.status)).c_str(),
                   f.reason.c_str());
  for (const FrameAlignment& f : result.frames)
    if (f.status == FrameStatus::Registered && f.check.checked && !f.check.verified)
      std::fprintf(stderr, "locard: frame %lld flagged by the self-check, left out: %s\n",
                   static_cast<long long>(f.frame_index), f.check.reason.c_str());
  if (!result.enough_trusted())
    std::fprintf(stderr,
                 "locard: only %zu of %zu usable frames verified (%.0f %%, need %.0f %%): the "
                 "model is incomplete or wrong; exit %d\n",
                 result.trusted_frames(), result.usable_frames(), 100.0 * result.trusted_share(),
                 100.0 * o.min_verified_share, kExitTooFewVerified);
  if (result.pieces > 1)
    std::fprintf(stderr,
                 "locard: the sequence falls into %zu unconnected pieces; each is written "
                 "separately (trajectory_piece<k>.txt, fused_piece<k>.ply)\n",
                 result.pieces);
  if (!global.quiet) {
    fmt::print("align: {} mode, {} of {} frames registered, {} piece{}\n", to_string(o.mode),
               registered, result.frames.size(), result.pieces, result.pieces == 1 ? "" : "s");
    fmt::print("align: {} of {} usable frames verified by the self-check ({:.0f} %)\n",
               result.trusted_frames(), result.usable_frames(), 100.0 * result.trusted_share());
    fmt::print("align: {} loop closure{} kept of {} candidates; pose graph {} nodes, {} edges, "
               "cost {:.4g} -> {:.4g}\n",
               accepted_loops, accepted_loops == 1 ? "" : "s", result.loops.size(),
               result.graph.nodes.size(), result.graph.edges.size(),
               result.pose_graph.initial_cost, result.pose_graph.final_cost);
    if (report.has_ground_truth) {
      const char* names[3] = {"initial pose (SVD or tripod guess)", "after ICP", "after loop closure"};
      for (int s = 0; s < 3; ++s) {
        const StageSummary& sum = report.summary[s];
        if (!sum.views) continue;
        fmt::print("align: {:<19} mean error {:.2f} mm, max {:.2f} mm, ATE {}\n", names[s],
                   1000.0 * sum.mean_translation_m, 1000.0 * sum.max_translation_m,
                   sum.ate_rmse_m ? fmt::format("{:.2f} mm", 1000.0 * *sum.ate_rmse_m) : "n/a");
      }
    }
    const AlignmentTimings& t = result.timings;
    fmt::print("align: {:.1f} s (frames {:.1f}, registration {:.1f}, loop closure {:.1f}, pose "
               "graph {:.1f}, self-check {:.1f}); wrote {}\n",
               t.total_s, t.prepare_s, t.register_s, t.loop_closure_s, t.pose_graph_s,
               t.verification_s, opt.output);
  }
  if (registered < 2) return 3;
  return result.enough_trusted() ? 0 : kExitTooFewVerified;
}

}  // namespace

void register_align(CLI::App& app, GlobalOptions& global) {
  auto options = std::make_shared<AlignCliOptions>();
  CLI::App* cmd = app.add_subcommand(
      "align",
      "Align every frame of an RGB-D sequence (TUM, 7-Scenes, Redwood): sequential "
      "registration, loop closure, pose graph; writes trajectory, pose graph, stage report and "
      "fused cloud. Or a set of range scans (a Stanford .conf, or a folder holding one or only "
      "PLY/PCD scans): multiway registration from identity; writes aligned.conf, "
      "scan_alignment.json and fused.ply");
  cmd->add_option("sequence", options->sequence,
                  "Sequence folder, .conf file or folder of range scans")
      ->required();
  cmd->add_option("-o,--output", options->output, "Output folder")->required();
  cmd->add_option("--mode", options->mode,
                  "cumulative (each view against the model of all earlier views, features + "
                  "ICP) or odometry (frame-to-local-model coloured ICP, for video); default: "
                  "from the data (odometry for video, cumulative for a tripod turn or when "
                  "unknown)");
  cmd->add_option("--odometry-icp", options->odometry_icp,
                  "Odometry mode, last ICP level: colored (colour registered to depth) or "
                  "point-to-plane; default: from the data (colored when colour is registered "
                  "to depth)");
  cmd->add_option("--tripod-icp", options->tripod_icp,
                  "Cumulative (tripod) mode, last ICP level: colored or point-to-plane; "
                  "default: from the data (colored when colour is registered to depth)");
  cmd->add_option("--voxel", options->tuning.voxel_size, "Voxel size of frames and model (m)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--stride", options->tuning.stride, "Depth pixel stride")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  cmd->add_option("--min-depth", options->tuning.min_depth_m, "Nearest depth used (m)")->capture_default_str();
  cmd->add_option("--max-depth", options->max_depth,
                  "Farthest depth used (m); default: from the data (structured light 3, time "
                  "of flight 4.5, synthetic 8)");
  cmd->add_option("--first", options->tuning.first_frame, "First frame (index in the sequence)");
  cmd->add_option("--frames", options->tuning.max_frames, "Number of frames (0: all)");
  cmd->add_flag("--no-loop-closure", options->no_loop_closure, "Skip loop closure");
  cmd->add_option("--loop-max-angle", options->tuning.loop_max_angle_deg,
                  "Loop candidates: cameras within this viewing angle (degrees)")
      ->capture_default_str();
  cmd->add_option("--loop-max-distance", options->tuning.loop_max_distance_m,
                  "Loop candidates: cameras within this distance (m)")
      ->capture_default_str();
  cmd->add_option("--loop-min-fitness", options->tuning.loop_min_fitness,
                  "Loop verification: least ICP fitness")
      ->capture_default_str();
  cmd->add_option("--local-model-frames", options->tuning.local_model_frames,
                  "Odometry mode: keyframes in the local model each frame is tracked against")
      ->capture_default_str();
  cmd->add_option("--keyframe-interval", options->tuning.keyframe_interval,
                  "Odometry mode: registered frames between keyframes")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--seed", options->tuning.seed, "RANSAC seed")->capture_default_str();
  cmd->add_flag("--force", options->force, "Write into a folder that is not empty");
  set_runner(cmd, [options, &global] { return run_align(*options, global); });
}

}  // namespace locard::cli
