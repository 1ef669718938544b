// `locard measure CASE ...`: measurements on a case's model, each with its uncertainty,
// appended to the case (log + manifest) and the report refreshed.
//   --from A --to B                 point to point (points snapped to the surface)
//   --point P --plane Q             point to the plane through the surface around Q
//   --plane Q --plane2 R            angle between two planes
//   --reference FILE                the Table-I comparison (name, a, b, distance_m)
// Points: x,y,z or evidence markers. Exit 2 for bad input (a point off the model, a reference
// file with unknown names or keys); nothing is written then.
#include "case_point.hpp"
#include "commands.hpp"

#include <locard/core/atomic_file.hpp>
#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/case_model.hpp>
#include <locard/forensics/measurement.hpp>
#include <locard/forensics/report.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <fstream>
#include <sstream>
#include <filesystem>
#include <memory>

namespace locard::cli {
namespace {

namespace fs = std::filesystem;
namespace fx = locard::forensics;

struct MeasureCli {
  std::string case_dir;
  std::string name;
  std::string from, to, point, plane, plane2, reference;
  double radius = 0.03;
  double plane_radius = 0.05;
  bool no_report = false;
  PointFrame frame = PointFrame::Case;
};

int run_measure(const MeasureCli& o, const GlobalOptions& global) {
  const auto t0 = std::chrono::steady_clock::now();
  fx::CaseFolder folder = fx::CaseFolder::open(o.case_dir, fx::CaseAccess::Change);
  const fx::MarkerSet markers = fx::read_markers(folder.root() / "evidence" / "markers.json");
  fx::SnapOptions so;
  so.search_radius_m = o.radius;
  fx::LogStep step;
  std::string result;  // printed once everything is saved: not a receipt for a failed save
  // Every file a measurement may write, kept aside until its step is logged (all or nothing).
  fx::CaseChange change(folder, {"measurements/reference.json", "measurements/table.json",
                                 "measurements/table.csv", "measurements/measurements.json",
                                 "measurements/measurements.csv"});
  nlohmann::json params = {{"snap_radius_m", o.radius},
                            {"points_frame", o.frame == PointFrame::Case ? "case" : "world"}};
  if (!o.reference.empty()) {
    const auto refs = fx::read_reference_measurements(
        o.reference, [&](const std::string& n) -> std::optional<Eigen::Vector3d> {
          if (const fx::EvidenceMarker* m = markers.find_usable(n)) return m->world;
          return std::nullopt;
        });
    const fx::CaseModel model = fx::CaseModel::load(folder);
    const auto rows = fx::compare_with_reference(model, refs, so);
    {
      std::ifstream in(o.reference, std::ios::binary);
      std::stringstream ss;
      ss << in.rdbuf();
      AtomicFile f(folder.path("measurements/reference.json"), false);
      f.stream() << ss.str();
      f.commit();
    }
    fx::write_measurement_table(folder, rows);
    if (!global.quiet) {
      result += fmt::format("{:<18} {:>10} {:>10} {:>9} {:>9}\n", "object", "real cm",
                            "model cm", "error mm", "U mm");
      for (const auto& r : rows) {
        if (!r.not_measured.empty()) {
          result += fmt::format("{:<18} {:>10.2f} not measured: {}\n", r.name, 100 * r.real_m,
                                r.not_measured);
          continue;
        }
        // A row whose end kept the picked point is never "within U" (nothing but the mesh fixes it).
        const char* verdict = !r.ends_snapped         ? "(an end not snapped: not within U)"
                              : r.within_uncertainty ? ""
                                                     : "(outside U)";
        result += fmt::format("{:<18} {:>10.2f} {:>10.2f} {:>9.1f} {:>9.1f} {}\n", r.name,
                              100 * r.real_m, 100 * r.model_m, 1000 * r.error_m,
                              1000 * r.expanded_uncertainty_m, verdict);
      }
    }
    step.step = "measure reference";
    params["reference"] = fs::absolute(o.reference).string();
    step.inputs = {fs::absolute(o.reference)};
    step.outputs = {"measurements/reference.json", "measurements/table.json",
                    "measurements/table.csv"};
  } else {
    const fx::CaseModel model = fx::CaseModel::load(folder);
    std::vector<fs::path> written;
    const std::string name = o.name.empty() ? "measurement" : o.name;
    if (!o.from.empty() || !o.to.empty()) {
      if (o.from.empty() || o.to.empty()) throw InputError("--from and --to go together");
      const auto a = parse_case_point(o.from, markers, o.frame), b = parse_case_point(o.to, markers, o.frame);
      const auto m = fx::measure_point_to_point(model, a, b, so);
      written = fx::append_measurement(folder, name, m);
      result += fmt::format("{}: {:.4f} m +- {:.4f} m (k=2); ends {} and {}\n", name,
                            m.distance_m, m.expanded_uncertainty_m, fx::to_string(m.a.feature),
                            fx::to_string(m.b.feature));
      for (const auto& [end, p] : {std::pair{"from", &m.a}, std::pair{"to", &m.b}})
        if (!fx::is_snapped(p->feature))
          result += fmt::format("warning: the --{} end is {}; the distance is only as good as "
                                "that pick: U holds the end only to the mesh there (within the "
                                "fusion's {:.0f} mm truncation band along the line), not to a feature\n",
                                end, fx::describe(p->feature), 1000 * model.model_truncation_m());
      params["kind"] = "point_to_point";
      params["from"] = o.from;
      params["to"] = o.to;
    } else if (!o.point.empty() && !o.plane.empty()) {
      const auto p = parse_case_point(o.point, markers, o.frame), q = parse_case_point(o.plane, markers, o.frame);
      const auto m = fx::measure_point_to_plane(model, p, q, o.plane_radius, so);
      written = fx::append_measurement(folder, name, m);
      result += fmt::format("{}: {:.4f} m +- {:.4f} m (k=2) from the plane\n", name,
                            m.distance_m, m.expanded_uncertainty_m);
      params["kind"] = "point_to_plane";
      params["point"] = o.point;
      params["plane"] = o.plane;
    } else if (!o.plane.empty() && !o.plane2.empty()) {
      const auto q = parse_case_point(o.plane, markers, o.frame), r = parse_case_point(o.plane2, markers, o.frame);
      const auto m = fx::measure_plane_angle(model, q, r, o.plane_radius, so);
      written = fx::append_measurement(folder, name, m);
      result += fmt::format("{}: {:.2f} deg +- {:.2f} deg (k=2)\n", name, m.angle_deg,
                            m.expanded_uncertainty_deg);
      params["kind"] = "plane_angle";
      params["plane"] = o.plane;
      params["plane2"] = o.plane2;
    } else {
      throw InputError("say what to measure: --from A --to B, --point P --plane Q, --plane Q "
                       "--plane2 R, or --reference FILE");
    }
    params["name"] = name;
    step.step = "measure";
    step.outputs = written;
  }
  step.parameters_json = params.dump();
  step.inputs.push_back("mesh/mesh.ply");
  step.duration_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  change.commit(step);
  if (!o.no_report) fx::refresh_case_report(folder);
  fmt::print("{}", result);
  print_log_head(folder.root());
  return 0;
}

}  // namespace

void register_measure(CLI::App& app, GlobalOptions& global) {
  auto o = std::make_shared<MeasureCli>();
  CLI::App* cmd = app.add_subcommand(
      "measure", "Measure on a case's model with uncertainty: point to point, point to plane, "
                 "angle between planes, or a reference file (Table I)");
  cmd->add_option("case", o->case_dir, "Case folder")->required();
  cmd->add_option("--name", o->name, "Name of the measurement");
  cmd->add_option("--from", o->from, "First point: x,y,z or a marker");
  cmd->add_option("--to", o->to, "Second point: x,y,z or a marker");
  cmd->add_option("--point", o->point, "Point for a point-to-plane distance");
  cmd->add_option("--plane", o->plane, "A point on the (first) plane");
  cmd->add_option("--plane2", o->plane2, "A point on the second plane (angle)");
  cmd->add_option("--reference", o->reference, "Reference file: name, a, b, distance_m");
  cmd->add_option("--radius", o->radius, "Snapping radius (m)")->capture_default_str();
  cmd->add_option("--plane-radius", o->plane_radius, "Plane fitting radius (m)")
      ->capture_default_str();
  cmd->add_flag("--no-report", o->no_report, "Do not rewrite the report");
  add_point_frame_option(cmd, o->frame);
  set_runner(cmd, [o, &global] { return run_measure(*o, global); });
}

}  // namespace locard::cli
