// `locard trajectory CASE --point A --point B [--point C ...]`: a bullet trajectory through two
// holes (or fitted to a rod's points): angles, the surfaces it meets both ways, error cone.
// Appended to trajectories/analyses.json, logged, report refreshed. See trajectory_analysis.hpp.
#include "case_point.hpp"
#include "commands.hpp"

#include <locard/core/atomic_file.hpp>
#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/case_model.hpp>
#include <locard/forensics/report.hpp>
#include <locard/forensics/trajectory_analysis.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <memory>

namespace locard::cli {
namespace {

namespace fx = locard::forensics;

struct TrajectoryCli {
  std::string case_dir;
  std::string name = "trajectory";
  std::vector<std::string> points;
  double sigma = 0.0;
  bool no_report = false;
  PointFrame frame = PointFrame::Case;
};

int run_trajectory(const TrajectoryCli& o) {
  const auto t0 = std::chrono::steady_clock::now();
  fx::CaseFolder folder = fx::CaseFolder::open(o.case_dir, fx::CaseAccess::Change);
  const fx::MarkerSet markers = fx::read_markers(folder.root() / "evidence" / "markers.json");
  fx::TrajectoryInput in;
  in.name = o.name;
  in.point_sigma_m = o.sigma;
  for (const std::string& p : o.points) in.points.push_back(parse_case_point(p, markers, o.frame));
  const fx::CaseModel model = fx::CaseModel::load(folder);
  const fx::TrajectoryAnalysis a =
      fx::record_trajectory_analysis(
          folder, fx::analyse_trajectory(&model, in),
          nlohmann::json{{"name", o.name},
                         {"points", o.points},
                         {"points_frame", o.frame == PointFrame::Case ? "case" : "world"},
                         {"sigma_m", o.sigma}}
              .dump(),
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count())
          .analysis;
  if (!o.no_report) fx::refresh_case_report(folder);
  // Printed once everything is saved: not a receipt for a failed save.
  fmt::print("{}: horizontal {:.2f} deg, vertical {:.2f} deg, cone half-angle {:.2f} deg (k=2)\n",
             a.name, a.horizontal_angle_deg, a.vertical_angle_deg, a.cone_half_angle_deg);
  for (const auto* h : {&a.forward, &a.backward}) {
    const char* way = h == &a.forward ? "forward" : "backward";
    const Eigen::Vector3d p =
        o.frame == PointFrame::Case ? markers.frame.to_local(h->point) : h->point;
    if (h->hit)
      fmt::print("{}: {} hit at ({:.4f}, {:.4f}, {:.4f}) in the {} frame, {:.3f} m away, cone "
                 "radius {:.4f} m\n",
                 a.name, way, p.x(), p.y(), p.z(), o.frame == PointFrame::Case ? "case" : "world",
                 h->distance_m, h->cone_radius_m);
    else
      fmt::print("{}: {}: no surface met\n", a.name, way);
  }
  print_log_head(folder.root());
  return 0;
}

}  // namespace

void register_trajectory(CLI::App& app, GlobalOptions&) {
  auto o = std::make_shared<TrajectoryCli>();
  CLI::App* cmd = app.add_subcommand(
      "trajectory", "Bullet trajectory through two holes or along a rod: angles, surfaces met "
                    "both ways, error cone");
  cmd->add_option("case", o->case_dir, "Case folder")->required();
  cmd->add_option("--name", o->name, "Name of the analysis")->capture_default_str();
  cmd->add_option("--point", o->points, "x,y,z or a marker; two (entry, exit) or more (rod)")
      ->required();
  cmd->add_option("--sigma", o->sigma, "Standard uncertainty of each point (m; 0: from the model)");
  cmd->add_flag("--no-report", o->no_report, "Do not rewrite the report");
  add_point_frame_option(cmd, o->frame);
  set_runner(cmd, [o] { return run_trajectory(*o); });
}

}  // namespace locard::cli
