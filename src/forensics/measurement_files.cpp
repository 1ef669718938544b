#include "forensics/measurement_files.hpp"

#include "forensics/csv_field.hpp"
#include "forensics/revisions_json.hpp"

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>

#include <fmt/format.h>

#include <fstream>

namespace locard::forensics {

using nlohmann::json;

json read_measurements_file(const std::filesystem::path& path) {
  json all = {{"measurements", json::array()}};
  if (!std::filesystem::exists(path)) return all;
  std::ifstream in(path);
  try {
    all = json::parse(in);
  } catch (const json::exception& e) {  // syntax, and numbers out of range (1e400)
    throw_input_error(path, fmt::format("not valid JSON: {}", e.what()));
  }
  const auto list = all.is_object() ? all.find("measurements") : all.end();
  if (list == all.end() || !list->is_array())
    throw_input_error(path, "expected {\"measurements\": [...]}");
  for (std::size_t i = 0; i < list->size(); ++i) {
    const json& m = (*list)[i];
    const std::string where = fmt::format("{}: measurement {}", path.string(), i + 1);
    if (!m.is_object() || !m.contains("name") || !m["name"].is_string())
      throw InputError(where + ": expected an object with a text 'name'");
    get_revisions(m, where);  // wrong types are named here, not later
  }
  return all;
}

namespace {

double number_or_nan(const json& m, const char* key) {
  const auto it = m.find(key);
  return it != m.end() && it->is_number() ? it->get<double>() : std::nan("");
}

std::string feature_of(const json& m, const char* end) {
  const auto it = m.find(end);
  if (it == m.end() || !it->is_object()) return "";
  const auto f = it->find("feature");
  return f != it->end() && f->is_string() ? f->get<std::string>() : "";
}

}  // namespace

std::string measurements_csv(const json& all) {
  std::string out = "name,kind,value,unit,expanded_uncertainty,a_feature,b_feature,created,"
                    "status,previous_names\n";
  for (const json& m : all["measurements"]) {
    const std::string kind = m.value("kind", "");
    const bool angle = kind == "plane_angle";
    const double value = number_or_nan(m, angle ? "angle_deg" : "distance_m");
    const double u = number_or_nan(m, angle ? "expanded_uncertainty_deg" : "expanded_uncertainty_m");
    const std::string a = kind == "point_to_plane" ? feature_of(m, "point") : feature_of(m, "a");
    const std::string b = kind == "point_to_plane" ? "plane" : feature_of(m, "b");
    const Revisions r = get_revisions(m, "measurement");
    out += fmt::format("{},{},{:.5f},{},{:.5f},{},{},{},{},{}\n", csv_field(m.value("name", "")),
                       csv_field(kind), value, angle ? "deg" : "m", u, csv_field(a), csv_field(b),
                       csv_field(m.value("created", "")), csv_field(r.status()),
                       csv_field(r.previous_names_text()));
  }
  return out;
}

void write_measurements_files(const std::filesystem::path& path, const json& all) {
  std::filesystem::create_directories(path.parent_path());
  {
    AtomicFile f(path, false);
    f.stream() << all.dump(1) << '\n';
    f.commit();
  }
  AtomicFile f(std::filesystem::path(path).replace_extension(".csv"), false);
  f.stream() << measurements_csv(all);
  f.commit();
}

}  // namespace locard::forensics
