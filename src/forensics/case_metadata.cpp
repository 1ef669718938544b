#include <locard/forensics/case_metadata.hpp>

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <fstream>

namespace locard::forensics {
namespace {

using nlohmann::json;

constexpr std::size_t kMaxField = 500;

json read_case_json(const CaseFolder& folder) {
  const auto path = folder.root() / "case.json";
  std::ifstream in(path);
  if (!in) throw_input_error(path, "cannot read the case's case.json");
  try {
    json j = json::parse(in);
    if (!j.is_object()) throw_input_error(path, "expected a JSON object");
    return j;
  } catch (const json::exception& e) {
    throw_input_error(path, fmt::format("not valid JSON: {}", e.what()));
  }
}

// A calendar date YYYY-MM-DD (the proleptic Gregorian calendar, years 1900-2999).
bool is_iso_date(const std::string& d) {
  if (d.size() != 10 || d[4] != '-' || d[7] != '-') return false;
  for (std::size_t i : {0, 1, 2, 3, 5, 6, 8, 9})
    if (d[i] < '0' || d[i] > '9') return false;
  const int y = std::stoi(d.substr(0, 4)), m = std::stoi(d.substr(5, 2)), day = std::stoi(d.substr(8, 2));
  if (y < 1900 || y > 2999 || m < 1 || m > 12 || day < 1) return false;
  const std::chrono::year_month_day ymd{std::chrono::year(y), std::chrono::month(static_cast<unsigned>(m)),
                                        std::chrono::day(static_cast<unsigned>(day))};
  return ymd.ok();
}

void check_field(const char* name, const std::string& value) {
  if (value.size() > kMaxField)
    throw InputError(fmt::format("--{}: longer than {} characters", name, kMaxField));
  for (char c : value)
    if (static_cast<unsigned char>(c) < 0x20)
      throw InputError(fmt::format("--{}: holds a control character", name));
}

}  // namespace

CaseMetadata read_case_metadata(const CaseFolder& folder) {
  const json j = read_case_json(folder);
  CaseMetadata m;
  const auto it = j.find("metadata");
  if (it == j.end()) return m;
  const std::string where = (folder.root() / "case.json").string() + ": metadata";
  if (!it->is_object()) throw InputError(where + ": expected an object");
  const auto field = [&](const char* key, std::string& out) {
    const auto f = it->find(key);
    if (f == it->end()) return;
    if (!f->is_string()) throw InputError(fmt::format("{}.{}: expected text", where, key));
    out = f->get<std::string>();
  };
  field("case_number", m.number);
  field("investigator", m.investigator);
  field("location", m.location);
  field("date", m.date);
  return m;
}

std::size_t set_case_metadata(CaseFolder& folder, const CaseMetadataUpdate& u,
                              const std::string& source) {
  const auto t0 = std::chrono::steady_clock::now();
  json changed = json::object();
  const std::pair<const char*, const std::optional<std::string>*> fields[] = {
      {"case_number", &u.number}, {"investigator", &u.investigator},
      {"location", &u.location},  {"date", &u.date}};
  for (const auto& [key, value] : fields)
    if (*value) {
      check_field(key, **value);
      changed[key] = **value;
    }
  if (u.date && !u.date->empty() && !is_iso_date(*u.date))
    throw InputError(fmt::format("--date: '{}' is not a date as YYYY-MM-DD", *u.date));
  if (changed.empty())
    throw InputError("nothing to set: give --number, --investigator, --location or --date");
  CaseChange change(folder, {"case.json"});
  json j = read_case_json(folder);
  json& metadata = j["metadata"];
  if (!metadata.is_object()) metadata = json::object();
  for (const auto& [key, value] : changed.items()) {
    if (value.get<std::string>().empty()) metadata.erase(key);
    else metadata[key] = value;
  }
  {
    AtomicFile f(folder.path("case.json"), false);
    f.stream() << j.dump(2) << '\n';
    f.commit();
  }
  LogStep step;
  step.step = "case set";
  step.parameters_json = json{{"source", source}, {"metadata", changed}}.dump();
  step.outputs = {"case.json"};
  step.duration_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return change.commit(step);
}

}  // namespace locard::forensics
