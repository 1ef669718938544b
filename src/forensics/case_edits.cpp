#include <locard/forensics/case_edits.hpp>

#include "forensics/json_util.hpp"

#include <locard/core/error.hpp>
#include <locard/forensics/case_measurements.hpp>
#include <locard/forensics/evidence_markers.hpp>
#include <locard/forensics/trajectory_analysis.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <vector>

namespace locard::forensics {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr std::size_t kMaxNameLength = 200;
constexpr std::size_t kMaxReasonLength = 2000;

const fs::path kMarkersJson = "evidence/markers.json";
const fs::path kMarkersCsv = "evidence/markers.csv";
const fs::path kTrajectoriesJson = "trajectories/analyses.json";
const fs::path kTrajectoriesCsv = "trajectories/analyses.csv";

void check_request(const CaseEdit& e) {
  if (e.edit == CaseEditKind::Rename) {
    if (e.new_name.empty()) throw InputError("a rename needs the new name");
    if (e.new_name.size() > kMaxNameLength)
      throw InputError(fmt::format("the new name is longer than {} characters", kMaxNameLength));
  } else {
    if (e.reason.empty()) throw InputError("a withdrawal needs a reason (it is kept with the object)");
    if (e.reason.size() > kMaxReasonLength)
      throw InputError(fmt::format("the reason is longer than {} characters", kMaxReasonLength));
  }
}

// The index of the one object `which` names among `names`: "#N" by position, else by name.
std::size_t pick(const std::vector<std::string>& names, const std::string& which,
                 std::string_view kind) {
  if (which.size() > 1 && which.front() == '#') {
    std::size_t used = 0;
    long n = 0;
    try {
      n = std::stol(which.substr(1), &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used + 1 != which.size() || n < 1 || static_cast<std::size_t>(n) > names.size())
      throw InputError(fmt::format("no {} {} (the case has {})", kind, which, names.size()));
    return static_cast<std::size_t>(n - 1);
  }
  std::vector<std::size_t> hits;
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == which) hits.push_back(i);
  if (hits.empty()) throw InputError(fmt::format("no {} named '{}' in this case", kind, which));
  if (hits.size() > 1) {
    std::string where;
    for (std::size_t i : hits) where += fmt::format("{}#{}", where.empty() ? "" : ", ", i + 1);
    throw InputError(fmt::format("{} {} {}s are named '{}' ({}): say which by position", hits.size(),
                                 kind, kind, which, where));
  }
  return hits.front();
}

// Renames or withdraws one object's revisions; `name` is its current name.
void revise(Revisions& r, std::string& name, const CaseEdit& e, std::string_view kind,
            const std::vector<std::string>& names_in_use) {
  if (r.withdrawn())
    throw InputError(fmt::format("{} '{}' was withdrawn already ({})", kind, name, r.status()));
  if (e.edit == CaseEditKind::Withdraw) {
    r.withdrawn_reason = e.reason;
    r.withdrawn_at = utc_now_iso8601();
    return;
  }
  if (e.new_name == name) throw InputError(fmt::format("{} is named '{}' already", kind, name));
  for (const std::string& other : names_in_use)
    if (other == e.new_name)
      throw InputError(fmt::format("another {} is named '{}' already", kind, e.new_name));
  r.previous_names.push_back(name);
  name = e.new_name;
}

std::string describe(const CaseEdit& e, std::string_view what, const std::string& old_name,
                     const std::string& new_name) {
  if (e.edit == CaseEditKind::Withdraw)
    return fmt::format("{} '{}' withdrawn: {}", what, old_name, e.reason);
  return fmt::format("{} renamed '{}' (was '{}')", what, new_name, old_name);
}

struct Applied {
  std::vector<fs::path> outputs;
  std::string summary;
  json identity;  // what the log records of the object edited
};

Applied edit_marker(CaseFolder& folder, const CaseEdit& e) {
  MarkerSet set = read_markers(folder.path(kMarkersJson));
  EvidenceMarker* m = set.find(e.which);
  if (!m) throw InputError(fmt::format("no marker '{}' in this case (see `locard marker list`)", e.which));
  std::vector<std::string> labels;
  for (const EvidenceMarker& other : set.markers)
    if (other.number != m->number) labels.push_back(other.label);
  const std::string old_label = m->label;
  revise(m->revisions, m->label, e, "marker", labels);
  write_markers(folder.path(kMarkersJson), set);
  return {{kMarkersJson, kMarkersCsv},
          describe(e, fmt::format("marker {}", m->number), old_label, m->label),
          {{"number", m->number}, {"label", old_label}}};
}

Applied edit_measurement(CaseFolder& folder, const CaseEdit& e) {
  std::vector<CaseMeasurement> all = read_case_measurements(folder.path(kCaseMeasurementsJson));
  std::vector<std::string> names;
  for (const CaseMeasurement& m : all) names.push_back(m.name);
  const std::size_t i = pick(names, e.which, "measurement");
  std::vector<std::string> others = names;
  others.erase(others.begin() + static_cast<std::ptrdiff_t>(i));
  revise(all[i].revisions, all[i].name, e, "measurement", others);
  write_case_measurements(folder.path(kCaseMeasurementsJson), all);
  return {{kCaseMeasurementsJson, kCaseMeasurementsCsv},
          describe(e, fmt::format("measurement #{}", i + 1), names[i], all[i].name),
          {{"position", i + 1}, {"name", names[i]}}};
}

Applied edit_trajectory(CaseFolder& folder, const CaseEdit& e) {
  std::vector<TrajectoryAnalysis> all = read_trajectory_analyses(folder.path(kTrajectoriesJson));
  std::vector<std::string> names;
  for (const TrajectoryAnalysis& a : all) names.push_back(a.name);
  const std::size_t i = pick(names, e.which, "trajectory");
  std::vector<std::string> others = names;
  others.erase(others.begin() + static_cast<std::ptrdiff_t>(i));
  revise(all[i].revisions, all[i].name, e, "trajectory", others);
  write_trajectory_analyses(folder.path(kTrajectoriesJson), all);
  return {{kTrajectoriesJson, kTrajectoriesCsv},
          describe(e, fmt::format("trajectory #{}", i + 1), names[i], all[i].name),
          {{"position", i + 1}, {"name", names[i]}}};
}

// Every file an edit of this kind may write (kept aside until its step is logged).
std::vector<fs::path> files_of(CaseObjectKind kind) {
  switch (kind) {
    case CaseObjectKind::Marker: return {kMarkersJson, kMarkersCsv};
    case CaseObjectKind::Measurement: return {kCaseMeasurementsJson, kCaseMeasurementsCsv};
    case CaseObjectKind::Trajectory: return {kTrajectoriesJson, kTrajectoriesCsv};
  }
  return {};
}

}  // namespace

std::string_view to_string(CaseObjectKind kind) {
  switch (kind) {
    case CaseObjectKind::Marker: return "marker";
    case CaseObjectKind::Measurement: return "measurement";
    case CaseObjectKind::Trajectory: return "trajectory";
  }
  return "?";
}

std::optional<CaseObjectKind> parse_case_object_kind(std::string_view text) {
  for (CaseObjectKind k :
       {CaseObjectKind::Marker, CaseObjectKind::Measurement, CaseObjectKind::Trajectory})
    if (text == to_string(k)) return k;
  return std::nullopt;
}

std::string case_objects_csv(const CaseFolder& folder, CaseObjectKind kind) {
  switch (kind) {
    case CaseObjectKind::Marker: return markers_csv(read_markers(folder.path(kMarkersJson)));
    case CaseObjectKind::Measurement:
      return case_measurements_csv(read_case_measurements(folder.path(kCaseMeasurementsJson)));
    case CaseObjectKind::Trajectory:
      return trajectory_analyses_csv(read_trajectory_analyses(folder.path(kTrajectoriesJson)));
  }
  return {};
}

CaseEditResult apply_case_edit(CaseFolder& folder, const CaseEdit& e) {
  const auto t0 = std::chrono::steady_clock::now();
  check_request(e);
  CaseChange change(folder, files_of(e.object));
  Applied applied;
  switch (e.object) {
    case CaseObjectKind::Marker: applied = edit_marker(folder, e); break;
    case CaseObjectKind::Measurement: applied = edit_measurement(folder, e); break;
    case CaseObjectKind::Trajectory: applied = edit_trajectory(folder, e); break;
  }
  LogStep step;
  step.step = fmt::format("{} {}", to_string(e.object),
                          e.edit == CaseEditKind::Rename ? "rename" : "withdraw");
  json params = {{"source", e.source}, {"which", e.which}, {"object", applied.identity}};
  if (e.edit == CaseEditKind::Rename) params["new_name"] = e.new_name;
  else params["reason"] = e.reason;
  step.parameters_json = params.dump();
  step.outputs = applied.outputs;
  step.duration_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  CaseEditResult result;
  result.log_seq = change.commit(step);
  result.summary = applied.summary;
  return result;
}

}  // namespace locard::forensics
