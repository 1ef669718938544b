// Table I: the reference (tape) file, each of its distances measured on the model and
// compared, and the table files (measurements/table.json, table.csv).
#include <locard/forensics/measurement.hpp>

#include "forensics/case_measurements_json.hpp"
#include "forensics/csv_field.hpp"
#include "forensics/json_util.hpp"
#include "io/json_file.hpp"

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/case_measurements.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <set>

namespace locard::forensics {
namespace {
using Eigen::Vector3d;
}  // namespace

std::vector<ReferenceMeasurement> read_reference_measurements(
    const std::filesystem::path& path,
    const std::function<std::optional<Vector3d>(const std::string&)>& marker_lookup) {
  // Regular files only; syntax errors and numbers out of range (1e400) alike are InputErrors
  // naming the file (only parse_error was caught here once: reference_fuzz found -1e400).
  const nlohmann::json j = io_detail::read_json_file(path);
  if (!j.is_object() || !j.contains("measurements") || !j["measurements"].is_array())
    throw_input_error(path, "expected {\"measurements\": [{\"name\", \"a\", \"b\", "
                            "\"distance_m\"}, ...]}");
  static const std::set<std::string> known = {"name", "a", "b", "distance_m", "source", "note"};
  std::vector<ReferenceMeasurement> out;
  std::set<std::string> names;
  std::size_t index = 0;
  for (const auto& m : j["measurements"]) {
    const std::string where = fmt::format("{}: measurements[{}]", path.string(), index++);
    if (!m.is_object()) throw InputError(where + ": expected an object");
    for (const auto& [key, value] : m.items())
      if (!known.count(key))
        throw InputError(fmt::format("{}: unknown key '{}' (expected name, a, b, distance_m, "
                                     "source, note)",
                                     where, key));
    if (!m.contains("name") || !m["name"].is_string() || m["name"].get<std::string>().empty())
      throw InputError(where + ": \"name\" (a non-empty string) is required");
    ReferenceMeasurement r;
    r.name = m["name"].get<std::string>();
    if (!names.insert(r.name).second)
      throw InputError(fmt::format("{} \"{}\": duplicate name", where, r.name));
    const std::string named = fmt::format("{} \"{}\"", where, r.name);
    for (const char* key : {"a", "b"}) {
      if (!m.contains(key)) throw InputError(fmt::format("{}: \"{}\" is required", named, key));
      Vector3d v;
      if (m[key].is_string()) {
        const std::string marker = m[key].get<std::string>();
        const std::optional<Vector3d> found =
            marker_lookup ? marker_lookup(marker) : std::optional<Vector3d>{};
        if (!found)
          throw InputError(fmt::format("{}: \"{}\" names marker '{}', which the case does not "
                                       "have (see evidence/markers.csv)",
                                       named, key, marker));
        v = *found;
      } else {
        v = json_vec3(m[key], fmt::format("{}: \"{}\"", named, key));
      }
      (key[0] == 'a' ? r.a : r.b) = v;
    }
    if (!m.contains("distance_m") || !m["distance_m"].is_number() ||
        !(m["distance_m"].get<double>() > 0))
      throw InputError(named + ": \"distance_m\" (the tape value, a positive number) is required");
    r.true_distance_m = m["distance_m"].get<double>();
    out.push_back(r);
  }
  if (out.empty()) throw_input_error(path, "no measurements listed");
  return out;
}

std::vector<TableRow> compare_with_reference(const CaseModel& model,
                                             const std::vector<ReferenceMeasurement>& reference,
                                             const SnapOptions& options) {
  std::vector<TableRow> rows;
  for (const ReferenceMeasurement& r : reference) {
    TableRow row;
    row.name = r.name;
    row.real_m = r.true_distance_m;
    try {
      row.detail = measure_point_to_point(model, r.a, r.b, options);
    } catch (const InputError& e) {
      throw InputError(fmt::format("reference measurement \"{}\": {}", r.name, e.what()));
    }
    row.model_m = row.detail.distance_m;
    row.error_m = row.model_m - row.real_m;
    row.expanded_uncertainty_m = row.detail.expanded_uncertainty_m;
    row.ends_snapped = is_snapped(row.detail.a.feature) && is_snapped(row.detail.b.feature);
    row.within_uncertainty = row.ends_snapped && std::abs(row.error_m) <= row.expanded_uncertainty_m;
    rows.push_back(std::move(row));
  }
  return rows;
}

void write_measurement_table(const CaseFolder& folder, const std::vector<TableRow>& rows) {
  nlohmann::json j = {{"coverage_factor", rows.empty() ? 2.0 : rows[0].detail.coverage_factor},
                      {"units", "m"},
                      {"rows", nlohmann::json::array()}};
  std::string csv = "name,real_m,model_m,error_m,expanded_uncertainty_m,within_uncertainty,"
                    "a_feature,b_feature\n";
  for (const TableRow& r : rows) {
    if (!r.not_measured.empty()) {
      j["rows"].push_back({{"name", r.name}, {"real_m", r.real_m}, {"not_measured", r.not_measured}});
      csv += fmt::format("{},{:.5f},,,,not measured,,\n", csv_field(r.name), r.real_m);
      continue;
    }
    j["rows"].push_back({{"name", r.name},
                         {"real_m", r.real_m},
                         {"model_m", r.model_m},
                         {"error_m", r.error_m},
                         {"expanded_uncertainty_m", r.expanded_uncertainty_m},
                         {"within_uncertainty", r.within_uncertainty},
                         {"ends_snapped", r.ends_snapped},
                         {"measurement", measurement_content_json(case_measurement("", r.detail))}});
    csv += fmt::format("{},{:.5f},{:.5f},{:.5f},{:.5f},{},{},{}\n", csv_field(r.name), r.real_m,
                       r.model_m, r.error_m, r.expanded_uncertainty_m,
                       !r.ends_snapped ? "not snapped" : r.within_uncertainty ? "yes" : "no",
                       to_string(r.detail.a.feature), to_string(r.detail.b.feature));
  }
  {
    AtomicFile f(folder.path("measurements/table.json"), false);
    f.stream() << j.dump(1) << '\n';
    f.commit();
  }
  AtomicFile f(folder.path("measurements/table.csv"), false);
  f.stream() << csv;
  f.commit();
}

}  // namespace locard::forensics
