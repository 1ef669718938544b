// ATE and RPE with the TUM benchmark's definitions (see trajectory_eval.hpp).
#include <locard/alignment/trajectory_eval.hpp>

#include <locard/core/error.hpp>
#include <locard/registration/rigid_transform.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <tuple>
#include <unordered_map>

namespace locard {

std::vector<TrajectoryAssociation> associate_trajectories(const Trajectory& ground_truth,
                                                          const Trajectory& estimate,
                                                          const AssociationOptions& options) {
  std::vector<TrajectoryAssociation> out;
  if (options.match_by_frame_index) {
    std::unordered_map<std::int64_t, std::size_t> by_index;
    for (std::size_t i = 0; i < ground_truth.size(); ++i)
      by_index.emplace(ground_truth[i].frame_index, i);
    for (std::size_t j = 0; j < estimate.size(); ++j) {
      auto it = by_index.find(estimate[j].frame_index);
      if (it != by_index.end()) out.push_back({it->second, j});
    }
  } else {
    // Candidates within the tolerance, taken greedily by time difference (evaluate_ate.py).
    // Both lists sorted by time make the candidate search a sliding window.
    std::vector<std::size_t> gt_order(ground_truth.size()), est_order(estimate.size());
    std::iota(gt_order.begin(), gt_order.end(), 0);
    std::iota(est_order.begin(), est_order.end(), 0);
    std::stable_sort(gt_order.begin(), gt_order.end(), [&](std::size_t a, std::size_t b) {
      return ground_truth[a].timestamp < ground_truth[b].timestamp;
    });
    std::stable_sort(est_order.begin(), est_order.end(), [&](std::size_t a, std::size_t b) {
      return estimate[a].timestamp < estimate[b].timestamp;
    });
    std::vector<std::tuple<double, std::size_t, std::size_t>> candidates;
    std::size_t lo = 0;
    for (std::size_t a : gt_order) {
      const double ta = ground_truth[a].timestamp;
      while (lo < est_order.size() &&
             estimate[est_order[lo]].timestamp + options.time_offset <=
                 ta - options.max_time_difference)
        ++lo;
      for (std::size_t k = lo; k < est_order.size(); ++k) {
        const std::size_t b = est_order[k];
        const double diff = estimate[b].timestamp + options.time_offset - ta;
        if (diff >= options.max_time_difference) break;
        if (std::abs(diff) < options.max_time_difference)
          candidates.emplace_back(std::abs(diff), a, b);
      }
    }
    std::sort(candidates.begin(), candidates.end());
    std::vector<char> gt_used(ground_truth.size(), 0), est_used(estimate.size(), 0);
    for (const auto& [diff, a, b] : candidates) {
      if (gt_used[a] || est_used[b]) continue;
      gt_used[a] = est_used[b] = 1;
      out.push_back({a, b});
    }
  }
  std::sort(out.begin(), out.end(), [&](const auto& x, const auto& y) {
    const double tx = ground_truth[x.ground_truth].timestamp;
    const double ty = ground_truth[y.ground_truth].timestamp;
    return tx != ty ? tx < ty : x.ground_truth < y.ground_truth;
  });
  return out;
}

ErrorStatistics error_statistics(std::vector<double> errors) {
  ErrorStatistics s;
  if (errors.empty()) return s;
  const double n = static_cast<double>(errors.size());
  double sum = 0.0, sum_sq = 0.0;
  for (double e : errors) {
    sum += e;
    sum_sq += e * e;
  }
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  double var = 0.0;
  for (double e : errors) var += (e - s.mean) * (e - s.mean);
  s.std_dev = std::sqrt(var / n);
  std::sort(errors.begin(), errors.end());
  s.min = errors.front();
  s.max = errors.back();
  const std::size_t m = errors.size() / 2;
  s.median = errors.size() % 2 ? errors[m] : 0.5 * (errors[m - 1] + errors[m]);
  return s;
}

AteResult absolute_trajectory_error(const Trajectory& ground_truth, const Trajectory& estimate,
                                    const AssociationOptions& options, bool align) {
  AteResult r;
  r.associations = associate_trajectories(ground_truth, estimate, options);
  r.pairs = r.associations.size();
  if (r.pairs < 3)
    throw InputError(fmt::format(
        "ATE: only {} pose pair{} associate (ground truth {} poses, estimate {} poses, {}); at "
        "least 3 are needed",
        r.pairs, r.pairs == 1 ? "" : "s", ground_truth.size(), estimate.size(),
        options.match_by_frame_index
            ? std::string("matched by frame index")
            : fmt::format("time tolerance {} s", options.max_time_difference)));
  std::vector<Eigen::Vector3d> est_t(r.pairs), gt_t(r.pairs);
  for (std::size_t k = 0; k < r.pairs; ++k) {
    gt_t[k] = ground_truth[r.associations[k].ground_truth].T_world_camera.translation();
    est_t[k] = estimate[r.associations[k].estimate].T_world_camera.translation();
  }
  if (align) {
    const auto S = estimate_rigid_transform(est_t, gt_t);
    if (!S)
      throw InputError(fmt::format("ATE: the {} associated camera positions are collinear or "
                                   "coincide; no unique rigid alignment exists",
                                   r.pairs));
    r.T_groundtruth_estimate = *S;
  }
  r.errors.resize(r.pairs);
  for (std::size_t k = 0; k < r.pairs; ++k)
    r.errors[k] = (gt_t[k] - r.T_groundtruth_estimate * est_t[k]).norm();
  r.translation = error_statistics(r.errors);
  return r;
}

RpeResult relative_pose_error(const Trajectory& ground_truth, const Trajectory& estimate,
                              const AssociationOptions& association, const RpeOptions& options) {
  if (!(options.delta > 0.0))
    throw InputError(fmt::format("RPE: delta must be positive, got {}", options.delta));
  const auto pairs = associate_trajectories(ground_truth, estimate, association);
  std::vector<double> trans, rot;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    std::size_t l = pairs.size();
    if (options.unit == DeltaUnit::Frames) {
      const auto step = static_cast<std::size_t>(std::llround(options.delta));
      if (step >= 1 && k + step < pairs.size()) l = k + step;
    } else {
      const double want = estimate[pairs[k].estimate].timestamp + options.delta;
      double best = std::numeric_limits<double>::infinity();
      for (std::size_t m = k + 1; m < pairs.size(); ++m) {
        const double d = std::abs(estimate[pairs[m].estimate].timestamp - want);
        if (d < best) {
          best = d;
          l = m;
        }
      }
      // The partner must lie at t_k + delta (within the association tolerance), not merely be
      // the closest pose there is: near the end of the trajectory there may be none.
      if (best > association.max_time_difference) l = pairs.size();
    }
    if (l >= pairs.size()) continue;
    const Isometry3d& e0 = estimate[pairs[k].estimate].T_world_camera;
    const Isometry3d& e1 = estimate[pairs[l].estimate].T_world_camera;
    const Isometry3d& g0 = ground_truth[pairs[k].ground_truth].T_world_camera;
    const Isometry3d& g1 = ground_truth[pairs[l].ground_truth].T_world_camera;
    const Isometry3d E = (e0.inverse() * e1) * (g0.inverse() * g1).inverse();
    trans.push_back(E.translation().norm());
    rot.push_back(rotation_difference_deg(Isometry3d::Identity(), E));
  }
  if (trans.empty())
    throw InputError(fmt::format("RPE: no two of the {} associated poses are {} {} apart",
                                 pairs.size(), options.delta,
                                 options.unit == DeltaUnit::Frames ? "frames" : "seconds"));
  RpeResult r;
  r.pairs = trans.size();
  r.translation = error_statistics(std::move(trans));
  r.rotation_deg = error_statistics(std::move(rot));
  return r;
}

}  // namespace locard
