#include <locard/forensics/trajectory_analysis.hpp>

#include "forensics/csv_field.hpp"
#include "forensics/json_util.hpp"
#include "forensics/revisions_json.hpp"

#include <locard/core/atomic_file.hpp>

#include <locard/core/error.hpp>
#include <locard/core/raycaster.hpp>
#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/measurement.hpp>

#include <Eigen/Eigenvalues>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>

namespace locard::forensics {
namespace {

using Eigen::Vector3d;
using nlohmann::json;

constexpr double kDeg = 180.0 / M_PI;

SurfaceHit cast(const Raycaster& rc, const TriangleMesh& mesh, const Vector3d& from,
                const Vector3d& dir, const TrajectoryInput& in) {
  SurfaceHit h;
  const RayHit r = rc.intersect(from.cast<float>(), dir.cast<float>(),
                                     static_cast<float>(in.min_gap_m),
                                     static_cast<float>(in.max_range_m));
  if (!r.hit()) return h;
  h.hit = true;
  h.distance_m = r.t;
  h.point = from + static_cast<double>(r.t) * dir;
  const auto& t = mesh.triangles[r.triangle];
  const Vector3d a = mesh.vertices[t[0]].cast<double>(), b = mesh.vertices[t[1]].cast<double>(),
                 c = mesh.vertices[t[2]].cast<double>();
  Vector3d n = (b - a).cross(c - a).normalized();
  if (n.dot(dir) > 0) n = -n;  // facing the incoming line
  h.normal = n;
  h.incidence_deg = std::acos(std::clamp(-n.dot(dir), -1.0, 1.0)) * kDeg;
  return h;
}

TrajectoryAnalysis analyse(const Raycaster* rc, const TriangleMesh* mesh,
                           const CaseModel* model, const TrajectoryInput& in) {
  if (in.points.size() < 2) throw InputError("a trajectory needs at least two points");
  for (const Vector3d& p : in.points)
    if (!p.allFinite()) throw InputError("trajectory points must be finite");
  TrajectoryAnalysis a;
  a.name = in.name;
  a.points = in.points;
  const std::size_t n = in.points.size();
  Vector3d mean = Vector3d::Zero();
  for (const Vector3d& p : in.points) mean += p;
  mean /= static_cast<double>(n);
  a.origin = mean;
  Vector3d d = in.points.back() - in.points.front();
  if (d.norm() < 1e-4)
    throw InputError("the first and last trajectory points coincide: the direction is undefined");
  if (n > 2) {  // total least squares: principal axis
    Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
    for (const Vector3d& p : in.points) C += (p - mean) * (p - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(C);
    Vector3d axis = es.eigenvectors().col(2).normalized();
    if (axis.dot(d) < 0) axis = -axis;
    d = axis;
    double ss = 0;
    for (const Vector3d& p : in.points) {
      const Vector3d r = p - mean;
      ss += (r - r.dot(d) * d).squaredNorm();
    }
    a.fit_rms_m = std::sqrt(ss / static_cast<double>(n));
  } else {
    d.normalize();
  }
  a.direction = d;
  a.horizontal_angle_deg = std::atan2(d.y(), d.x()) * kDeg;
  a.vertical_angle_deg = std::asin(std::clamp(d.z(), -1.0, 1.0)) * kDeg;

  // Point uncertainty: given, else from the model at each point (mean of snapped sigmas).
  double sigma = in.point_sigma_m;
  if (sigma <= 0 && model) {
    double sum = 0;
    for (const Vector3d& p : in.points) {
      try {
        const SnappedPoint s = snap_point(*model, p);
        // Perpendicular to the line: the covariance's part across d (two axes).
        const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - d * d.transpose();
        sum += std::sqrt(std::max(0.0, (P * s.covariance * P).trace() / 2.0));
      } catch (const InputError&) {
        // A point in the air (a rod's middle) has no surface: the sensor's noise floor.
        sum += model->noise().axial_sigma_m(1.5, 0.0);
      }
    }
    sigma = sum / static_cast<double>(n);
  }
  if (sigma <= 0) throw InputError("trajectory: give the points' uncertainty (point_sigma_m)");
  a.point_sigma_m = sigma;
  double angular = 0.0;
  if (n == 2) {
    angular = std::sqrt(2.0) * sigma / (in.points[1] - in.points[0]).norm();
  } else {
    double spread = 0;
    for (const Vector3d& p : in.points) spread += std::pow((p - mean).dot(d), 2);
    angular = std::max(sigma, a.fit_rms_m) / std::sqrt(spread);
  }
  a.angular_sigma_deg = angular * kDeg;
  const double half = in.coverage_factor * angular;
  a.cone_half_angle_deg = half * kDeg;
  if (rc && mesh) {
    a.forward = cast(*rc, *mesh, in.points.back(), d, in);
    a.backward = cast(*rc, *mesh, in.points.front(), -d, in);
    for (SurfaceHit* h : {&a.forward, &a.backward})
      if (h->hit) h->cone_radius_m = h->distance_m * std::tan(half) + in.coverage_factor * sigma;
  }
  return a;
}

json hit_json(const SurfaceHit& h) {
  if (!h.hit) return {{"hit", false}};
  return {{"hit", true},
          {"point", vec_json(h.point)},
          {"normal", vec_json(h.normal)},
          {"distance_m", h.distance_m},
          {"incidence_deg", h.incidence_deg},
          {"cone_radius_m", h.cone_radius_m}};
}

SurfaceHit hit_from(const json& j, const std::string& where) {
  SurfaceHit h;
  h.hit = j.value("hit", false);
  if (!h.hit) return h;
  h.point = json_vec3(j.at("point"), where);
  h.normal = json_vec3(j.at("normal"), where);
  h.distance_m = j.value("distance_m", 0.0);
  h.incidence_deg = j.value("incidence_deg", 0.0);
  h.cone_radius_m = j.value("cone_radius_m", 0.0);
  return h;
}

}  // namespace

TrajectoryAnalysis analyse_trajectory(const CaseModel* model, const TrajectoryInput& input) {
  if (!model) return analyse(nullptr, nullptr, nullptr, input);
  return analyse(&model->raycaster(), &model->mesh(), model, input);
}

TrajectoryAnalysis analyse_trajectory(const TriangleMesh& mesh, const TrajectoryInput& input) {
  const Raycaster rc(mesh);
  return analyse(&rc, &mesh, nullptr, input);
}

std::string trajectory_analyses_json(const std::vector<TrajectoryAnalysis>& analyses) {
  json all = json::array();
  for (const TrajectoryAnalysis& a : analyses) {
    json pts = json::array();
    for (const auto& p : a.points) pts.push_back(vec_json(p));
    json one = {{"name", a.name},
                   {"points", pts},
                   {"origin", vec_json(a.origin)},
                   {"direction", vec_json(a.direction)},
                   {"horizontal_angle_deg", a.horizontal_angle_deg},
                   {"vertical_angle_deg", a.vertical_angle_deg},
                   {"fit_rms_m", a.fit_rms_m},
                   {"point_sigma_m", a.point_sigma_m},
                   {"angular_sigma_deg", a.angular_sigma_deg},
                   {"cone_half_angle_deg", a.cone_half_angle_deg},
                   {"forward", hit_json(a.forward)},
                   {"backward", hit_json(a.backward)}};
    put_revisions(one, a.revisions);
    all.push_back(std::move(one));
  }
  return json{{"convention", "horizontal angle: azimuth from +x, counter-clockwise seen from "
                             "above; vertical angle: elevation above the horizontal; direction "
                             "from the first point to the last; cone half-angle expanded (k=2)"},
              {"analyses", all}}
      .dump(1);
}

std::vector<TrajectoryAnalysis> read_trajectory_analyses(const std::filesystem::path& path) {
  std::vector<TrajectoryAnalysis> out;
  if (!std::filesystem::exists(path)) return out;
  std::ifstream in(path);
  try {
    const json j = json::parse(in);
    for (const json& a : j.at("analyses")) {
      TrajectoryAnalysis t;
      t.name = a.value("name", "");
      const std::string where = path.string() + ": " + t.name;
      for (const json& p : a.at("points")) t.points.push_back(json_vec3(p, where));
      t.origin = json_vec3(a.at("origin"), where);
      t.direction = json_vec3(a.at("direction"), where);
      t.horizontal_angle_deg = a.value("horizontal_angle_deg", 0.0);
      t.vertical_angle_deg = a.value("vertical_angle_deg", 0.0);
      t.fit_rms_m = a.value("fit_rms_m", 0.0);
      t.point_sigma_m = a.value("point_sigma_m", 0.0);
      t.angular_sigma_deg = a.value("angular_sigma_deg", 0.0);
      t.cone_half_angle_deg = a.value("cone_half_angle_deg", 0.0);
      t.forward = hit_from(a.at("forward"), where);
      t.backward = hit_from(a.at("backward"), where);
      t.revisions = get_revisions(a, where);
      out.push_back(std::move(t));
    }
  } catch (const json::exception& e) {
    throw_input_error(path, fmt::format("malformed trajectory analyses: {}", e.what()));
  }
  return out;
}

std::string trajectory_analyses_csv(const std::vector<TrajectoryAnalysis>& analyses) {
  std::string out = "name,points,horizontal_angle_deg,vertical_angle_deg,cone_half_angle_deg,"
                    "fit_rms_m,forward_hit_m,backward_hit_m,status,previous_names\n";
  auto hit = [](const SurfaceHit& h) { return h.hit ? fmt::format("{:.4f}", h.distance_m) : ""; };
  for (const TrajectoryAnalysis& a : analyses)
    out += fmt::format("{},{},{:.3f},{:.3f},{:.3f},{:.5f},{},{},{},{}\n", csv_field(a.name),
                       a.points.size(), a.horizontal_angle_deg, a.vertical_angle_deg,
                       a.cone_half_angle_deg, a.fit_rms_m, hit(a.forward), hit(a.backward),
                       csv_field(a.revisions.status()),
                       csv_field(a.revisions.previous_names_text()));
  return out;
}

void write_trajectory_analyses(const std::filesystem::path& json_path,
                               const std::vector<TrajectoryAnalysis>& analyses) {
  std::filesystem::create_directories(json_path.parent_path());
  {
    AtomicFile f(json_path, false);
    f.stream() << trajectory_analyses_json(analyses) << '\n';
    f.commit();
  }
  AtomicFile f(std::filesystem::path(json_path).replace_extension(".csv"), false);
  f.stream() << trajectory_analyses_csv(analyses);
  f.commit();
}

std::string default_trajectory_name(std::size_t stored) { return fmt::format("T{}", stored + 1); }

RecordedTrajectory record_trajectory_analysis(CaseFolder& folder, TrajectoryAnalysis analysis,
                                              const std::string& parameters_json,
                                              double duration_s) {
  const std::filesystem::path relative = "trajectories/analyses.json";
  CaseChange change(folder, {relative, "trajectories/analyses.csv"});
  std::vector<TrajectoryAnalysis> all = read_trajectory_analyses(folder.path(relative));
  if (analysis.name.empty()) analysis.name = default_trajectory_name(all.size());
  for (const TrajectoryAnalysis& existing : all)
    if (existing.name == analysis.name)
      throw InputError(fmt::format("a trajectory named '{}' exists already in this case",
                                   analysis.name));
  all.push_back(analysis);
  write_trajectory_analyses(folder.path(relative), all);
  LogStep step;
  step.step = "trajectory";
  step.parameters_json = parameters_json;
  step.duration_s = duration_s;
  step.inputs = {"mesh/mesh.ply"};
  step.outputs = {relative, "trajectories/analyses.csv"};
  RecordedTrajectory recorded;
  recorded.log_seq = change.commit(step);
  recorded.analysis = std::move(analysis);
  return recorded;
}

}  // namespace locard::forensics
