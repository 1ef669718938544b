#include <locard/forensics/evidence_markers.hpp>

#include "forensics/csv_field.hpp"

#include "forensics/json_util.hpp"
#include "forensics/revisions_json.hpp"

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <utility>

namespace locard::forensics {
namespace {

using nlohmann::json;

}  // namespace

Eigen::Vector3d CaseFrame::to_local(const Eigen::Vector3d& world) const {
  return axes.transpose() * (world - origin);
}

Eigen::Vector3d CaseFrame::to_world(const Eigen::Vector3d& local) const {
  return origin + axes * local;
}

CaseFrame CaseFrame::from_points(const Eigen::Vector3d& origin, const Eigen::Vector3d& on_x_axis,
                                 const Eigen::Vector3d& in_xy_plane, std::string description) {
  const Eigen::Vector3d x = on_x_axis - origin;
  if (x.norm() < 1e-6) throw InputError("case frame: the x-axis point coincides with the origin");
  const Eigen::Vector3d ex = x.normalized();
  Eigen::Vector3d y = in_xy_plane - origin;
  y -= y.dot(ex) * ex;
  if (y.norm() < 1e-6 * std::max(1.0, (in_xy_plane - origin).norm()))
    throw InputError("case frame: the three points are collinear; the xy plane is undefined");
  const Eigen::Vector3d ey = y.normalized();
  CaseFrame f;
  f.origin = origin;
  f.axes.col(0) = ex;
  f.axes.col(1) = ey;
  f.axes.col(2) = ex.cross(ey);
  f.description = std::move(description);
  return f;
}

LevelledFrame level_frame(const CaseFrame& current, const std::vector<Eigen::Vector3d>& floor_points) {
  if (floor_points.size() < 3)
    throw InputError(fmt::format("level: {} floor point(s) given, at least 3 needed (--floor x,y,z "
                                 "three times or more)",
                                 floor_points.size()));
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : floor_points) centre += p;
  centre /= static_cast<double>(floor_points.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : floor_points) scatter += (p - centre) * (p - centre).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);
  // Spread: the second axis of the points' scatter (RMS along it) must span a floor patch, or
  // the plane's tilt about the points' line is a guess.
  const double spread = std::sqrt(eig.eigenvalues()(1) / static_cast<double>(floor_points.size()));
  if (spread < 0.05)
    throw InputError(fmt::format("level: the floor points lie along a line (spread {:.1f} cm "
                                 "across it, at least 5 cm needed): pick them around the room",
                                 100.0 * spread));
  Eigen::Vector3d n = eig.eigenvectors().col(0).normalized();
  const Eigen::Vector3d old_z = current.axes.col(2);
  if (n.dot(old_z) < 0) n = -n;
  LevelledFrame out;
  for (const Eigen::Vector3d& p : floor_points) {
    const double d = std::abs(n.dot(p - centre));
    out.rms_m += d * d;
    out.max_m = std::max(out.max_m, d);
  }
  out.rms_m = std::sqrt(out.rms_m / static_cast<double>(floor_points.size()));
  out.tilt_deg = std::acos(std::clamp(n.dot(old_z), -1.0, 1.0)) * 180.0 / M_PI;
  Eigen::Vector3d x = current.axes.col(0) - current.axes.col(0).dot(n) * n;
  if (x.norm() < 1e-6) x = current.axes.col(1) - current.axes.col(1).dot(n) * n;  // x was vertical
  CaseFrame& f = out.frame;
  f.axes.col(0) = x.normalized();
  f.axes.col(2) = n;
  f.axes.col(1) = n.cross(f.axes.col(0));
  f.origin = current.origin - n.dot(current.origin - centre) * n;
  f.description = fmt::format("levelled from {} picked floor points (rms {:.1f} mm about their "
                              "plane; z turned {:.2f} deg from the frame before, origin on the "
                              "floor); before: {}",
                              floor_points.size(), 1000.0 * out.rms_m, out.tilt_deg,
                              current.description);
  return out;
}

const EvidenceMarker& MarkerSet::add(EvidenceMarker marker) {
  if (marker.label.empty()) throw InputError("an evidence marker needs a label");
  for (const EvidenceMarker& m : markers)
    if (m.label == marker.label)
      throw InputError(fmt::format("marker label '{}' is already used by marker {}", marker.label,
                                   m.number));
  if (!marker.world.allFinite()) throw InputError("marker coordinates must be finite");
  int highest = 0;
  for (const EvidenceMarker& m : markers) highest = std::max(highest, m.number);
  marker.number = highest + 1;
  if (marker.created.empty()) marker.created = utc_now_iso8601();
  markers.push_back(std::move(marker));
  return markers.back();
}

const EvidenceMarker* MarkerSet::find(const std::string& name) const {
  std::string key = name;
  if (key.rfind("marker:", 0) == 0) key = key.substr(7);
  for (const EvidenceMarker& m : markers)
    if (m.label == name || std::to_string(m.number) == key) return &m;
  return nullptr;
}

EvidenceMarker* MarkerSet::find(const std::string& name) {
  return const_cast<EvidenceMarker*>(std::as_const(*this).find(name));
}

const EvidenceMarker* MarkerSet::find_usable(const std::string& name) const {
  const EvidenceMarker* m = find(name);
  if (m && m->revisions.withdrawn())
    throw InputError(fmt::format("marker {} '{}' was withdrawn ({}); it cannot be used", m->number,
                                 m->label, m->revisions.status()));
  return m;
}

bool MarkerSet::remove(int number) {
  const auto it = std::find_if(markers.begin(), markers.end(),
                               [&](const EvidenceMarker& m) { return m.number == number; });
  if (it == markers.end()) return false;
  markers.erase(it);
  return true;
}

MarkerSet read_markers(const std::filesystem::path& path) {
  MarkerSet set;
  if (!std::filesystem::exists(path)) return set;
  std::ifstream in(path);
  json j;
  try {
    j = json::parse(in);
  } catch (const json::exception& e) {  // syntax, and numbers out of range (1e400)
    throw_input_error(path, fmt::format("not valid JSON: {}", e.what()));
  }
  const std::string where = path.string();
  try {
    const json& f = j.at("frame");
    set.frame.origin = json_vec3(f.at("origin"), where + ": frame.origin");
    set.frame.axes.col(0) = json_vec3(f.at("x_axis"), where + ": frame.x_axis");
    set.frame.axes.col(1) = json_vec3(f.at("y_axis"), where + ": frame.y_axis");
    set.frame.axes.col(2) = json_vec3(f.at("z_axis"), where + ": frame.z_axis");
    set.frame.description = f.value("description", "");
    for (const json& m : j.at("markers")) {
      EvidenceMarker e;
      e.number = m.at("number").get<int>();
      e.label = m.at("label").get<std::string>();
      e.note = m.value("note", "");
      e.world = json_vec3(m.at("world"), fmt::format("{}: marker {}", where, e.number));
      e.snapped = m.value("snapped", false);
      e.expanded_uncertainty_m = m.value("expanded_uncertainty_m", 0.0);
      e.created = m.value("created", "");
      e.revisions = get_revisions(m, fmt::format("{}: marker {}", where, e.number));
      set.markers.push_back(std::move(e));
    }
  } catch (const json::exception& e) {
    throw_input_error(path, fmt::format("malformed markers file: {}", e.what()));
  }
  if (!(set.frame.axes.transpose() * set.frame.axes).isApprox(Eigen::Matrix3d::Identity(), 1e-6))
    throw_input_error(path, "frame axes are not orthonormal");
  return set;
}

std::string markers_csv(const MarkerSet& set) {
  std::string out = "number,label,x,y,z,world_x,world_y,world_z,expanded_uncertainty_m,note,"
                    "status,previous_labels\n";
  for (const EvidenceMarker& m : set.markers) {
    const Eigen::Vector3d l = set.frame.to_local(m.world);
    out += fmt::format("{},{},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{},{},{}\n",
                       m.number, csv_field(m.label), l.x(), l.y(), l.z(), m.world.x(),
                       m.world.y(), m.world.z(), m.expanded_uncertainty_m, csv_field(m.note),
                       csv_field(m.revisions.status()),
                       csv_field(m.revisions.previous_names_text()));
  }
  return out;
}

void write_markers(const std::filesystem::path& path, const MarkerSet& set) {
  json markers = json::array();
  for (const EvidenceMarker& m : set.markers) {
    json one = {{"number", m.number},
                {"label", m.label},
                {"note", m.note},
                {"world", vec_json(m.world)},
                {"local", vec_json(set.frame.to_local(m.world))},
                {"snapped", m.snapped},
                {"expanded_uncertainty_m", m.expanded_uncertainty_m},
                {"created", m.created}};
    put_revisions(one, m.revisions);
    markers.push_back(std::move(one));
  }
  const json j = {{"frame",
                   {{"origin", vec_json(set.frame.origin)},
                    {"x_axis", vec_json(set.frame.axes.col(0))},
                    {"y_axis", vec_json(set.frame.axes.col(1))},
                    {"z_axis", vec_json(set.frame.axes.col(2))},
                    {"description", set.frame.description}}},
                  {"markers", markers}};
  std::filesystem::create_directories(path.parent_path());
  {
    AtomicFile f(path, false);
    f.stream() << j.dump(1) << '\n';
    f.commit();
  }
  AtomicFile f(std::filesystem::path(path).replace_extension(".csv"), false);
  f.stream() << markers_csv(set);
  f.commit();
}

}  // namespace locard::forensics
