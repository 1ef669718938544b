// `locard marker add|list|frame CASE ...`: numbered, labelled evidence markers on the model,
// reported in a chosen frame (evidence/markers.json + markers.csv); see evidence_markers.hpp.
#include "case_point.hpp"
#include "commands.hpp"

#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/case_model.hpp>
#include <locard/forensics/evidence_markers.hpp>
#include <locard/forensics/measurement.hpp>
#include <locard/forensics/report.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <memory>

namespace locard::cli {
namespace {

namespace fx = locard::forensics;

struct MarkerCli {
  std::string case_dir;
  std::vector<std::string> floor;  // `locard level`
  std::string label, at, note;
  bool no_snap = false;
  std::string origin, x_point, xy_point, description = "case frame";
  bool no_report = false;
  PointFrame frame = PointFrame::Case;
};

// One transaction: the markers files and their log step are saved together or not at all
// (a full disk leaves the case as it was), then the report as a step of its own.
void save(fx::CaseFolder& folder, const fx::MarkerSet& set, const std::string& step,
          const nlohmann::json& params, double seconds, bool report) {
  fx::LogStep s;
  s.step = step;
  s.parameters_json = params.dump();
  s.duration_s = seconds;
  s.outputs = {"evidence/markers.json", "evidence/markers.csv"};
  fx::CaseChange change(folder, s.outputs);
  fx::write_markers(folder.path("evidence/markers.json"), set);
  change.commit(s);
  if (report) fx::refresh_case_report(folder);
}

int run_add(const MarkerCli& o) {
  const auto t0 = std::chrono::steady_clock::now();
  fx::CaseFolder folder = fx::CaseFolder::open(o.case_dir, fx::CaseAccess::Change);
  fx::MarkerSet set = fx::read_markers(folder.root() / "evidence" / "markers.json");
  const Eigen::Vector3d p = parse_case_point(o.at, set, o.frame);
  fx::EvidenceMarker m;
  m.label = o.label;
  m.note = o.note;
  m.world = p;
  const fx::CaseModel model = fx::CaseModel::load(folder);
  const fx::SnappedPoint s = fx::snap_point(model, p);  // also refuses points off the model
  if (!o.no_snap) {
    m.world = s.snapped;
    m.snapped = true;
  }
  m.expanded_uncertainty_m = 2.0 * std::sqrt(std::max(0.0, s.covariance.trace()));
  const fx::EvidenceMarker added = set.add(m);
  save(folder, set, "marker add",
       {{"label", o.label},
        {"at", o.at},
        {"at_frame", o.frame == PointFrame::Case ? "case" : "world"},
        {"world", {p.x(), p.y(), p.z()}},
        {"snap", !o.no_snap},
        {"note", o.note}},
       std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), !o.no_report);
  // Only now, with everything saved: a line printed before a failed save was a false receipt.
  const bool case_frame = o.frame == PointFrame::Case;
  const Eigen::Vector3d shown = case_frame ? set.frame.to_local(added.world) : added.world;
  fmt::print("marker {} '{}' at ({:.4f}, {:.4f}, {:.4f}) in the {} frame, +- {:.4f} m\n",
             added.number, added.label, shown.x(), shown.y(), shown.z(),
             case_frame ? "case" : "world",
             added.expanded_uncertainty_m);
  print_log_head(folder.root());
  return 0;
}

int run_list(const MarkerCli& o) {
  const fx::CaseFolder folder = fx::CaseFolder::open(o.case_dir, fx::CaseAccess::Read);
  const fx::MarkerSet set = fx::read_markers(folder.root() / "evidence" / "markers.json");
  fmt::print("{}", fx::markers_csv(set));
  return 0;
}

int run_frame(const MarkerCli& o) {
  const auto t0 = std::chrono::steady_clock::now();
  fx::CaseFolder folder = fx::CaseFolder::open(o.case_dir, fx::CaseAccess::Change);
  fx::MarkerSet set = fx::read_markers(folder.root() / "evidence" / "markers.json");
  set.frame = fx::CaseFrame::from_points(parse_case_point(o.origin, set, o.frame),
                                         parse_case_point(o.x_point, set, o.frame),
                                         parse_case_point(o.xy_point, set, o.frame),
                                         o.description);
  save(folder, set, "marker frame",
       {{"origin", o.origin}, {"x_point", o.x_point}, {"xy_point", o.xy_point},
        {"points_frame", o.frame == PointFrame::Case ? "case" : "world"},
        {"description", o.description}},
       std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), !o.no_report);
  fmt::print("{}", fx::markers_csv(set));
  print_log_head(folder.root());
  return 0;
}

// `locard level CASE --floor P --floor P --floor P ...`: the case frame levelled on picked floor
// points (fx::level_frame); the markers' frame, so every command that reads or prints the case
// frame, the report's top view and plan, follow it.
int run_level(const MarkerCli& o) {
  const auto t0 = std::chrono::steady_clock::now();
  fx::CaseFolder folder = fx::CaseFolder::open(o.case_dir, fx::CaseAccess::Change);
  fx::MarkerSet set = fx::read_markers(folder.root() / "evidence" / "markers.json");
  const fx::CaseModel model = fx::CaseModel::load(folder);
  std::vector<Eigen::Vector3d> points;
  for (const std::string& text : o.floor) {
    // Onto the model's surface (as a marker is): the plane is the model's floor, not the typed
    // coordinates; a point off the model is refused, naming it.
    points.push_back(fx::snap_point(model, parse_case_point(text, set, o.frame)).snapped);
  }
  const fx::LevelledFrame level = fx::level_frame(set.frame, points);
  set.frame = level.frame;
  save(folder, set, "level",
       {{"floor_points", o.floor},
        {"points_frame", o.frame == PointFrame::Case ? "case" : "world"},
        {"tilt_deg", level.tilt_deg},
        {"rms_m", level.rms_m},
        {"max_m", level.max_m}},
       std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), !o.no_report);
  fmt::print("level: the floor through {} points, rms {:.1f} mm (farthest {:.1f} mm); the case "
             "frame's z turned {:.2f} deg onto its normal, origin on the floor\n",
             points.size(), 1000.0 * level.rms_m, 1000.0 * level.max_m, level.tilt_deg);
  const Eigen::Vector3d z = level.frame.axes.col(2), c = level.frame.origin;
  fmt::print("level: up (world) = ({:.4f}, {:.4f}, {:.4f}), origin (world) = ({:.4f}, {:.4f}, "
             "{:.4f})\n",
             z.x(), z.y(), z.z(), c.x(), c.y(), c.z());
  print_log_head(folder.root());
  return 0;
}

}  // namespace

void register_level(CLI::App& app, GlobalOptions&) {
  auto o = std::make_shared<MarkerCli>();
  CLI::App* cmd = app.add_subcommand(
      "level", "Level a case on picked floor points: the case frame's z becomes the floor's "
               "normal (least-squares plane through 3 or more points) and its origin drops onto "
               "the floor; a logged step. Top views, plans and case-frame coordinates follow");
  cmd->add_option("case", o->case_dir, "Case folder")->required();
  cmd->add_option("--floor", o->floor, "x,y,z of a floor point or a marker on the floor "
                                       "(case frame unless --frame world); 3 or more, spread")
      ->required()
      ->expected(1)
      ->take_all();
  add_point_frame_option(cmd, o->frame);
  cmd->add_flag("--no-report", o->no_report, "Do not rewrite the report");
  set_runner(cmd, [o] { return run_level(*o); });
}

void register_marker(CLI::App& app, GlobalOptions&) {
  auto o = std::make_shared<MarkerCli>();
  CLI::App* cmd = app.add_subcommand("marker", "Evidence markers of a case: add, list, frame");
  cmd->require_subcommand(1);
  CLI::App* add = cmd->add_subcommand("add", "Add a numbered, labelled marker on the model");
  add->add_option("case", o->case_dir, "Case folder")->required();
  add->add_option("--label", o->label, "Label, e.g. 'cartridge case'")->required();
  add->add_option("--at", o->at, "x,y,z (case frame unless --frame world; snapped to the surface)")
      ->required();
  add_point_frame_option(add, o->frame);
  add->add_option("--note", o->note, "Free text");
  add->add_flag("--no-snap", o->no_snap, "Keep the point as given");
  add->add_flag("--no-report", o->no_report, "Do not rewrite the report");
  CLI::App* list = cmd->add_subcommand("list", "Print the markers as CSV (case frame)");
  list->add_option("case", o->case_dir, "Case folder")->required();
  CLI::App* frame = cmd->add_subcommand(
      "frame", "Choose the frame markers are reported in: origin, a point on +x, a point in the "
               "xy plane (+y side)");
  frame->add_option("case", o->case_dir, "Case folder")->required();
  frame->add_option("--origin", o->origin, "x,y,z or a marker")->required();
  frame->add_option("--x-point", o->x_point, "x,y,z or a marker on the +x axis")->required();
  frame->add_option("--xy-point", o->xy_point, "x,y,z or a marker in the xy plane")->required();
  frame->add_option("--description", o->description, "What the frame is");
  frame->add_flag("--no-report", o->no_report, "Do not rewrite the report");
  add_point_frame_option(frame, o->frame);
  set_runner(cmd, [o, add, list, frame] {
    if (add->parsed()) return run_add(*o);
    if (list->parsed()) return run_list(*o);
    if (frame->parsed()) return run_frame(*o);
    return 2;
  });
}

}  // namespace locard::cli
