// The stages every kind of input shares (see reconstruct_stages.hpp).
#include "forensics/reconstruct_stages.hpp"

#include <locard/core/error.hpp>
#include <locard/forensics/case_model.hpp>
#include <locard/forensics/report.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <fstream>
#include <sstream>

namespace locard::forensics::detail {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// One reference distance; a reference point the scan did not cover is reported, not fatal.
TableRow measure_one(const CaseModel& model, const ReferenceMeasurement& ref,
                     const SnapOptions& so, const StageHooks& hooks) {
  try {
    auto one = compare_with_reference(model, {ref}, so);
    return std::move(one[0]);
  } catch (const InputError& e) {
    TableRow row;
    row.name = ref.name;
    row.real_m = ref.true_distance_m;
    row.not_measured = e.what();
    hooks.note(fmt::format("warning: {}", e.what()));
    return row;
  }
}

void log_phase(CaseFolder& folder, StepPhase phase, const json& parameters) {
  LogStep s;
  s.step = "reconstruct";
  s.phase = phase;
  s.parameters_json = parameters.dump();
  folder.append_log_step(s);
}

}  // namespace

std::vector<fs::path> write_mesh_files(CaseFolder& folder, const TriangleMesh& mesh,
                                       const std::vector<MeshFormat>& formats, UpAxis up) {
  std::vector<fs::path> outputs;
  MeshExportOptions options;
  options.up = up;
  for (MeshFormat f : formats) {
    const fs::path rel = fmt::format("mesh/mesh.{}", to_string(f));
    // Every file a format writes (an OBJ's .mtl and texture too), beside the named one.
    for (const fs::path& written : write_mesh(folder.path(rel), mesh, options))
      outputs.push_back(rel.parent_path() / written.filename());
  }
  if (std::find(formats.begin(), formats.end(), MeshFormat::Ply) == formats.end()) {
    write_mesh(folder.path("mesh/mesh.ply"), mesh);  // measurements need it
    outputs.push_back("mesh/mesh.ply");
  }
  return outputs;
}

void run_measure_stage(CaseFolder& folder, const fs::path& reference,
                       const std::vector<ReferenceMeasurement>& refs,
                       const ReconstructParameters& P, const StageHooks& hooks,
                       ReconstructSummary& summary) {
  if (refs.empty()) return;
  const auto t0 = Clock::now();
  const CaseModel model = CaseModel::load(folder);
  SnapOptions so;
  so.search_radius_m = P.snap_radius_m;
  auto progress = hooks.begin("measure", refs.size());
  std::vector<TableRow> rows;
  for (std::size_t i = 0; i < refs.size(); ++i) {
    rows.push_back(measure_one(model, refs[i], so, hooks));
    if (progress) progress(i + 1, refs.size());
  }
  hooks.end("measure");
  {
    std::ifstream in(reference, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    write_text(folder.path("measurements/reference.json"), ss.str());
  }
  write_measurement_table(folder, rows);
  summary.measurements = rows.size();
  for (const TableRow& r : rows) {
    summary.measurements_within += r.within_uncertainty;
    summary.measurements_not_measured += !r.not_measured.empty();
    summary.measurements_not_snapped += r.not_measured.empty() && !r.ends_snapped;
  }
  LogStep s;
  s.step = "measure reference";
  s.parameters_json = json{{"reference", fs::absolute(reference).string()},
                           {"snap_radius_m", so.search_radius_m},
                           {"coverage_factor", so.coverage_factor}}.dump();
  s.duration_s = seconds_since(t0);
  s.inputs = {fs::absolute(reference), "mesh/mesh.ply", "alignment/pose_covariance.json"};
  s.outputs = {"measurements/reference.json", "measurements/table.json", "measurements/table.csv"};
  folder.append_log_step(s);
  summary.stage_seconds.emplace_back("measure", seconds_since(t0));
}

void run_report_stage(CaseFolder& folder, const std::string& title, const ReconstructParameters& P,
                      const StageHooks& hooks, ReconstructSummary& summary) {
  const auto t0 = Clock::now();
  hooks.begin("report", 0);
  ReportOptions ro;
  ro.title = title;
  ro.render_width = P.render_width;
  ro.render_height = P.render_height;
  ro.pdf = P.pdf;
  ro.paper = P.paper;
  const ReportResult report = write_case_report(folder, ro);
  hooks.end("report");
  if (!report.pdf_note.empty()) hooks.note(report.pdf_note);
  LogStep s;
  s.step = "report";
  s.parameters_json = json{{"pdf", P.pdf}, {"render_size", {P.render_width, P.render_height}},
                           {"pdf_note", report.pdf_note}}.dump();
  s.duration_s = seconds_since(t0);
  s.outputs = {"report/report.html"};
  if (report.pdf) s.outputs.push_back("report/report.pdf");
  folder.append_log_step(s);
  summary.stage_seconds.emplace_back("report", seconds_since(t0));
  summary.report_html = report.html;
  summary.report_pdf = report.pdf;
}

// The bracket around the stages: "begin" before anything else (a case killed at any point
// after it reads as incomplete), "failed" with the error when a stage throws, "complete" last.
ReconstructSummary run_bracketed(const fs::path& input_root, const fs::path& case_dir, bool force,
                                 const std::function<void(CaseFolder&, ReconstructSummary&)>& stages) {
  const auto start = Clock::now();
  CaseFolder folder = CaseFolder::create(case_dir, force);
  log_phase(folder, StepPhase::Begin,
            {{"input", input_root.string()}, {"software_version", software_version()}});
  ReconstructSummary summary;
  summary.case_dir = case_dir;
  try {
    stages(folder, summary);
  } catch (const std::exception& e) {
    try {
      log_phase(folder, StepPhase::Failed, {{"error", e.what()}});
    } catch (const std::exception&) {
      // The log cannot take the failure (a full disk): the case still reads as incomplete.
    }
    throw;
  }
  summary.seconds = seconds_since(start);
  log_phase(folder, StepPhase::Complete,
            {{"seconds", summary.seconds},
             {"registered", summary.registered},
             {"verified", summary.verified},
             {"enough_verified", summary.enough_verified}});
  return summary;
}

}  // namespace locard::forensics::detail

namespace locard::forensics {

std::string_view to_string(ScanPoseSource source) {
  return source == ScanPoseSource::Global ? "global" : "input";
}

std::optional<ScanPoseSource> parse_scan_pose_source(std::string_view name) {
  if (name == "input") return ScanPoseSource::Input;
  if (name == "global") return ScanPoseSource::Global;
  return std::nullopt;
}

std::string_view to_string(WorldFrameChoice choice) {
  return choice == WorldFrameChoice::FirstCamera ? "first-camera" : "auto";
}

std::optional<WorldFrameChoice> parse_world_frame_choice(std::string_view name) {
  if (name == "auto") return WorldFrameChoice::Auto;
  if (name == "first-camera") return WorldFrameChoice::FirstCamera;
  return std::nullopt;
}

std::string mesh_formats_text(const std::vector<MeshFormat>& formats) {
  std::string text;
  for (MeshFormat f : formats) text += (text.empty() ? "" : ",") + std::string(to_string(f));
  return text;
}

std::vector<MeshFormat> parse_mesh_formats(std::string_view text) {
  std::vector<MeshFormat> formats;
  std::stringstream ss{std::string(text)};
  std::string name;
  while (std::getline(ss, name, ','))
    if (const auto f = parse_mesh_format(name)) formats.push_back(*f);
    else throw InputError(fmt::format("formats: unknown mesh format '{}'", name));
  return formats;
}

}  // namespace locard::forensics
