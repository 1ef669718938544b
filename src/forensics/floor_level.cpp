#include <locard/forensics/floor_level.hpp>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

namespace locard::forensics {
namespace {

constexpr double kDeg = M_PI / 180.0;

struct Plane {
  Eigen::Vector3d normal;  // unit, towards up
  double offset = 0.0;     // normal . p = offset on the plane
};

struct Count {
  std::size_t on = 0, below = 0;
};

Count count_points(const std::vector<Eigen::Vector3d>& points, const Plane& plane, double distance) {
  Count c;
  for (const Eigen::Vector3d& p : points) {
    const double d = plane.normal.dot(p) - plane.offset;
    c.on += std::abs(d) <= distance;
    c.below += d < -distance;
  }
  return c;
}

// Least squares: the plane through the inliers' centroid, normal the smallest principal axis.
Plane refit(const std::vector<Eigen::Vector3d>& points, const Plane& plane, double distance,
            const Eigen::Vector3d& up, double* rms, std::size_t* inliers) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  std::vector<const Eigen::Vector3d*> on;
  for (const Eigen::Vector3d& p : points)
    if (std::abs(plane.normal.dot(p) - plane.offset) <= distance) on.push_back(&p);
  for (const auto* p : on) mean += *p;
  mean /= static_cast<double>(on.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto* p : on) scatter += (*p - mean) * (*p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);
  Plane out;
  out.normal = eig.eigenvectors().col(0);
  if (out.normal.dot(up) < 0) out.normal = -out.normal;
  out.offset = out.normal.dot(mean);
  double sum = 0.0;
  for (const auto* p : on) sum += std::pow(out.normal.dot(*p) - out.offset, 2);
  *rms = std::sqrt(sum / static_cast<double>(on.size()));
  *inliers = on.size();
  return out;
}

}  // namespace

std::optional<FloorLevel> find_floor_level(const std::vector<Eigen::Vector3d>& points,
                                           const Eigen::Vector3d& up_guess,
                                           const FloorLevelOptions& o) {
  if (points.size() < 3 || !(up_guess.norm() > 1e-9)) return std::nullopt;
  const Eigen::Vector3d up = up_guess.normalized();
  // The lowest share of the points along the guess: the floor is below the furniture.
  std::vector<std::size_t> order(points.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  const auto low_count = std::max<std::size_t>(
      3, static_cast<std::size_t>(o.lowest_share * static_cast<double>(points.size())));
  std::nth_element(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(low_count - 1),
                   order.end(), [&](std::size_t a, std::size_t b) {
                     return up.dot(points[a]) < up.dot(points[b]);
                   });
  order.resize(low_count);

  std::mt19937_64 rng(o.seed);
  std::uniform_int_distribution<std::size_t> pick(0, order.size() - 1);
  const double cos_tilt = std::cos(o.max_tilt_deg * kDeg);
  Plane best{up, 0.0};
  std::size_t best_count = 0;
  for (int it = 0; it < o.iterations; ++it) {
    const Eigen::Vector3d& a = points[order[pick(rng)]];
    const Eigen::Vector3d& b = points[order[pick(rng)]];
    const Eigen::Vector3d& c = points[order[pick(rng)]];
    Eigen::Vector3d n = (b - a).cross(c - a);
    if (n.norm() < 1e-9) continue;
    n.normalize();
    if (n.dot(up) < 0) n = -n;
    if (n.dot(up) < cos_tilt) continue;  // a wall or a slope, not a floor
    const Plane plane{n, n.dot(a)};
    const Count count = count_points(points, plane, o.inlier_distance_m);
    // Nothing is under a floor but outliers: a plane with much below it cuts through walls.
    if (static_cast<double>(count.below) > o.max_below_share * static_cast<double>(points.size()))
      continue;
    if (count.on > best_count) {
      best_count = count.on;
      best = plane;
    }
  }
  const auto needed = std::max(o.min_inliers, static_cast<std::size_t>(
                                                  o.min_inlier_share * static_cast<double>(points.size())));
  if (best_count < needed) return std::nullopt;
  FloorLevel f;
  const Plane fitted = refit(points, best, o.inlier_distance_m, up, &f.rms_m, &f.inliers);
  if (fitted.normal.dot(up) < cos_tilt) return std::nullopt;
  f.points = points.size();
  f.normal = fitted.normal;
  f.height_m = fitted.offset;
  f.tilt_deg = std::acos(std::clamp(f.normal.z(), -1.0, 1.0)) / kDeg;
  f.R_level = Eigen::Quaterniond::FromTwoVectors(f.normal, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return f;
}

}  // namespace locard::forensics
