// The case's ad-hoc measurements: one reader, one writer (see case_measurements.hpp).
#include <locard/forensics/case_measurements.hpp>

#include "forensics/case_measurements_json.hpp"
#include "forensics/csv_field.hpp"
#include "forensics/json_util.hpp"
#include "forensics/revisions_json.hpp"
#include "io/json_file.hpp"

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/io/strict_json.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <utility>

namespace locard::forensics {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr MeasurementKind kKinds[] = {MeasurementKind::PointToPoint, MeasurementKind::PointToPlane,
                                      MeasurementKind::PlaneAngle};
// Every SnapFeature (measurement.hpp): a feature missing here could be written but not read.
constexpr SnapFeature kFeatures[] = {SnapFeature::Face,          SnapFeature::Edge,
                                     SnapFeature::Corner,        SnapFeature::EdgeOutermost,
                                     SnapFeature::CornerOutermost, SnapFeature::MeshSurface,
                                     SnapFeature::NotSnapped};

// --- reading ---------------------------------------------------------------------------------

std::size_t count_at(StrictObject& o, const std::string& key) {
  const json& v = o.required(key);
  if (!v.is_number_unsigned())
    o.fail(fmt::format("{}: expected a whole number >= 0, found {}", o.place(key),
                       v.is_number() ? v.dump() : StrictObject::type_phrase(v)));
  return v.get<std::size_t>();
}

double non_negative_at(StrictObject& o, const std::string& key) {
  const double x = o.number(key);
  if (x < 0.0)
    o.fail(fmt::format("{}: expected a number >= 0, found {}", o.place(key),
                       StrictObject::number_text(x)));
  return x;
}

template <typename Enum, std::size_t N>
Enum one_of(StrictObject& o, const std::string& key, const Enum (&values)[N]) {
  const std::string text = o.string(key);
  std::string known;
  for (Enum v : values) {
    if (to_string(v) == text) return v;
    known += fmt::format("{}\"{}\"", known.empty() ? "" : ", ", to_string(v));
  }
  o.fail(fmt::format("{}: unknown {} \"{}\" (expected one of: {})", o.place(key), key, text, known));
}

MeasuredEnd read_end(StrictObject& parent, const std::string& key, const fs::path& file) {
  StrictObject o(parent.required(key), parent.place(key), file);
  MeasuredEnd e;
  e.given = o.vec3("given");
  e.snapped = o.vec3("snapped");
  e.feature = one_of(o, "feature", kFeatures);
  if (const json* s = o.optional("snapped_to_feature")) {
    if (!s->is_boolean())
      o.fail(o.place("snapped_to_feature") + ": expected true or false, found " +
             StrictObject::type_phrase(*s));
    e.snapped_to_feature = s->get<bool>();
    if (*e.snapped_to_feature != is_snapped(e.feature))
      o.fail(fmt::format("{}: {} contradicts the feature \"{}\"", o.place("snapped_to_feature"),
                         *e.snapped_to_feature, to_string(e.feature)));
  }
  e.views = count_at(o, "views");
  e.points = count_at(o, "points");
  e.planes = count_at(o, "planes");
  e.standard_uncertainty_m = non_negative_at(o, "standard_uncertainty_m");
  o.finish();
  return e;
}

MeasuredPlane read_plane(StrictObject& parent, const std::string& key, const fs::path& file) {
  StrictObject o(parent.required(key), parent.place(key), file);
  MeasuredPlane p;
  p.point = o.vec3("point");
  p.normal = o.vec3("normal");
  p.rms_m = non_negative_at(o, "rms_m");
  p.points = count_at(o, "points");
  p.offset_sigma_m = non_negative_at(o, "offset_sigma_m");
  p.normal_sigma_deg = non_negative_at(o, "normal_sigma_deg");
  o.finish();
  return p;
}

// The value and its uncertainties under the kind's keys (`unit`: "m" or "deg").
void read_value(StrictObject& o, const std::string& value_key, const std::string& unit,
                CaseMeasurement& m) {
  m.value = o.number(value_key);
  m.standard_uncertainty = non_negative_at(o, "standard_uncertainty_" + unit);
  m.expanded_uncertainty = non_negative_at(o, "expanded_uncertainty_" + unit);
}

// `number` counts from 1; the place named in messages carries the name once it is known.
CaseMeasurement read_measurement(const json& j, std::size_t number, const fs::path& file) {
  std::string where = fmt::format("measurement {}", number);
  if (j.is_object() && j.contains("name") && j["name"].is_string())
    where += fmt::format(" \"{}\"", j["name"].get<std::string>());
  StrictObject o(j, where, file);
  CaseMeasurement m;
  m.name = o.string("name");
  if (m.name.empty()) o.fail(o.place("name") + ": expected a name, found an empty string");
  m.kind = one_of(o, "kind", kKinds);
  m.created = o.string("created");
  switch (m.kind) {
    case MeasurementKind::PointToPoint:
      m.a = read_end(o, "a", file);
      m.b = read_end(o, "b", file);
      read_value(o, "distance_m", "m", m);
      m.coverage_factor = o.positive("coverage_factor");
      break;
    case MeasurementKind::PointToPlane:
      m.a = read_end(o, "point", file);
      m.plane = read_plane(o, "plane", file);
      read_value(o, "distance_m", "m", m);
      break;
    case MeasurementKind::PlaneAngle:
      m.plane = read_plane(o, "first", file);
      m.second_plane = read_plane(o, "second", file);
      read_value(o, "angle_deg", "deg", m);
      break;
  }
  o.optional("previous_names");  // both read by get_revisions, which names wrong types
  o.optional("withdrawn");
  m.revisions = get_revisions(j, fmt::format("{}: {}", file.string(), where));
  o.finish();
  return m;
}

// --- writing ---------------------------------------------------------------------------------

json end_json(const MeasuredEnd& e) {
  json j = {{"given", vec_json(e.given)},
            {"snapped", vec_json(e.snapped)},
            {"feature", to_string(e.feature)},
            {"views", e.views},
            {"points", e.points},
            {"planes", e.planes},
            {"standard_uncertainty_m", e.standard_uncertainty_m}};
  if (e.snapped_to_feature) j["snapped_to_feature"] = *e.snapped_to_feature;
  return j;
}

json plane_json(const MeasuredPlane& p) {
  return {{"point", vec_json(p.point)},
          {"normal", vec_json(p.normal)},
          {"rms_m", p.rms_m},
          {"points", p.points},
          {"offset_sigma_m", p.offset_sigma_m},
          {"normal_sigma_deg", p.normal_sigma_deg}};
}

// InputError unless the measurement holds exactly the parts of its kind.
void check_parts(const CaseMeasurement& m) {
  bool ok = false;
  const char* needs = "";
  switch (m.kind) {
    case MeasurementKind::PointToPoint:
      ok = m.a && m.b && !m.plane && !m.second_plane && m.coverage_factor;
      needs = "ends a and b, a coverage factor and no planes";
      break;
    case MeasurementKind::PointToPlane:
      ok = m.a && !m.b && m.plane && !m.second_plane && !m.coverage_factor;
      needs = "end a (the point) and a plane, nothing else";
      break;
    case MeasurementKind::PlaneAngle:
      ok = !m.a && !m.b && m.plane && m.second_plane && !m.coverage_factor;
      needs = "two planes, nothing else";
      break;
  }
  if (!ok)
    throw InputError(fmt::format("measurement '{}' ({}) needs {}", m.name, to_string(m.kind), needs));
}

json entry_json(const CaseMeasurement& m) {
  if (m.name.empty()) throw InputError("a measurement needs a name");
  const bool finite = std::isfinite(m.value) && std::isfinite(m.standard_uncertainty) &&
                      std::isfinite(m.expanded_uncertainty) &&
                      std::isfinite(m.coverage_factor.value_or(0.0));
  if (!finite)
    throw InputError(fmt::format("measurement '{}': its value or uncertainty is not finite", m.name));
  json j = measurement_content_json(m);
  j["name"] = m.name;
  j["created"] = m.created;
  put_revisions(j, m.revisions);
  return j;
}

}  // namespace

std::string_view to_string(MeasurementKind kind) {
  switch (kind) {
    case MeasurementKind::PointToPoint: return "point_to_point";
    case MeasurementKind::PointToPlane: return "point_to_plane";
    case MeasurementKind::PlaneAngle: return "plane_angle";
  }
  return "?";
}

MeasuredEnd measured_end(const SnappedPoint& p) {
  MeasuredEnd e;
  e.given = p.given;
  e.snapped = p.snapped;
  e.feature = p.feature;
  e.snapped_to_feature = is_snapped(p.feature);
  e.views = p.views;
  e.points = p.points;
  e.planes = p.planes;
  e.standard_uncertainty_m = std::sqrt(std::max(0.0, p.covariance.trace()));
  return e;
}

MeasuredPlane measured_plane(const PlaneEstimate& p) {
  MeasuredPlane out;
  out.point = p.point;
  out.normal = p.normal;
  out.rms_m = p.rms_m;
  out.points = p.points;
  out.offset_sigma_m = p.offset_sigma_m;
  out.normal_sigma_deg = p.normal_sigma_rad * 180.0 / M_PI;
  return out;
}

CaseMeasurement case_measurement(std::string name, const PointToPointMeasurement& m) {
  CaseMeasurement c;
  c.name = std::move(name);
  c.kind = MeasurementKind::PointToPoint;
  c.a = measured_end(m.a);
  c.b = measured_end(m.b);
  c.value = m.distance_m;
  c.standard_uncertainty = m.standard_uncertainty_m;
  c.expanded_uncertainty = m.expanded_uncertainty_m;
  c.coverage_factor = m.coverage_factor;
  return c;
}

CaseMeasurement case_measurement(std::string name, const PointToPlaneMeasurement& m) {
  CaseMeasurement c;
  c.name = std::move(name);
  c.kind = MeasurementKind::PointToPlane;
  c.a = measured_end(m.point);
  c.plane = measured_plane(m.plane);
  c.value = m.distance_m;
  c.standard_uncertainty = m.standard_uncertainty_m;
  c.expanded_uncertainty = m.expanded_uncertainty_m;
  return c;
}

CaseMeasurement case_measurement(std::string name, const PlaneAngleMeasurement& m) {
  CaseMeasurement c;
  c.name = std::move(name);
  c.kind = MeasurementKind::PlaneAngle;
  c.plane = measured_plane(m.first);
  c.second_plane = measured_plane(m.second);
  c.value = m.angle_deg;
  c.standard_uncertainty = m.standard_uncertainty_deg;
  c.expanded_uncertainty = m.expanded_uncertainty_deg;
  return c;
}

json measurement_content_json(const CaseMeasurement& m) {
  check_parts(m);
  json j = {{"kind", to_string(m.kind)}};
  const std::string unit(m.unit());
  switch (m.kind) {
    case MeasurementKind::PointToPoint:
      j["a"] = end_json(*m.a);
      j["b"] = end_json(*m.b);
      j["coverage_factor"] = *m.coverage_factor;
      break;
    case MeasurementKind::PointToPlane:
      j["point"] = end_json(*m.a);
      j["plane"] = plane_json(*m.plane);
      break;
    case MeasurementKind::PlaneAngle:
      j["first"] = plane_json(*m.plane);
      j["second"] = plane_json(*m.second_plane);
      break;
  }
  j[m.is_angle() ? "angle_deg" : "distance_m"] = m.value;
  j["standard_uncertainty_" + unit] = m.standard_uncertainty;
  j["expanded_uncertainty_" + unit] = m.expanded_uncertainty;
  return j;
}

json case_measurements_to_json(const std::vector<CaseMeasurement>& measurements) {
  json list = json::array();
  for (const CaseMeasurement& m : measurements) list.push_back(entry_json(m));
  return {{"measurements", std::move(list)}};
}

std::vector<CaseMeasurement> read_case_measurements(const fs::path& path) {
  std::vector<CaseMeasurement> out;
  if (!fs::exists(path)) return out;
  const json j = io_detail::read_json_file(path);
  StrictObject top(j, "the file", path);
  const json& list = top.array("measurements", true);
  top.finish();
  for (std::size_t i = 0; i < list.size(); ++i) out.push_back(read_measurement(list[i], i + 1, path));
  return out;
}

std::string case_measurements_csv(const std::vector<CaseMeasurement>& measurements) {
  std::string out = "name,kind,value,unit,expanded_uncertainty,a_feature,b_feature,created,"
                    "status,previous_names\n";
  for (const CaseMeasurement& m : measurements) {
    const std::string_view a = m.a ? to_string(m.a->feature) : "";
    const std::string_view b = m.kind == MeasurementKind::PointToPlane ? "plane"
                               : m.b                                   ? to_string(m.b->feature)
                                                                       : "";
    out += fmt::format("{},{},{:.5f},{},{:.5f},{},{},{},{},{}\n", csv_field(m.name),
                       csv_field(to_string(m.kind)), m.value, m.unit(), m.expanded_uncertainty,
                       csv_field(a), csv_field(b), csv_field(m.created),
                       csv_field(m.revisions.status()), csv_field(m.revisions.previous_names_text()));
  }
  return out;
}

void write_case_measurements(const fs::path& path, const std::vector<CaseMeasurement>& measurements) {
  const std::string text = case_measurements_to_json(measurements).dump(1);  // checks them first
  fs::create_directories(path.parent_path());
  {
    AtomicFile f(path, false);
    f.stream() << text << '\n';
    f.commit();
  }
  AtomicFile f(fs::path(path).replace_extension(".csv"), false);
  f.stream() << case_measurements_csv(measurements);
  f.commit();
}

std::vector<fs::path> append_case_measurement(const CaseFolder& folder, CaseMeasurement measurement) {
  if (measurement.name.empty()) throw InputError("a measurement needs a name");
  const fs::path path = folder.path(kCaseMeasurementsJson);
  std::vector<CaseMeasurement> all = read_case_measurements(path);
  if (measurement.created.empty()) measurement.created = utc_now_iso8601();
  all.push_back(std::move(measurement));
  write_case_measurements(path, all);
  return {kCaseMeasurementsJson, kCaseMeasurementsCsv};
}

}  // namespace locard::forensics
