// The tripod fit (tripod_fit.hpp): pan axis by vote, rings by clustering, refined by
// alternation.
#include "alignment/tripod_fit.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace locard::alignment_detail {
namespace {

constexpr double kDeg = M_PI / 180.0;

double angle_between_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) / kDeg;
}

std::vector<Eigen::Vector3d> camera_axes(const std::vector<Eigen::Matrix3d>& R,
                                         const Eigen::Vector3d& a) {
  std::vector<Eigen::Vector3d> u(R.size());
  for (std::size_t i = 0; i < R.size(); ++i) u[i] = R[i].transpose() * a;
  return u;
}

// Step 1: pan axis candidates from pairs turned well apart, signed towards the cameras' up.
std::vector<Eigen::Vector3d> candidates(const std::vector<Eigen::Matrix3d>& R) {
  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  for (const Eigen::Matrix3d& r : R) up -= r.col(1);  // camera y points down the image
  std::vector<Eigen::Vector3d> out;
  for (std::size_t i = 0; i < R.size(); ++i)
    for (std::size_t k : {2, 3, 5, 8, 13, 21}) {
      if (i + k >= R.size()) break;
      const Eigen::AngleAxisd turn(R[i + k] * R[i].transpose());
      if (turn.angle() < 8.0 * kDeg || turn.angle() > 172.0 * kDeg) continue;
      out.push_back(turn.axis().dot(up) < 0.0 ? Eigen::Vector3d(-turn.axis()) : turn.axis());
    }
  // Enough that some pair lies within the refinement's reach of the true axis; the vote costs
  // n^2 per candidate, and tracking fits once per view.
  constexpr std::size_t kMaxCandidates = 64;
  if (out.size() <= kMaxCandidates) return out;
  std::vector<Eigen::Vector3d> thinned;
  for (std::size_t k = 0; k < kMaxCandidates; ++k) thinned.push_back(out[k * out.size() / kMaxCandidates]);
  return thinned;
}

// Step 2: how many pairs of views see the candidate axis the same way.
std::size_t votes(const std::vector<Eigen::Vector3d>& u, double vote_deg) {
  const double cos_vote = std::cos(vote_deg * kDeg);
  std::size_t score = 0;
  for (std::size_t i = 0; i < u.size(); ++i)
    for (std::size_t j = i + 1; j < u.size(); ++j) score += u[i].dot(u[j]) > cos_vote;
  return score;
}

// Step 3: ring axes, densest first; each ring holds enough views.
std::vector<Eigen::Vector3d> rings(const std::vector<Eigen::Vector3d>& u,
                                   const TripodFitOptions& o) {
  const double cos_dense = std::cos(o.inlier_deg * kDeg);
  std::vector<std::size_t> density(u.size(), 0);
  for (std::size_t i = 0; i < u.size(); ++i)
    for (std::size_t j = 0; j < u.size(); ++j) density[i] += u[i].dot(u[j]) > cos_dense;
  std::vector<std::size_t> order(u.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return density[a] > density[b]; });
  std::vector<Eigen::Vector3d> seeds;
  for (std::size_t i : order)
    if (std::none_of(seeds.begin(), seeds.end(), [&](const Eigen::Vector3d& s) {
          return angle_between_deg(s, u[i]) < o.ring_deg;
        }))
      seeds.push_back(u[i]);
  std::vector<std::size_t> members(seeds.size(), 0);
  for (const Eigen::Vector3d& v : u) {
    std::size_t best = 0;
    for (std::size_t r = 1; r < seeds.size(); ++r)
      if (v.dot(seeds[r]) > v.dot(seeds[best])) best = r;
    if (angle_between_deg(v, seeds[best]) < o.ring_deg) ++members[best];
  }
  const std::size_t largest = *std::max_element(members.begin(), members.end());
  const std::size_t needed = std::max(o.min_ring_views, (largest + 3) / 4);
  std::vector<Eigen::Vector3d> kept;
  for (std::size_t r = 0; r < seeds.size(); ++r)
    if (members[r] >= needed) kept.push_back(seeds[r]);
  return kept;
}

int nearest_ring(const Eigen::Vector3d& v, const std::vector<Eigen::Vector3d>& ring_axes) {
  int best = 0;
  for (int r = 1; r < static_cast<int>(ring_axes.size()); ++r)
    if (v.dot(ring_axes[r]) > v.dot(ring_axes[best])) best = r;
  return best;
}

// Step 4: alternate the rings' camera-frame axes and the world axis over the inliers; the
// first rounds take the whole ring (the vote's axis may be a little off), the last the inliers.
void refine(const std::vector<Eigen::Matrix3d>& R, TripodFit& fit, const TripodFitOptions& o) {
  constexpr int kRounds = 12;
  for (int round = 0; round < kRounds; ++round) {
    const double gate = round < kRounds / 3 ? o.ring_deg : o.inlier_deg;
    const std::vector<Eigen::Vector3d> u = camera_axes(R, fit.axis);
    std::vector<Eigen::Vector3d> ring_sum(fit.ring_axes.size(), Eigen::Vector3d::Zero());
    Eigen::Vector3d axis_sum = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < R.size(); ++i) {
      const int r = nearest_ring(u[i], fit.ring_axes);
      if (angle_between_deg(u[i], fit.ring_axes[r]) >= gate) continue;
      ring_sum[r] += u[i];
      axis_sum += R[i] * fit.ring_axes[r];
    }
    for (std::size_t r = 0; r < ring_sum.size(); ++r)
      if (ring_sum[r].norm() > 0.0) fit.ring_axes[r] = ring_sum[r].normalized();
    if (axis_sum.norm() > 0.0) fit.axis = axis_sum.normalized();
  }
}

}  // namespace

Eigen::Matrix3d onto_ring(const Eigen::Matrix3d& R, const Eigen::Vector3d& axis,
                          const Eigen::Vector3d& ring_axis) {
  const Eigen::Vector3d seen = R.transpose() * axis;
  return R * Eigen::Quaterniond::FromTwoVectors(ring_axis, seen).toRotationMatrix();
}

Eigen::Matrix3d onto_its_ring(const TripodFit& fit, std::size_t k, const Eigen::Matrix3d& R) {
  return onto_ring(R, fit.axis, fit.ring_axes[static_cast<std::size_t>(fit.ring[k])]);
}

std::optional<TripodFit> fit_tripod(const std::vector<Eigen::Matrix3d>& R,
                                    const TripodFitOptions& o) {
  if (R.size() < 2 * o.min_ring_views) return std::nullopt;
  const std::vector<Eigen::Vector3d> axes = candidates(R);
  if (axes.empty()) return std::nullopt;
  std::size_t best = 0, best_votes = 0;
  for (std::size_t k = 0; k < axes.size(); ++k) {
    const std::size_t v = votes(camera_axes(R, axes[k]), o.vote_deg);
    if (v > best_votes) {
      best_votes = v;
      best = k;
    }
  }
  TripodFit fit;
  fit.axis = axes[best];
  fit.ring_axes = rings(camera_axes(R, fit.axis), o);
  refine(R, fit, o);
  const std::vector<Eigen::Vector3d> u = camera_axes(R, fit.axis);
  std::size_t inliers = 0;
  for (const Eigen::Vector3d& v : u) {
    const int r = nearest_ring(v, fit.ring_axes);
    fit.ring.push_back(r);
    fit.off_axis_deg.push_back(angle_between_deg(v, fit.ring_axes[r]));
    inliers += fit.off_axis_deg.back() < o.inlier_deg;
  }
  if (static_cast<double>(inliers) < o.min_inlier_share * static_cast<double>(R.size()))
    return std::nullopt;
  return fit;
}

std::vector<std::size_t> densest_centres(const std::vector<Eigen::Isometry3d>& T, double radius) {
  const double r2 = radius * radius;
  std::vector<std::size_t> best;
  for (std::size_t i = 0; i < T.size(); ++i) {
    std::vector<std::size_t> near;
    for (std::size_t j = 0; j < T.size(); ++j)
      if ((T[j].translation() - T[i].translation()).squaredNorm() <= r2) near.push_back(j);
    if (near.size() > best.size()) best = std::move(near);
  }
  return best;
}

Eigen::Vector3d median_centre(const std::vector<Eigen::Isometry3d>& T) {
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  if (T.empty()) return m;
  std::vector<double> v(T.size());
  for (int axis = 0; axis < 3; ++axis) {
    for (std::size_t i = 0; i < T.size(); ++i) v[i] = T[i].translation()(axis);
    const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    m(axis) = *mid;
  }
  return m;
}

std::optional<std::vector<char>> which_views_off_tripod(const std::vector<Eigen::Isometry3d>& T,
                                                        double off_axis_deg, double residual_m) {
  std::vector<Eigen::Matrix3d> R;
  for (const Eigen::Isometry3d& t : T) R.push_back(t.linear());
  const std::optional<TripodFit> fit = fit_tripod(R);
  if (!fit) return std::nullopt;
  const NodalFit nodal = fit_nodal(T);
  std::vector<char> off(T.size());
  for (std::size_t i = 0; i < T.size(); ++i)
    off[i] = fit->off_axis_deg[i] >= off_axis_deg || nodal.residual_m[i] >= residual_m;
  return off;
}

std::optional<std::size_t> views_off_tripod(const std::vector<Eigen::Isometry3d>& T,
                                            double off_axis_deg, double residual_m) {
  const auto off = which_views_off_tripod(T, off_axis_deg, residual_m);
  if (!off) return std::nullopt;
  return static_cast<std::size_t>(std::count(off->begin(), off->end(), 1));
}

NodalFit fit_nodal(const std::vector<Eigen::Isometry3d>& T, double inlier_m) {
  NodalFit fit;
  std::vector<char> used(T.size(), 1);
  const auto residuals = [&] {
    fit.residual_m.clear();
    for (const Eigen::Isometry3d& t : T) fit.residual_m.push_back(fit.residual(t));
  };
  for (int round = 0; round < 3; ++round) {
    Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
    std::size_t n = 0;
    for (std::size_t i = 0; i < T.size(); ++i) {
      if (!used[i]) continue;
      Eigen::Matrix<double, 3, 6> A;
      A << Eigen::Matrix3d::Identity(), T[i].linear();
      H += A.transpose() * A;
      b += A.transpose() * T[i].translation();
      ++n;
    }
    if (n == 0) break;
    H.bottomRightCorner<3, 3>().diagonal().array() += 1e-6 * static_cast<double>(n);
    const Eigen::Matrix<double, 6, 1> x = H.ldlt().solve(b);
    if (!x.allFinite()) break;
    fit.pivot = x.head<3>();
    fit.offset = x.tail<3>();
    residuals();
    std::vector<double> sorted = fit.residual_m;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2),
                     sorted.end());
    const double gate = std::max(inlier_m, 3.0 * sorted[sorted.size() / 2]);
    for (std::size_t i = 0; i < T.size(); ++i) used[i] = fit.residual_m[i] <= gate;
  }
  if (fit.residual_m.size() != T.size()) residuals();
  return fit;
}

}  // namespace locard::alignment_detail
