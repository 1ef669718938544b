// Snapping a picked point to what the model says is there (a face, an edge, a corner, or
// "not snapped": the point as given), and fitting a plane around a point, each with its
// covariance (measurement.hpp). The measurements built on them: measurement.cpp; Table I:
// measurement_table.cpp.
#include <locard/forensics/measurement.hpp>

#include <locard/core/error.hpp>
#include <locard/core/raycaster.hpp>

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <set>

namespace locard::forensics {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

struct Plane {
  Vector3d normal = Vector3d::UnitZ();  // unit
  double d = 0.0;                       // normal . x + d = 0
  std::vector<std::uint32_t> inliers;   // indices into LocalPoints
  double rms = 0.0;
  double distance(const Vector3d& x) const { return normal.dot(x) + d; }
};

// Least-squares plane through the given points (smallest principal axis of their scatter).
Plane refit(const std::vector<Vector3d>& pts, const std::vector<std::uint32_t>& ids) {
  Vector3d mean = Vector3d::Zero();
  for (auto i : ids) mean += pts[i];
  mean /= static_cast<double>(ids.size());
  Matrix3d C = Matrix3d::Zero();
  for (auto i : ids) C += (pts[i] - mean) * (pts[i] - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Matrix3d> es(C);
  Plane p;
  p.normal = es.eigenvectors().col(0).normalized();
  p.d = -p.normal.dot(mean);
  p.inliers = ids;
  double ss = 0;
  for (auto i : ids) ss += std::pow(p.distance(pts[i]), 2);
  p.rms = std::sqrt(ss / static_cast<double>(ids.size()));
  return p;
}

// Sequential RANSAC: up to `max_planes` planes, largest first, each refit by least squares.
// Seeded: the same points give the same planes.
std::vector<Plane> find_planes(const LocalPoints& L, double threshold, std::size_t min_points,
                               int max_planes = 4) {
  std::vector<Plane> planes;
  std::vector<std::uint32_t> remaining(L.points.size());
  std::iota(remaining.begin(), remaining.end(), 0u);
  std::mt19937_64 rng(20240607);
  while (static_cast<int>(planes.size()) < max_planes && remaining.size() >= min_points) {
    std::uniform_int_distribution<std::size_t> pick(0, remaining.size() - 1);
    std::size_t best_count = 0;
    Vector3d best_n = Vector3d::UnitZ();
    double best_d = 0;
    for (int it = 0; it < 300; ++it) {
      const Vector3d& a = L.points[remaining[pick(rng)]];
      const Vector3d& b = L.points[remaining[pick(rng)]];
      const Vector3d& c = L.points[remaining[pick(rng)]];
      Vector3d n = (b - a).cross(c - a);
      if (n.norm() < 1e-9) continue;
      n.normalize();
      const double d = -n.dot(a);
      std::size_t count = 0;
      for (auto i : remaining) count += std::abs(n.dot(L.points[i]) + d) <= threshold;
      if (count > best_count) {
        best_count = count;
        best_n = n;
        best_d = d;
      }
    }
    if (best_count < min_points) break;
    std::vector<std::uint32_t> in;
    for (auto i : remaining)
      if (std::abs(best_n.dot(L.points[i]) + best_d) <= threshold) in.push_back(i);
    Plane p = refit(L.points, in);
    for (int round = 0; round < 2; ++round) {  // re-select inliers around the refit plane
      std::vector<std::uint32_t> again;
      for (auto i : remaining)
        if (std::abs(p.distance(L.points[i])) <= threshold) again.push_back(i);
      if (again.size() < min_points) break;
      p = refit(L.points, again);
    }
    if (p.inliers.size() < min_points) break;
    std::set<std::uint32_t> used(p.inliers.begin(), p.inliers.end());
    std::vector<std::uint32_t> rest;
    for (auto i : remaining)
      if (!used.count(i)) rest.push_back(i);
    remaining.swap(rest);
    planes.push_back(std::move(p));
  }
  return planes;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const std::size_t m = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(m), v.end());
  double hi = v[m];
  if (v.size() % 2) return hi;
  const double lo = *std::max_element(v.begin(), v.begin() + static_cast<long>(m));
  return 0.5 * (lo + hi);
}

// Offset variance of a plane: the fit's scatter over its points plus the sensor's per-view
// error, which does not average out within one view (a view's depth bias moves all its points).
double plane_offset_variance(const Plane& p, const LocalPoints& L) {
  std::set<std::uint32_t> views;
  double axial2 = 0.0;
  for (auto i : p.inliers) {
    views.insert(L.view[i]);
    axial2 += L.axial_sigma_m[i] * L.axial_sigma_m[i];
  }
  const double n = static_cast<double>(p.inliers.size());
  const double nv = static_cast<double>(std::max<std::size_t>(views.size(), 1));
  return p.rms * p.rms / n + (axial2 / n) / nv;
}

// The fitted plane's tilt, seen as an offset at x: a least-squares plane is known best at its
// points' centroid, and its offset at x away from it varies by rms^2 r^T S^-1 r (the
// regression's prediction variance), r the in-plane offset of x from the centroid and S the
// points' in-plane scatter. A face end snapped at its edge - where the line meets an end face
// near its top - sits well off the centroid of the face's points within reach.
double plane_tilt_variance_at(const Plane& p, const LocalPoints& L, const Vector3d& x) {
  Vector3d mean = Vector3d::Zero();
  for (auto i : p.inliers) mean += L.points[i];
  mean /= static_cast<double>(p.inliers.size());
  const Vector3d u = p.normal.unitOrthogonal(), v = p.normal.cross(u);
  Eigen::Matrix2d S = Eigen::Matrix2d::Zero();
  for (auto i : p.inliers) {
    const Eigen::Vector2d a((L.points[i] - mean).dot(u), (L.points[i] - mean).dot(v));
    S += a * a.transpose();
  }
  const Eigen::Vector2d r((x - mean).dot(u), (x - mean).dot(v));
  if (S.determinant() <= 0.0) return 0.0;
  return p.rms * p.rms * r.dot(S.inverse() * r);
}

// Mean pose covariance of the observing views propagated to p (fully correlated).
Matrix3d pose_covariance_at(const CaseModel& model, const Vector3d& p,
                            const std::vector<std::uint32_t>& views) {
  Matrix3d out = Matrix3d::Zero();
  if (views.empty()) return out;
  Eigen::Matrix<double, 3, 6> J;
  J.block<3, 3>(0, 0) << 0, p.z(), -p.y(), -p.z(), 0, p.x(), p.y(), -p.x(), 0;  // -[p]x
  J.block<3, 3>(0, 3) = Matrix3d::Identity();
  for (auto k : views) out += J * model.views()[k].covariance * J.transpose();
  return out / static_cast<double>(views.size());
}

Vector3d nearest_on_mesh(const CaseModel& model, const Vector3d& p) {
  // Cast along the six axis directions and the direction to the nearest vertex; keep the
  // closest hit. Good enough for a fallback on a mesh with no plane around the point.
  Vector3d best = p;
  double best_d = std::numeric_limits<double>::infinity();
  const Vector3d dirs[6] = {Vector3d::UnitX(), -Vector3d::UnitX(), Vector3d::UnitY(),
                            -Vector3d::UnitY(), Vector3d::UnitZ(), -Vector3d::UnitZ()};
  for (const Vector3d& d : dirs) {
    const RayHit h = model.raycaster().intersect(p.cast<float>(), d.cast<float>(), 0.0f, 0.1f);
    if (h.hit() && h.t < best_d) {
      best_d = h.t;
      best = p + static_cast<double>(h.t) * d;
    }
  }
  return best;
}

}  // namespace

std::string_view to_string(SnapFeature feature) {
  switch (feature) {
    case SnapFeature::Face: return "face";
    case SnapFeature::Edge: return "edge";
    case SnapFeature::Corner: return "corner";
    case SnapFeature::EdgeOutermost: return "edge (outermost point)";
    case SnapFeature::CornerOutermost: return "corner (outermost point)";
    case SnapFeature::MeshSurface: return "surface";
    case SnapFeature::NotSnapped: return "not snapped";
  }
  return "?";
}

std::string describe(SnapFeature feature) {
  if (feature == SnapFeature::NotSnapped)
    return "not snapped: the picked point is used as given (no face, edge or corner across the "
           "measuring line within reach)";
  return std::string(to_string(feature));
}

namespace {

// Cos of the widest angle between a plane's normal and the measuring direction for the plane
// to face it (a wall, a box's end face), and the largest for it to lie along it (a side plane).
const double kCosFacing = std::cos(35.0 * M_PI / 180.0);
constexpr double kCosSide = 0.5;
// How far across the measuring line (along the edge) a side plane's points count as the end's.
constexpr double kEdgeBandM = 0.01;

// Where a pick that is on no surface along the measuring direction may land. A click beside a
// box's edge, on a face the scanner never saw (the mesh closes it), or a few millimetres off
// the surface the mesh smoothed, then measures from the surface the investigator meant instead
// of counting as "not snapped". Candidates are the planes along o (|n.o| < kCosSide) whose
// points come within `reach` of the pick across the line, each at those nearest points, nearest
// first; the move is across the line only, so the pick keeps its place along o (where the end
// lies along the line is the snapping's to find). Planes the pick already lies on are not
// candidates (the snap as given tried them): a face seen too obliquely to fix its own end (a
// handful of points, a plane tilted by the corner's rounding) then lands on the face beside it.
std::vector<Vector3d> landing_candidates(const std::vector<Plane>& planes, const LocalPoints& L,
                                         const Vector3d& point, const Vector3d& o,
                                         double on_point, double reach) {
  std::vector<std::pair<double, Vector3d>> found;
  for (const Plane& p : planes) {
    if (std::abs(p.normal.dot(o)) >= kCosSide) continue;
    if (std::abs(p.distance(point)) <= on_point) continue;  // the pick's own: snapped from as given
    double nearest = reach;
    Vector3d at = point;
    for (auto i : p.inliers) {
      const Vector3d across = L.points[i] - point - (L.points[i] - point).dot(o) * o;
      if (across.norm() < nearest) {
        nearest = across.norm();
        at = point + across;
      }
    }
    if (nearest >= reach) continue;
    const Vector3d n_across = (p.normal - p.normal.dot(o) * o).normalized();
    found.emplace_back(nearest, at - p.distance(at) / p.normal.dot(n_across) * n_across);
  }
  std::sort(found.begin(), found.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  std::vector<Vector3d> out;
  for (const auto& f : found) out.push_back(f.second);
  return out;
}

SnappedPoint snap_on_model(const CaseModel& model, const Vector3d& point,
                           const std::optional<Vector3d>& outward, const SnapOptions& options,
                           bool may_land);

}  // namespace

SnappedPoint snap_point(const CaseModel& model, const Vector3d& point,
                        const std::optional<Vector3d>& outward, const SnapOptions& options) {
  if (!point.allFinite()) throw InputError("measurement point has non-finite coordinates");
  const double off = model.distance_to_mesh(point);
  if (off > options.max_snap_distance_m)
    throw InputError(fmt::format(
        "point ({:.4f}, {:.4f}, {:.4f}) is off the model: the nearest surface is {:.3f} m away "
        "(at most {:.3f} m allowed); pick a point on a surface",
        point.x(), point.y(), point.z(), off, options.max_snap_distance_m));
  return snap_on_model(model, point, outward, options, true);
}

namespace {

bool by_outermost_point(SnapFeature feature) {
  return feature == SnapFeature::EdgeOutermost || feature == SnapFeature::CornerOutermost;
}

// Not snapped where it was picked: landing on a surface nearby. Nearest landing first; the
// first from which the end snaps is taken (a spurious plane of mixed pixels, or a wall behind a
// window's edge, lands where nothing fixes the end). The move is across the measuring line: it
// changes neither the distance nor its uncertainty.
SnappedPoint snap_or_land(const CaseModel& model, const Vector3d& point, const Vector3d& outward,
                          const SnapOptions& options, const LocalPoints& L, double radius,
                          const std::vector<Plane>& planes, double threshold) {
  SnappedPoint direct = snap_on_model(model, point, outward, options, false);
  // An end fixed only by the outermost of too few points to count is the weakest snap: a
  // landing beside it (the same place along the line) that counts its edge or meets a face is
  // better evidence of the same end.
  if (is_snapped(direct.feature) && !by_outermost_point(direct.feature)) return direct;
  const Vector3d o = outward.normalized();
  const double on_point = std::max(0.006, threshold);
  std::vector<Vector3d> landings = landing_candidates(planes, L, point, o, on_point, options.search_radius_m);
  // Nothing seen within reach: look twice as far (unless L already did: a sparse spot).
  if (landings.empty() && planes.empty() && radius < 2 * options.search_radius_m) {
    const LocalPoints wide = model.local_points(point, 2 * options.search_radius_m);
    landings = landing_candidates(find_planes(wide, threshold, options.min_plane_points), wide, point, o,
                                  on_point, options.search_radius_m);
  }
  for (const Vector3d& landed : landings) {
    SnappedPoint moved = snap_on_model(model, landed, outward, options, false);
    if (!is_snapped(moved.feature) || (is_snapped(direct.feature) && by_outermost_point(moved.feature)))
      continue;
    moved.given = point;
    return moved;
  }
  return direct;
}

// Whether an end found `along` o from `from` is within reach of the click there: within the
// edge margin, or as far beyond it as the model's surface stands off the end - a click lands on
// the mesh, and fusion rounds a thin slab's corner away by centimetres (a table top 4 cm thick
// seen from above by a noisy sensor), so a click on what the model shows is that far short.
// What the mesh does show beyond the margin (a wall 2.9 cm behind a table's end, a surface
// going on to the neighbourhood's boundary) is not the end the click was on.
bool within_reach(const CaseModel& model, const Vector3d& from, const Vector3d& o, double along,
                  double margin) {
  return along <= margin || along < margin + model.distance_to_mesh(from + along * o);
}

// The planes that fix an end measured along o: the largest one facing the line (crossed by it
// where it has points, within the snap distance) and those the line runs along through the
// point (side planes: their edge along o is the end).
struct LinePlanes {
  const Plane* facing = nullptr;
  std::vector<const Plane*> side;
};

LinePlanes planes_at_line(const CaseModel& model, const std::vector<Plane>& planes,
                          const LocalPoints& L, const Vector3d& point, const Vector3d& o,
                          double on_point, const SnapOptions& options) {
  LinePlanes found;
  for (const Plane& p : planes) {
    const double c = p.normal.dot(o);
    if (std::abs(c) >= kCosFacing) {
      const double t = -p.distance(point) / c;
      if (std::abs(t) > options.max_snap_distance_m) continue;
      if (!within_reach(model, point, o, t, options.edge_margin_m)) continue;
      // It must have points where the line through p along o crosses it.
      const Vector3d x = point + t * o;
      std::size_t near_line = 0;
      for (auto i : p.inliers) near_line += (L.points[i] - x).norm() <= 0.015;
      if (near_line < 5) continue;
      if (!found.facing || p.inliers.size() > found.facing->inliers.size()) found.facing = &p;
    } else if (std::abs(c) < kCosSide && std::abs(p.distance(point)) <= on_point) {
      found.side.push_back(&p);
    }
  }
  // Two side planes within 30 degrees of each other meet far from the pick: one is a sliver of
  // the other (the band of a rounded edge, a tilted fit of a few points), and moving onto both
  // would carry the end away. The larger one is kept (planes come largest first).
  std::vector<const Plane*> distinct;
  for (const Plane* p : found.side) {
    bool sliver = false;
    for (const Plane* kept : distinct) sliver |= std::abs(p->normal.dot(kept->normal)) > std::cos(30.0 * M_PI / 180.0);
    if (!sliver) distinct.push_back(p);
  }
  found.side.swap(distinct);
  return found;
}

// A facing plane ends the side planes: their points stop where the line crosses it (a box's
// top at its end face, the floor at a wall). Side points well past the crossing (more than the
// inlier band twice over, or the edge margin) mean the facing plane is not where that side
// ends - a few points fitted across a rounded edge or a band of mixed pixels, tilted 30 degrees
// off the face it is not - or that the side is a face flush with another that goes on (a bed's
// side and its headboard's, one plane). Split: the side planes that run on past it, and those
// that reach it and stop there.
struct SidesAtFacing {
  std::vector<const Plane*> run_on, stop;
};

SidesAtFacing sides_at_facing(const Plane& facing, const std::vector<const Plane*>& side,
                              const LocalPoints& L, const Vector3d& q, const Vector3d& o,
                              double threshold, const SnapOptions& options) {
  const double t = -facing.distance(q) / facing.normal.dot(o);
  const double tolerance = std::max(2.0 * threshold, options.edge_margin_m);
  SidesAtFacing found;
  for (const Plane* p : side) {
    const Vector3d along_edge = p->normal.cross(o).normalized();
    std::size_t past = 0;
    double farthest = -std::numeric_limits<double>::infinity();
    for (auto i : p->inliers) {
      const Vector3d rel = L.points[i] - q;
      if (std::abs(rel.dot(along_edge)) > kEdgeBandM) continue;
      past += rel.dot(o) > t + tolerance;
      farthest = std::max(farthest, rel.dot(o));
    }
    if (past >= 10)
      found.run_on.push_back(p);
    else if (farthest >= t - tolerance)
      found.stop.push_back(p);
  }
  return found;
}

// Whether the facing plane is this end, and which side planes end there: where some side runs
// on past the facing plane, it is the end only if another side reaches it and stops (the bed's
// top at the headboard); the one running on is then not this end's edge.
bool facing_ends_sides(const Plane& facing, std::vector<const Plane*>& side, const LocalPoints& L,
                       const Vector3d& q, const Vector3d& o, double threshold,
                       const SnapOptions& options) {
  SidesAtFacing split = sides_at_facing(facing, side, L, q, o, threshold, options);
  if (split.run_on.empty()) return true;
  if (split.stop.empty()) return false;
  side.swap(split.stop);
  return true;
}

// Side planes: q moves perpendicular to o onto them (minimum-norm solution); their offsets'
// variance joins the covariance.
void move_onto_side_planes(const std::vector<const Plane*>& side, const LocalPoints& L,
                           const Vector3d& o, Vector3d& q, Matrix3d& cov) {
  Eigen::MatrixXd A(static_cast<long>(side.size()) + 1, 3);
  Eigen::VectorXd r(static_cast<long>(side.size()) + 1);
  for (std::size_t i = 0; i < side.size(); ++i) {
    A.row(static_cast<long>(i)) = side[i]->normal.transpose();
    r[static_cast<long>(i)] = -side[i]->distance(q);
  }
  A.row(static_cast<long>(side.size())) = o.transpose();
  r[static_cast<long>(side.size())] = 0.0;
  const Vector3d delta = A.completeOrthogonalDecomposition().solve(r);
  q += delta;
  for (const Plane* p : side) cov += p->normal * p->normal.transpose() * plane_offset_variance(*p, L);
}

// The side planes' points near the end, per view: (points in the window [-2w, -w] along o,
// points beyond -w, the view's sampling step), and the farthest point along o.
struct EdgeCounts {
  std::map<std::uint32_t, std::array<double, 3>> per_view;
  double farthest = -std::numeric_limits<double>::infinity();
  // The window's and the beyond's points over all views.
  double window() const { return pooled(0); }
  double beyond() const { return pooled(1); }

 private:
  double pooled(std::size_t k) const {
    double total = 0;
    for (const auto& [view, e] : per_view) total += e[k];
    return total;
  }
};

// The outermost point along o, leaving out one or two strays beyond a gap: a mixed pixel past
// the edge decides "the surface goes on" where too few points lie just inside the end to count
// them (a chair's seat seen past its back). The gap must exceed three sampling steps (a surface
// that goes on is sampled about every step, in every view) and twice the edge margin.
double outermost_supported(std::vector<std::pair<double, double>> reach, double margin) {
  if (reach.empty()) return -std::numeric_limits<double>::infinity();
  std::sort(reach.begin(), reach.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<double> steps;
  for (const auto& r : reach) steps.push_back(r.second);
  const double gap = std::max(3.0 * median(steps), 2.0 * margin);
  for (std::size_t strays = 1; strays <= 2 && strays + 3 <= reach.size(); ++strays)
    if (reach[strays - 1].first - reach[strays].first > gap) return reach[strays].first;
  return reach.front().first;
}

// A raw point moved along its camera ray onto the plane. Depth noise moves a point along its
// ray: an error e puts it e cos(incidence) off the plane and nearly e along it, so on a surface
// seen at grazing incidence a point within the inlier band may have slid band / cos(incidence)
// along it - centimetres past a table top's edge seen from just above it. On the ray, the
// point is where its pixel saw the plane - the edge lies within a pixel footprint of the last
// one. Rays within 3 degrees of the plane are left where they are.
Vector3d on_plane_along_ray(const Vector3d& camera, const Vector3d& x, const Plane& plane) {
  const Vector3d ray = x - camera;
  const double along = plane.normal.dot(ray);
  if (std::abs(along) < std::sin(3.0 * M_PI / 180.0) * ray.norm()) return x;
  return camera + (-plane.distance(camera) / along) * ray;
}

// Counts the side planes' points within `band` of the measuring line along the edge (and on
// the plane), leaving out those marked foreign (points_on_other_surfaces). `every_point`
// false: each plane's inliers; true: every point of `pts` on a side plane (a straight edge
// followed farther along itself, in a wider neighbourhood with planes of its own).
EdgeCounts count_edge_points(const CaseModel& model, const LocalPoints& pts,
                             const std::vector<const Plane*>& side, const Vector3d& q,
                             const Vector3d& o, double m, double margin, double threshold,
                             double band, const std::vector<bool>& foreign, bool every_point) {
  EdgeCounts counts;
  std::vector<std::pair<double, double>> reach;  // (along o, sampling step) of each point
  const CameraIntrinsics& K = model.intrinsics();
  for (const Plane* p : side) {
    const Vector3d along_edge = p->normal.cross(o).normalized();
    auto visit = [&](std::uint32_t i) {
      const Vector3d& x = pts.points[i];
      if (foreign[i] || (every_point && std::abs(p->distance(x)) > threshold)) return;
      // A raw point is counted where its ray meets the plane, with its pixel's footprint as
      // the sampling step (mesh vertices: as they are, the voxel); the outermost point is taken
      // as seen (lateral noise carries rays just past the edge onto the plane, a footprint
      // further out than depth noise does).
      Vector3d counted_at = x;
      double step = model.model_voxel_m();
      if (pts.from_raw_depth) {
        const Vector3d camera = model.views()[pts.view[i]].T_world_camera.translation();
        const Vector3d ray = x - camera;
        counted_at = on_plane_along_ray(camera, x, *p);
        step = ray.norm() / K.fx / std::max(0.25, std::abs(ray.normalized().dot(p->normal)));
      }
      const Vector3d rel = counted_at - q;
      const double s_along = rel.dot(o);
      if (std::abs(rel.dot(along_edge)) > band) return;
      reach.emplace_back((x - q).dot(o), step);
      auto& e = counts.per_view[pts.view[i]];
      if (s_along >= -2 * m && s_along < -m) e[0] += 1;
      if (s_along >= -m) e[1] += 1;
      e[2] = std::max(e[2], step);
    };
    if (every_point)
      for (std::uint32_t i = 0; i < pts.points.size(); ++i) visit(i);
    else
      for (auto i : p->inliers) visit(i);
  }
  counts.farthest = outermost_supported(std::move(reach), margin);
  return counts;
}

// A surface across the side planes (the wall a radiator's side runs into, the floor at a
// cylinder's foot) crosses them in a line of points that would read as the side going on:
// points on planes of their own, at more than 20 degrees to every side plane, are marked.
// `nearer_too` (the neighbourhood at the line): so are points within such a plane's inlier
// band that lie nearer to it than to every side plane. Sequential RANSAC gives the first
// (largest) plane the strip of the other surface within its band: with structured light's
// 1.8 cm band at 2 m, the floor's strip before a cylinder's foot and the cap's beside its rim
// counted as its wall going on, 9-13 mm past each end (a 24 cm cylinder's height measured 2 cm
// long at U 12 mm). Not along a hidden edge's 8 cm band, where it carried the bedroom's
// cupboard door 2 cm past its edge.
std::vector<bool> points_on_other_surfaces(const LocalPoints& pts, const std::vector<const Plane*>& side,
                                           const std::vector<Plane>& planes, double threshold,
                                           bool nearer_too) {
  std::vector<bool> foreign(pts.points.size(), false);
  for (const Plane& w : planes) {
    bool along_a_side = false;
    for (const Plane* p : side) along_a_side |= std::abs(w.normal.dot(p->normal)) > std::cos(20.0 * M_PI / 180.0);
    if (along_a_side) continue;
    for (auto i : w.inliers) foreign[i] = true;
    for (std::uint32_t i = 0; nearer_too && i < pts.points.size(); ++i) {
      const double off = std::abs(w.distance(pts.points[i]));
      if (foreign[i] || off > threshold) continue;
      bool nearer = true;
      for (const Plane* p : side) nearer &= off < std::abs(p->distance(pts.points[i]));
      foreign[i] = nearer;
    }
  }
  return foreign;
}

// The end along o from the counts. Counting, per view: with w = edge_window_m, the points in
// the window [-2w, -w] give the view's density along o, and the points beyond -w, divided by
// that density, how far the surface goes on:
//   edge_k = -w + w * N_beyond / N_window.
// Unlike the outermost point, this is unbiased under lateral noise (points move across the
// edge both ways) and barely moved by a stray mixed pixel. Pooled over the views (each weighs
// by its density), with a leave-one-view-out jackknife for the spread between views. Moves q
// along o and adds the variance along o to cov.
SnapFeature edge_from_counts(const CaseModel& model, const EdgeCounts& counts, std::size_t sides,
                             double m, Vector3d& q, const Vector3d& o, Matrix3d& cov) {
  const double window = counts.window(), beyond = counts.beyond();
  std::vector<double> steps;
  for (const auto& [view, e] : counts.per_view) steps.push_back(e[2]);
  const double step = median(steps);
  const double lateral = model.noise().lateral_sigma_m(1.0);
  if (window < 8) {
    // Too few points just inside the edge to count: the outermost point plus half a sampling
    // step, with a conservative uncertainty (a step / sqrt(3) and the lateral noise, not
    // reduced by the number of views).
    q += (counts.farthest + 0.5 * step) * o;
    cov += o * o.transpose() * (step * step / 3.0 + lateral * lateral);
    return sides == 1 ? SnapFeature::EdgeOutermost : SnapFeature::CornerOutermost;
  }
  const double edge = -m + m * beyond / window;
  double jack = 0.0;
  std::size_t used = 0;
  for (const auto& [view, e] : counts.per_view) {
    if (window - e[0] < 1) continue;
    const double ek = -m + m * (beyond - e[1]) / (window - e[0]);
    jack += (ek - edge) * (ek - edge);
    ++used;
  }
  const double n = static_cast<double>(std::max<std::size_t>(used, 1));
  jack *= (n - 1) / n;
  q += edge * o;
  // The jackknife spread of the views, the counting noise (Poisson in both windows), the
  // quantisation of a count (a step / sqrt(12)) and the sensor's lateral noise per view.
  // var(b / w) ~ var(b) / w^2 + b^2 var(w) / w^4, each count's variance taken as n + 1 (the
  // posterior of a Poisson rate under a flat prior): a count of 0 or 1 points says little, and
  // the plain n would call it nearly exact.
  const double counting = m * m * ((beyond + 1.0) / (window * window) +
                                   beyond * beyond * (window + 1.0) /
                                       (window * window * window * window));
  // Mixed pixels between the edge and a surface close behind it (less than the mixed-pixel
  // filter's jump) land on the plane within about half a step either side of the edge: a
  // systematic of uniform width one step, the same in every view.
  const double mixed = step * step / 12.0;
  const double var = jack + counting + step * step / 12.0 / n + lateral * lateral / n + mixed;
  cov += o * o.transpose() * var;
  return sides == 1 ? SnapFeature::Edge : SnapFeature::Corner;
}

// Whether the side planes end within reach of the pick along o. With enough points just
// inside the end to count (the window), by the count (edge_from_counts): the farthest point
// alone runs past a real end by the lateral noise and the mixed pixels - a pixel's footprint,
// over a centimetre on a far or oblique surface - while a surface that goes on past the pick
// counts to the edge of the neighbourhood (within_reach). Too few to count: the farthest point,
// within the margin either way - a farthest point of a few dozen points (a plane fitted 45
// degrees off to the bulge the mesh shows at a far table's corner) is not evidence enough to
// reach past it, nor one that stops more than the margin short of the pick: the surface the
// pick is on runs on past where these few points end (a side plane seen by one view, 5 cm back).
bool end_within_reach(const CaseModel& model, const EdgeCounts& counts, double m, double margin,
                      const Vector3d& q, const Vector3d& o) {
  if (counts.per_view.empty()) return false;
  if (counts.window() < 8) return std::abs(counts.farthest) < margin;
  return within_reach(model, q, o, -m + m * counts.beyond() / counts.window(), margin);
}

// Where the side planes' points end along o, near the line through q; views whose window is
// mostly hidden (fewer than 6 points) are skipped. NotSnapped when the surface goes on past
// the point (moved onto the side planes, across the line, but nothing fixes it along the line).
SnapFeature snap_to_side_edge(const CaseModel& model, const LocalPoints& L,
                              const std::vector<Plane>& planes,
                              const std::vector<const Plane*>& side, const Vector3d& o,
                              double threshold, const SnapOptions& options, Vector3d& q,
                              Matrix3d& cov, std::size_t& points_used) {
  const double m = options.edge_window_m;
  EdgeCounts counts = count_edge_points(model, L, side, q, o, m, options.edge_margin_m, threshold, kEdgeBandM,
                                        points_on_other_surfaces(L, side, planes, threshold, true), false);
  if (counts.window() < 8) {
    // Too few points to count here: the straight edge followed along itself, taken where
    // there it has enough to count - something in front hides the edge at the line (a handle
    // before a door), or a far top seen at grazing incidence has a footprint of centimetres a
    // pixel. Where it has not, the outermost point near the line stays the estimate: 8 cm
    // along the edge hold strays enough to carry it past the end (a mixed pixel on the
    // plane's extension 5 cm before the bedroom chair's seat).
    const LocalPoints wide = model.local_points(q, options.edge_follow_m);
    const std::vector<bool> foreign = points_on_other_surfaces(
        wide, side, find_planes(wide, threshold, options.min_plane_points, 6), threshold, false);
    EdgeCounts along = count_edge_points(model, wide, side, q, o, m, options.edge_margin_m,
                                         threshold, options.edge_follow_m, foreign, true);
    points_used += wide.points.size();
    if (along.window() >= 8) counts = std::move(along);
  }
  if (end_within_reach(model, counts, m, options.edge_margin_m, q, o))
    return edge_from_counts(model, counts, side.size(), m, q, o, cov);
  return SnapFeature::NotSnapped;
}

// An end with no measuring direction: the nearest plane's foot, or the mesh's nearest point.
SnappedPoint snap_without_direction(const CaseModel& model, SnappedPoint s, const LocalPoints& L,
                                    const std::vector<Plane>& planes, const Matrix3d& pose_cov) {
  const Vector3d point = s.given;
  if (planes.empty()) {
    s.snapped = nearest_on_mesh(model, point);
    s.feature = SnapFeature::MeshSurface;
    const double v = model.model_voxel_m();
    s.covariance = Matrix3d::Identity() * (v * v / 12.0) + pose_cov;
    return s;
  }
  const Plane* nearest = &planes[0];
  for (const Plane& p : planes)
    if (std::abs(p.distance(point)) < std::abs(nearest->distance(point))) nearest = &p;
  s.snapped = point - nearest->distance(point) * nearest->normal;
  s.feature = SnapFeature::Face;
  Matrix3d cov = pose_cov;
  cov += nearest->normal * nearest->normal.transpose() * plane_offset_variance(*nearest, L);
  s.covariance = cov;
  return s;
}

// An end nothing fixed along the line is where it was picked, on the mesh, and the mesh
// alone says where the surface is there: the fusion averaged depth over its truncation band,
// and where no plane or edge was fitted (a corner it rounded, a thin edge, a face seen edge-on)
// it stands up to that far off the surface the views saw - 2-3.5 cm short at a far table's
// rounded corner. Taken as uniform within +- the truncation along the line: a "not snapped"
// end states how little it knows instead of the pose's millimetres (it is still never counted
// as measured within U).
Matrix3d as_picked_variance(const CaseModel& model, const Vector3d& o) {
  const double t = model.model_truncation_m();
  return o * o.transpose() * (t * t / 3.0);
}

// The raw points snapping looks at around a pick, the sphere's radius and the plane inlier
// band (2.5 axial sigmas, at least plane_inlier_m). The sphere grows twice over:
//  - where the spot was seen sparsely (far, at grazing incidence: a box's top seen from just
//    above it) it doubles, so that its faces hold enough points to be planes;
//  - a corner resolves from a plane cut across it only in a sphere several inlier bands wide
//    (a right-angle corner's diagonal cut holds both faces' points within 1.4 bands of the
//    edge, each face about half): structured light at 2-2.6 m has bands of 1.5-2.6 cm, and its
//    best plane in the 3 cm sphere was such a cut (rms 7-8 mm, 97 % of the points). At least
//    four bands, at most three search radii.
struct Neighbourhood {
  LocalPoints points;
  double radius = 0.0;
  double threshold = 0.0;
};

Neighbourhood neighbourhood_at(const CaseModel& model, const Vector3d& point,
                               const SnapOptions& options) {
  Neighbourhood n;
  n.radius = options.search_radius_m;
  n.points = model.local_points(point, n.radius);
  if (n.points.points.size() < 4 * options.min_plane_points) {
    n.radius = 2 * options.search_radius_m;
    n.points = model.local_points(point, n.radius);
  }
  n.threshold = std::max(options.plane_inlier_m, 2.5 * median(n.points.axial_sigma_m));
  const double bands = std::min(4.0 * n.threshold, 3.0 * options.search_radius_m);
  if (bands > n.radius) {
    n.radius = bands;
    n.points = model.local_points(point, n.radius);
  }
  return n;
}

SnappedPoint snap_on_model(const CaseModel& model, const Vector3d& point,
                           const std::optional<Vector3d>& outward, const SnapOptions& options,
                           bool may_land) {
  SnappedPoint s;
  s.given = point;
  s.snapped = point;
  const Neighbourhood around = neighbourhood_at(model, point, options);
  const LocalPoints& L = around.points;
  const double radius = around.radius, threshold = around.threshold;
  s.points = L.points.size();
  const std::vector<std::uint32_t> seen = model.observing_views(point);
  s.views = seen.size();
  const Matrix3d pose_cov = pose_covariance_at(model, point, seen);
  const std::vector<Plane> planes = find_planes(L, threshold, options.min_plane_points);
  s.planes = planes.size();
  if (outward && may_land) return snap_or_land(model, point, *outward, options, L, radius, planes, threshold);
  if (!outward) return snap_without_direction(model, s, L, planes, pose_cov);
  if (planes.empty()) {  // nothing to snap to across the line: as picked
    s.feature = SnapFeature::NotSnapped;
    s.covariance = pose_cov + as_picked_variance(model, outward->normalized());
    return s;
  }
  Matrix3d cov = pose_cov;
  const Vector3d o = outward->normalized();
  const double on_point = std::max(0.006, threshold);  // a side plane must pass through p
  LinePlanes at_line = planes_at_line(model, planes, L, point, o, on_point, options);
  Vector3d q = point;
  if (!at_line.side.empty()) move_onto_side_planes(at_line.side, L, o, q, cov);
  if (at_line.facing && !facing_ends_sides(*at_line.facing, at_line.side, L, q, o, threshold, options))
    at_line.facing = nullptr;  // not the end: the side planes' own end is counted instead
  if (at_line.facing) {
    const Plane& facing = *at_line.facing;
    const double t = -facing.distance(q) / facing.normal.dot(o);
    q += t * o;
    const double c = facing.normal.dot(o);
    cov += o * o.transpose() * (plane_offset_variance(facing, L) + plane_tilt_variance_at(facing, L, q)) / (c * c);
    const std::size_t sides = at_line.side.size();
    s.feature = sides == 0 ? SnapFeature::Face : (sides == 1 ? SnapFeature::Edge : SnapFeature::Corner);
  } else if (!at_line.side.empty()) {
    s.feature = snap_to_side_edge(model, L, planes, at_line.side, o, threshold, options, q, cov, s.points);
  } else {
    s.feature = SnapFeature::NotSnapped;  // no plane across the line, none along it
  }
  if (s.feature == SnapFeature::NotSnapped) cov += as_picked_variance(model, o);
  s.snapped = q;
  s.covariance = cov;
  return s;
}

}  // namespace

PlaneEstimate fit_plane_at(const CaseModel& model, const Vector3d& on_plane, double radius_m,
                           const SnapOptions& options) {
  const double off = model.distance_to_mesh(on_plane);
  if (off > options.max_snap_distance_m)
    throw InputError(fmt::format("plane point ({:.4f}, {:.4f}, {:.4f}) is off the model: the "
                                 "nearest surface is {:.3f} m away",
                                 on_plane.x(), on_plane.y(), on_plane.z(), off));
  const LocalPoints L = model.local_points(on_plane, radius_m);
  const double threshold = std::max(options.plane_inlier_m, 2.5 * median(L.axial_sigma_m));
  const std::vector<Plane> planes = find_planes(L, threshold, options.min_plane_points, 1);
  if (planes.empty())
    throw InputError(fmt::format("no plane found around ({:.4f}, {:.4f}, {:.4f}) within {:.3f} m",
                                 on_plane.x(), on_plane.y(), on_plane.z(), radius_m));
  const Plane& p = planes[0];
  PlaneEstimate e;
  e.normal = p.normal;
  e.point = on_plane - p.distance(on_plane) * p.normal;
  e.rms_m = p.rms;
  e.points = p.inliers.size();
  const Matrix3d pose = pose_covariance_at(model, e.point, model.observing_views(e.point));
  e.offset_sigma_m = std::sqrt(plane_offset_variance(p, L) + p.normal.dot(pose * p.normal));
  // Tilt of a least-squares plane: sigma ~ rms / sqrt(sum of squared in-plane distances).
  double spread = 0.0;
  for (auto i : p.inliers) {
    const Vector3d r = L.points[i] - e.point;
    spread += (r - r.dot(p.normal) * p.normal).squaredNorm() / 2.0;
  }
  e.normal_sigma_rad = spread > 0 ? p.rms / std::sqrt(spread) : 0.0;
  return e;
}

}  // namespace locard::forensics
