// `locard reconstruct INPUT -o CASE_DIR`: scan to case folder in one command (read, align,
// loop closure, mesh, export, measurements, report); see include/locard/forensics/reconstruct.hpp
// and docs/case-format.md. Exit status: 0 done, 2 bad input (nothing written over).
#include "commands.hpp"

#include <locard/alignment/sequential_alignment.hpp>
#include <locard/core/error.hpp>
#include <locard/core/progress.hpp>
#include <locard/forensics/reconstruct.hpp>
#include <locard/io/rgbd_sequence.hpp>

#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <memory>

namespace locard::cli {
namespace {

namespace fs = std::filesystem;

struct ReconstructCli {
  std::string input;
  std::string output;
  std::string config;
  std::string reference;
  std::optional<double> voxel;
  std::optional<double> mesh_voxel;
  std::optional<std::size_t> frames;
  std::optional<std::uint64_t> seed;
  std::optional<std::string> mode;
  std::optional<std::string> scan_poses;
  std::optional<std::string> up;
  bool no_pdf = false;
  bool force = false;
};

int run_reconstruct(const ReconstructCli& o, const GlobalOptions& global) {
  namespace fx = locard::forensics;
  if (!fs::exists(o.input)) throw_input_error(o.input, "no such file or folder");
  // Defaults from what the data is (its traits), then the config file, then flags.
  SequenceTraits traits;
  if (fs::is_directory(o.input)) {
    const DatasetFormat format = detect_format(o.input);
    if (format == DatasetFormat::Tum || format == DatasetFormat::SevenScenes ||
        format == DatasetFormat::Redwood)
      traits = open_rgbd_sequence(o.input).traits;
  }
  fx::ReconstructParameters p = fx::ReconstructParameters::defaults_for(traits);
  if (!o.config.empty()) p = fx::ReconstructParameters::from_json_file(o.config, p);
  if (!o.reference.empty()) p.reference = o.reference;
  if (o.voxel) p.alignment.voxel_size = *o.voxel;
  if (o.mesh_voxel) p.fusion.voxel_size = *o.mesh_voxel;
  if (o.frames) p.alignment.max_frames = *o.frames;
  if (o.seed) p.alignment.seed = *o.seed;
  if (o.mode) {
    const auto mode = parse_alignment_mode(*o.mode);
    if (!mode) throw InputError(fmt::format("--mode must be cumulative or odometry, got '{}'", *o.mode));
    p.alignment.mode = *mode;
  }
  // --scan-poses and --up are checked against their names by CLI11.
  if (o.scan_poses) p.scan_poses = fx::parse_scan_pose_source(*o.scan_poses).value();
  if (o.up) p.up = parse_up_axis(*o.up).value();
  if (o.no_pdf) p.pdf = false;

  const bool show = ProgressBar::should_show(global.quiet);
  std::unique_ptr<ProgressBar> bar;
  fx::StageCallbacks cb;
  cb.begin = [&](const std::string& stage, std::size_t total) -> ProgressCallback {
    if (!global.quiet && !show) fmt::print("reconstruct: {} ...\n", stage);
    std::fflush(stdout);
    bar = std::make_unique<ProgressBar>(stage, std::max<std::size_t>(total, 1), show);
    return bar->callback();
  };
  cb.end = [&](const std::string&) {
    if (bar) bar->finish();
    bar.reset();
  };
  cb.log = [&](const std::string& m) { std::fprintf(stderr, "locard: %s\n", m.c_str()); };
  const fx::ReconstructSummary s = fx::reconstruct_case(o.input, o.output, p, o.force, cb);
  if (!global.quiet) {
    fmt::print("reconstruct: {} of {} views registered, {} of {} usable verified by the "
               "self-check; mesh {} vertices, {} triangles\n",
               s.registered, s.frames, s.verified, s.usable, s.vertices, s.triangles);
    if (s.measurements)
      fmt::print("reconstruct: {} reference measurements, {} within their stated uncertainty "
                 "(measurements/table.csv)\n",
                 s.measurements, s.measurements_within);
    if (s.measurements_not_measured)
      fmt::print("reconstruct: {} reference measurements not covered by the model\n",
                 s.measurements_not_measured);
    if (s.measurements_not_snapped)
      fmt::print("reconstruct: {} reference measurements with an end not snapped (no face, edge "
                 "or corner across the line: the tape point is used as given, so they measure "
                 "nothing)\n",
                 s.measurements_not_snapped);
    if (s.floor_seen_share) {
      fmt::print("reconstruct: floor observed {:.0f} % (coverage/floor_coverage.json)\n",
                 100.0 * *s.floor_seen_share);
      for (const std::string& line : s.coverage_advice)
        fmt::print("reconstruct: coverage: {}\n", line);
    }
    std::string stages;
    for (const auto& [name, sec] : s.stage_seconds)
      stages += fmt::format("{}{} {:.1f} s", stages.empty() ? "" : ", ", name, sec);
    fmt::print("reconstruct: {:.1f} s ({})\n", s.seconds, stages);
    fmt::print("reconstruct: case folder {}\n", s.case_dir.string());
    fmt::print("reconstruct: report {}\n", fs::absolute(s.report_html).string());
    if (s.report_pdf) fmt::print("reconstruct: report {}\n", fs::absolute(*s.report_pdf).string());
  }
  print_log_head(s.case_dir);
  if (!s.enough_verified) {
    std::fprintf(stderr,
                 "locard: only %zu of %zu usable views verified: the case is written with the "
                 "flagged views left out, but the model is incomplete or wrong; exit %d\n",
                 s.verified, s.usable, kExitTooFewVerified);
    return kExitTooFewVerified;
  }
  return 0;
}

}  // namespace

void register_reconstruct(CLI::App& app, GlobalOptions& global) {
  auto o = std::make_shared<ReconstructCli>();
  CLI::App* cmd = app.add_subcommand(
      "reconstruct",
      "Scan to case folder in one command: hash the inputs, align (registration, loop closure, "
      "pose graph), mesh, export, measure the reference distances, write the report");
  cmd->add_option("input", o->input,
                  "RGB-D sequence folder (TUM, 7-Scenes, Redwood, scan-sim), or range scans: a "
                  "Stanford .conf, a folder of PLY/PCD scans, an E57 file of several scans")
      ->required();
  cmd->add_option("-o,--output", o->output, "Case folder to create")->required();
  cmd->add_option("--config", o->config,
                  "JSON file of parameters (every key of case.json's \"parameters\")");
  cmd->add_option("--reference", o->reference,
                  "Reference (tape) measurements, JSON; default INPUT/measurements.json");
  cmd->add_option("--voxel", o->voxel, "Alignment voxel (m)")->check(CLI::PositiveNumber);
  cmd->add_option("--mesh-voxel", o->mesh_voxel, "TSDF voxel (m)")->check(CLI::PositiveNumber);
  cmd->add_option("--frames", o->frames, "Use at most this many frames");
  cmd->add_option("--seed", o->seed, "RANSAC seed");
  cmd->add_option("--mode", o->mode,
                  "cumulative or odometry (default: from the data: odometry for video, "
                  "cumulative for a tripod turn)");
  cmd->add_option("--scan-poses", o->scan_poses,
                  "Range scans: input (start from the poses the input gives, default) or global "
                  "(feature registration for every pair)")
      ->check(CLI::IsMember({"input", "global"}));
  cmd->add_option("--up", o->up,
                  "The axis that points up in mesh.obj and mesh.fbx: y (default; Blender, "
                  "Unity) or z (CloudCompare, surveying tools); mesh.glb is always y-up")
      ->check(CLI::IsMember({"y", "z"}));
  cmd->add_flag("--no-pdf", o->no_pdf, "Do not print report.pdf");
  cmd->add_flag("--force", o->force, "Replace an existing case folder");
  set_runner(cmd, [o, &global] { return run_reconstruct(*o, global); });
}

}  // namespace locard::cli
