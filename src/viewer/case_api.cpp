// The viewer's JSON API over one case folder (see case_api.hpp). Reads go straight to the
// case's files; everything that adds to the case (markers, trajectory analyses) goes through
// the forensics library, which appends to log.jsonl and rewrites manifest.json exactly as the
// CLI does.
#include <locard/viewer/case_api.hpp>

#include "forensics/case_measurements_json.hpp"
#include "forensics/revisions_json.hpp"

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/forensics/case_edits.hpp>
#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/case_measurements.hpp>
#include <locard/forensics/case_model.hpp>
#include <locard/forensics/evidence_markers.hpp>
#include <locard/forensics/measurement.hpp>
#include <locard/forensics/report.hpp>
#include <locard/forensics/trajectory_analysis.hpp>
#include <locard/io/ply.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <fstream>

namespace locard::viewer {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

ApiResponse json_response(const json& body, int status = 200) {
  return ApiResponse{status, "application/json", body.dump()};
}
ApiResponse error_response(int status, const std::string& message) {
  return json_response(json{{"error", message}}, status);
}

// Parses a file as JSON; nullopt when it is missing or malformed.
std::optional<json> read_json_file(const fs::path& path) {
  std::ifstream in(path);
  if (!in) return std::nullopt;
  json out = json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (out.is_discarded()) return std::nullopt;
  return out;
}

// A request's JSON body; throws InputError (-> 400) when it is not a JSON object.
json parse_body(std::string_view body) {
  json out = json::parse(body, nullptr, /*allow_exceptions=*/false);
  if (out.is_discarded() || !out.is_object())
    throw InputError("request body: expected a JSON object");
  return out;
}

// body[key] as a finite 3-vector; throws InputError (-> 400) naming the key otherwise.
Eigen::Vector3d point_field(const json& body, const char* key) {
  const auto it = body.find(key);
  if (it == body.end() || !it->is_array() || it->size() != 3)
    throw InputError(fmt::format("'{}': expected [x, y, z] in metres", key));
  Eigen::Vector3d p;
  for (int i = 0; i < 3; ++i) {
    const json& v = (*it)[static_cast<std::size_t>(i)];
    if (!v.is_number()) throw InputError(fmt::format("'{}': coordinate {} is not a number", key, i));
    p[i] = v.get<double>();
    if (!std::isfinite(p[i])) throw InputError(fmt::format("'{}': coordinate {} is not finite", key, i));
  }
  return p;
}

json to_json(const Eigen::Vector3d& p) { return json::array({p.x(), p.y(), p.z()}); }

json to_json(const forensics::EvidenceMarker& m) {
  json out{{"number", m.number},
           {"label", m.label},
           {"note", m.note},
           {"world", to_json(m.world)},
           {"snapped", m.snapped},
           {"expanded_uncertainty_m", m.expanded_uncertainty_m},
           {"created", m.created}};
  forensics::put_revisions(out, m.revisions);
  return out;
}

json to_json(const forensics::SurfaceHit& h) {
  if (!h.hit) return json{{"hit", false}};
  return json{{"hit", true},
              {"point", to_json(h.point)},
              {"normal", to_json(h.normal)},
              {"distance_m", h.distance_m},
              {"incidence_deg", h.incidence_deg},
              {"cone_radius_m", h.cone_radius_m}};
}

json to_json(const forensics::TrajectoryAnalysis& t) {
  json points = json::array();
  for (const Eigen::Vector3d& p : t.points) points.push_back(to_json(p));
  json out{{"name", t.name},
              {"points", points},
              {"origin", to_json(t.origin)},
              {"direction", to_json(t.direction)},
              {"horizontal_angle_deg", t.horizontal_angle_deg},
              {"vertical_angle_deg", t.vertical_angle_deg},
              {"fit_rms_m", t.fit_rms_m},
              {"point_sigma_m", t.point_sigma_m},
              {"angular_sigma_deg", t.angular_sigma_deg},
              {"cone_half_angle_deg", t.cone_half_angle_deg},
              {"forward", to_json(t.forward)},
              {"backward", to_json(t.backward)}};
  forensics::put_revisions(out, t.revisions);
  return out;
}

// Expanded (k) uncertainty of a point's position, as `locard marker add` reports it: k times
// the radial standard uncertainty sqrt(trace(covariance)).
double expanded_point_uncertainty(const Eigen::Matrix3d& covariance, double k) {
  return k * std::sqrt(std::max(0.0, covariance.trace()));
}

std::string utc_now_iso8601() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buffer[32];
  std::strftime(buffer, sizeof buffer, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buffer;
}

std::string optional_string(const json& body, const char* key, std::size_t max_length) {
  const auto it = body.find(key);
  if (it == body.end() || it->is_null()) return {};
  if (!it->is_string()) throw InputError(fmt::format("'{}': expected a string", key));
  std::string out = it->get<std::string>();
  if (out.size() > max_length)
    throw InputError(fmt::format("'{}': longer than {} characters", key, max_length));
  return out;
}

// body[key] as a boolean, `absent` when missing; any other type is an InputError (-> 400): a
// "snap": "yes" once escaped as nlohmann's type_error and a 500 with its text.
bool optional_bool(const json& body, const char* key, bool absent) {
  const auto it = body.find(key);
  if (it == body.end() || it->is_null()) return absent;
  if (!it->is_boolean()) throw InputError(fmt::format("'{}': expected true or false", key));
  return it->get<bool>();
}

template <typename T>
void append_bytes(std::string& out, const T* data, std::size_t count) {
  const std::size_t offset = out.size();
  out.resize(offset + sizeof(T) * count);
  if (count > 0) std::memcpy(out.data() + offset, data, sizeof(T) * count);
}

bool is_regular(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

}  // namespace

struct CaseApi::Impl {
  fs::path root;  // canonical
  // Decimated cloud buffer, built on first request per `max` value (the case is read-only
  // for the cloud while the viewer runs).
  std::size_t points_max = 0;
  std::string points_buffer;

  // The measurable model (mesh, views, pose covariances, sensor noise), loaded on the first
  // request that needs it.
  std::optional<forensics::CaseModel> model_cache;

  // Throws InputError (-> 400) naming what is missing when the folder is not a case.
  // Change verifies the case first (CaseNotIntact -> 409 when it does not verify).
  forensics::CaseFolder folder(forensics::CaseAccess access) const {
    return forensics::CaseFolder::open(root, access);
  }
  const forensics::CaseModel& model() {
    if (!model_cache) model_cache.emplace(forensics::CaseModel::load(folder(forensics::CaseAccess::Read)));
    return *model_cache;
  }
};

CaseApi::CaseApi(fs::path case_dir) : impl_(std::make_unique<Impl>()) {
  std::error_code ec;
  if (!fs::is_directory(case_dir, ec)) throw_input_error(case_dir, "no such case folder");
  impl_->root = fs::canonical(case_dir);
}

CaseApi::~CaseApi() = default;

const fs::path& CaseApi::case_dir() const { return impl_->root; }

std::optional<fs::path> CaseApi::resolve_case_file(std::string_view relative) const {
  if (relative.empty() || relative.front() == '/' ||
      relative.find('\\') != std::string_view::npos ||
      relative.find('\0') != std::string_view::npos)
    return std::nullopt;
  const fs::path rel(relative);
  for (const fs::path& part : rel) {
    if (part == ".." || part == "." || part.empty()) return std::nullopt;
  }
  std::error_code ec;
  const fs::path full = fs::canonical(impl_->root / rel, ec);
  if (ec) return std::nullopt;
  // Inside the case folder after every symbolic link is followed.
  const auto [root_end, full_it] =
      std::mismatch(impl_->root.begin(), impl_->root.end(), full.begin(), full.end());
  if (root_end != impl_->root.end() || full_it == full.end()) return std::nullopt;
  if (!fs::is_regular_file(full, ec)) return std::nullopt;
  return full;
}

ApiResponse CaseApi::handle(std::string_view method, std::string_view path, std::string_view body,
                            std::size_t max_points) {
  try {
    const bool get = method == "GET";
    const bool post = method == "POST";
    if (get && path == "/api/case") return case_summary();
    if (get && path == "/api/points") return points(max_points);
    if (post && path == "/api/measure") return measure(body);
    if (get && path == "/api/markers") return markers();
    if (post && path == "/api/markers") return add_marker(body);
    if (post && path == "/api/trajectory") return trajectory(body);
    if (get && path == "/api/measurements") return measurements();
    if (get && path == "/api/trajectories") return trajectories();
    if (post && path == "/api/evidence/rename") return edit(body, false);
    if (post && path == "/api/evidence/withdraw") return edit(body, true);
    return error_response(404, fmt::format("no such API call: {} {}", method, path));
  } catch (const forensics::CaseNotIntact& e) {
    // The case does not verify: nothing is added to it (the finding is the answer).
    return error_response(409, e.what());
  } catch (const InputError& e) {
    return error_response(400, e.what());
  }
}

ApiResponse CaseApi::case_summary() {
  const fs::path& root = impl_->root;
  json out = json::object();
  out["case_dir"] = root.string();
  if (auto c = read_json_file(root / "case.json")) out["case"] = std::move(*c);
  json view = json::object();
  view["mesh_glb"] = is_regular(root / "mesh/mesh.glb");
  view["mesh_ply"] = is_regular(root / "mesh/mesh.ply");
  view["cloud"] = is_regular(root / "cloud/registered.ply");
  view["coverage"] = is_regular(root / "coverage/floor_coverage.json");
  if (auto m = read_json_file(root / "mesh/mesh.json")) {
    view["mesh_info"] = *m;
    view["inferred_triangles"] = m->value("inferred_triangles", 0);
  }
  json simulations = json::array();
  std::error_code ec;
  if (fs::is_directory(root / "simulations", ec)) {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(root / "simulations", ec))
      if (entry.is_directory()) names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    for (const std::string& name : names) {
      const fs::path dir = root / "simulations" / name;
      json s = {{"name", name}};
      if (is_regular(dir / "animation.glb")) s["animation"] = "simulations/" + name + "/animation.glb";
      if (is_regular(dir / "events.json")) s["events"] = "simulations/" + name + "/events.json";
      if (is_regular(dir / "scenario.json")) s["scenario"] = "simulations/" + name + "/scenario.json";
      simulations.push_back(std::move(s));
    }
  }
  view["simulations"] = std::move(simulations);
  out["view"] = std::move(view);
  return json_response(out);
}

ApiResponse CaseApi::points(std::size_t max_points) {
  if (max_points == 0) max_points = 1'000'000;
  if (!impl_->points_buffer.empty() && impl_->points_max == max_points)
    return ApiResponse{200, "application/octet-stream", impl_->points_buffer};
  const fs::path path = impl_->root / "cloud/registered.ply";
  if (!is_regular(path)) return error_response(404, "the case has no cloud/registered.ply");
  const PointCloud cloud = read_ply(path);
  const std::size_t total = cloud.size();
  const std::size_t stride = total <= max_points ? 1 : (total + max_points - 1) / max_points;
  const std::size_t n = total == 0 ? 0 : (total + stride - 1) / stride;
  const ScalarField* segment = cloud.find_scalar("segment");

  std::vector<float> xyz;
  std::vector<std::uint8_t> rgb;
  std::vector<std::int32_t> labels;
  xyz.reserve(3 * n);
  rgb.reserve(3 * n + 3);
  if (segment) labels.reserve(n);
  for (std::size_t i = 0; i < total; i += stride) {
    const Eigen::Vector3f& p = cloud.positions[i];
    xyz.insert(xyz.end(), {p.x(), p.y(), p.z()});
    const Rgb8 c = cloud.has_colors() ? cloud.colors[i] : Rgb8{200, 200, 200};
    rgb.insert(rgb.end(), {c.r, c.g, c.b});
    if (segment) labels.push_back(static_cast<std::int32_t>(std::lround(segment->values[i])));
  }
  while (rgb.size() % 4 != 0) rgb.push_back(0);

  std::string out = "LCPT";
  const std::uint32_t header[3] = {static_cast<std::uint32_t>(n), segment ? 1u : 0u,
                                   static_cast<std::uint32_t>(total)};
  append_bytes(out, header, 3);
  append_bytes(out, xyz.data(), xyz.size());
  append_bytes(out, rgb.data(), rgb.size());
  append_bytes(out, labels.data(), labels.size());
  impl_->points_max = max_points;
  impl_->points_buffer = out;
  return ApiResponse{200, "application/octet-stream", std::move(out)};
}

ApiResponse CaseApi::measure(std::string_view body) {
  const json request = parse_body(body);
  const Eigen::Vector3d a = point_field(request, "a");
  const Eigen::Vector3d b = point_field(request, "b");
  const bool save = optional_bool(request, "save", true);
  const std::string given_name = optional_string(request, "name", 200);
  const auto start = std::chrono::steady_clock::now();
  const forensics::PointToPointMeasurement m =
      forensics::measure_point_to_point(impl_->model(), a, b);
  // The ends, distance and uncertainties as the case's file records them, without the kind.
  json out = forensics::measurement_content_json(forensics::case_measurement("", m));
  out.erase("kind");
  if (!save) return json_response(out);
  // Saved like `locard measure`: appended to measurements/measurements.json, one log step.
  forensics::CaseFolder folder = impl_->folder(forensics::CaseAccess::Change);
  forensics::CaseChange change(folder,
                               {"measurements/measurements.json", "measurements/measurements.csv"});
  const std::string name =
      given_name.empty() ? fmt::format("viewer {}", utc_now_iso8601()) : given_name;
  forensics::LogStep step;
  step.step = "measure";
  step.parameters_json = json{{"source", "viewer"},
                              {"name", name},
                              {"kind", "point_to_point"},  // as `locard measure` logs it
                              {"a", to_json(a)},
                              {"b", to_json(b)}}
                             .dump();
  step.outputs = forensics::append_measurement(folder, name, m);
  step.duration_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out["name"] = name;
  out["log_seq"] = change.commit(step);
  return json_response(out, 201);
}

ApiResponse CaseApi::markers() {
  const forensics::MarkerSet set = forensics::read_markers(impl_->root / "evidence/markers.json");
  json list = json::array();
  for (const forensics::EvidenceMarker& m : set.markers) {
    json j = to_json(m);
    j["local"] = to_json(set.frame.to_local(m.world));
    list.push_back(std::move(j));
  }
  const forensics::CaseFrame& f = set.frame;
  return json_response(json{{"frame", f.description},
                            {"case_frame",
                             {{"description", f.description},
                              {"origin", to_json(f.origin)},
                              {"x_axis", to_json(f.axes.col(0))},
                              {"y_axis", to_json(f.axes.col(1))},
                              {"z_axis", to_json(f.axes.col(2))}}},
                            {"markers", std::move(list)}});
}

ApiResponse CaseApi::add_marker(std::string_view body) {
  const auto start = std::chrono::steady_clock::now();
  const json request = parse_body(body);
  const Eigen::Vector3d position = point_field(request, "position");
  const bool snap = optional_bool(request, "snap", true);
  forensics::EvidenceMarker marker;
  marker.label = optional_string(request, "label", 200);
  marker.note = optional_string(request, "note", 2000);
  marker.world = position;
  marker.created = utc_now_iso8601();
  if (snap) {
    const forensics::SnappedPoint p = forensics::snap_point(impl_->model(), position);
    marker.world = p.snapped;
    marker.snapped = true;
    marker.expanded_uncertainty_m = expanded_point_uncertainty(p.covariance, 2.0);
  }

  forensics::CaseFolder folder = impl_->folder(forensics::CaseAccess::Change);
  const fs::path json_path = folder.path("evidence/markers.json");
  forensics::MarkerSet set = forensics::read_markers(json_path);
  const forensics::EvidenceMarker added = set.add(marker);
  forensics::CaseChange change(folder, {"evidence/markers.json", "evidence/markers.csv"});
  forensics::write_markers(json_path, set);

  forensics::LogStep step;
  step.step = "marker add";
  step.parameters_json = json{{"source", "viewer"},
                              {"number", added.number},
                              {"label", added.label},
                              {"note", added.note},
                              {"position", to_json(position)},
                              {"snap", snap}}
                             .dump();
  step.outputs = {"evidence/markers.json", "evidence/markers.csv"};
  step.duration_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const std::size_t seq = change.commit(step);
  json out = to_json(added);
  out["local"] = to_json(set.frame.to_local(added.world));
  out["log_seq"] = seq;
  return json_response(out, 201);
}

ApiResponse CaseApi::trajectory(std::string_view body) {
  const auto start = std::chrono::steady_clock::now();
  const json request = parse_body(body);
  forensics::TrajectoryInput input;
  input.points = {point_field(request, "a"), point_field(request, "b")};
  input.name = optional_string(request, "name", 200);
  const bool save = optional_bool(request, "save", true);

  forensics::TrajectoryAnalysis analysis = forensics::analyse_trajectory(&impl_->model(), input);
  if (!save) {  // a preview: named as it would be stored
    if (analysis.name.empty())
      analysis.name = forensics::default_trajectory_name(
          forensics::read_trajectory_analyses(impl_->root / "trajectories/analyses.json").size());
    return json_response(to_json(analysis), 200);
  }
  forensics::CaseFolder folder = impl_->folder(forensics::CaseAccess::Change);
  const json parameters{{"source", "viewer"},
                        {"name", input.name},
                        {"points", json::array({to_json(input.points[0]), to_json(input.points[1])})},
                        {"coverage_factor", input.coverage_factor},
                        {"min_gap_m", input.min_gap_m},
                        {"max_range_m", input.max_range_m}};
  const forensics::RecordedTrajectory recorded = forensics::record_trajectory_analysis(
      folder, std::move(analysis), parameters.dump(),
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  json out = to_json(recorded.analysis);
  out["log_seq"] = recorded.log_seq;
  return json_response(out, 201);
}

ApiResponse CaseApi::measurements() {
  try {  // the file as it is, through the one reader (none yet: an empty list)
    return json_response(forensics::case_measurements_to_json(
        forensics::read_case_measurements(impl_->root / forensics::kCaseMeasurementsJson)));
  } catch (const InputError& e) {  // the case's file, not the request, is wrong
    return error_response(500, e.what());
  }
}

ApiResponse CaseApi::trajectories() {
  json list = json::array();
  for (const forensics::TrajectoryAnalysis& t :
       forensics::read_trajectory_analyses(impl_->root / "trajectories/analyses.json"))
    list.push_back(to_json(t));
  return json_response(json{{"analyses", std::move(list)}});
}

ApiResponse CaseApi::edit(std::string_view body, bool withdraw) {
  const json request = parse_body(body);
  forensics::CaseEdit e;
  const std::string kind = optional_string(request, "kind", 20);
  const auto parsed = forensics::parse_case_object_kind(kind);
  if (!parsed) throw InputError("'kind': expected \"marker\", \"measurement\" or \"trajectory\"");
  e.object = *parsed;
  e.which = optional_string(request, "which", 200);
  if (e.which.empty()) throw InputError("'which': say which one (a marker's number or label, a name, or #N)");
  e.edit = withdraw ? forensics::CaseEditKind::Withdraw : forensics::CaseEditKind::Rename;
  e.new_name = optional_string(request, "name", 200);
  e.reason = optional_string(request, "reason", 2000);
  e.source = "viewer";
  forensics::CaseFolder folder = impl_->folder(forensics::CaseAccess::Change);
  const forensics::CaseEditResult r = forensics::apply_case_edit(folder, e);
  return json_response(json{{"summary", r.summary}, {"log_seq", r.log_seq}}, 201);
}

void CaseApi::refresh_report() {
  forensics::CaseFolder folder = impl_->folder(forensics::CaseAccess::Change);
  forensics::refresh_case_report(folder);
}

}  // namespace locard::viewer
