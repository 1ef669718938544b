#include <locard/preprocess/outlier_removal.hpp>

#include <locard/core/error.hpp>
#include <locard/core/kdtree.hpp>

#include "preprocess/point_status.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <string>

namespace locard {

namespace {

// Positions of the finite points and their input indices.
struct FinitePoints {
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::uint32_t> input_index;
};

FinitePoints finite_points(const PointCloud& cloud,
                           const std::vector<detail::PointStatus>& status) {
  FinitePoints finite;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (status[i] == detail::PointStatus::Keep) {
      finite.positions.push_back(cloud.positions[i]);
      finite.input_index.push_back(static_cast<std::uint32_t>(i));
    }
  }
  return finite;
}

}  // namespace

FilterResult remove_radius_outliers(const PointCloud& cloud,
                                    const RadiusOutlierOptions& options) {
  if (!(options.radius > 0.f) || !std::isfinite(options.radius) || options.min_neighbors < 0) {
    throw InputError("radius outlier removal: expected radius > 0 and min_neighbors >= 0, got "
                     "radius " + std::to_string(options.radius) + ", min_neighbors " +
                     std::to_string(options.min_neighbors));
  }
  cloud.check_consistent();
  std::vector<detail::PointStatus> status = detail::finite_status(cloud);
  const FinitePoints finite = finite_points(cloud, status);
  const KdTree tree(finite.positions);
  // Only whether min_neighbors other points exist matters: a hybrid search capped at
  // min_neighbors + 1 (the point itself included) answers that without listing them all.
  const int needed = options.min_neighbors + 1;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, finite.positions.size(), 512),
                    [&](const auto& range) {
                      std::vector<Neighbor> neighbors;
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        const std::size_t found =
                            tree.hybrid(finite.positions[i], options.radius, needed, neighbors);
                        if (found < static_cast<std::size_t>(needed)) {
                          status[finite.input_index[i]] = detail::PointStatus::Rejected;
                        }
                      }
                    });
  return detail::build_filter_result(cloud, status);
}

FilterResult remove_statistical_outliers(const PointCloud& cloud,
                                         const StatisticalOutlierOptions& options) {
  if (options.k < 1 || !(options.std_ratio >= 0.0)) {
    throw InputError("statistical outlier removal: expected k >= 1 and std_ratio >= 0, got k " +
                     std::to_string(options.k) + ", std_ratio " +
                     std::to_string(options.std_ratio));
  }
  cloud.check_consistent();
  std::vector<detail::PointStatus> status = detail::finite_status(cloud);
  const FinitePoints finite = finite_points(cloud, status);
  const std::size_t n = finite.positions.size();
  if (n < static_cast<std::size_t>(options.k) + 1) return detail::build_filter_result(cloud, status);

  // d_i: mean distance to the k nearest other points. With duplicates, "other" means any
  // k of the k + 1 nearest except the point itself.
  const KdTree tree(finite.positions);
  std::vector<double> mean_distance(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 512), [&](const auto& range) {
    std::vector<Neighbor> neighbors;
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      tree.knn(finite.positions[i], options.k + 1, neighbors);
      double sum = 0.0;
      int used = 0;
      for (const Neighbor& nb : neighbors) {
        if (nb.index == i || used == options.k) continue;
        sum += std::sqrt(static_cast<double>(nb.squared_distance));
        ++used;
      }
      mean_distance[i] = sum / used;
    }
  });
  // mu and the sample standard deviation sigma of the d_i (Rusu 2008, section IV-A).
  double mu = 0.0;
  for (double d : mean_distance) mu += d;
  mu /= static_cast<double>(n);
  double variance = 0.0;
  for (double d : mean_distance) variance += (d - mu) * (d - mu);
  const double sigma = std::sqrt(variance / static_cast<double>(n - 1));
  const double threshold = mu + options.std_ratio * sigma;
  for (std::size_t i = 0; i < n; ++i) {
    if (mean_distance[i] > threshold) status[finite.input_index[i]] = detail::PointStatus::Rejected;
  }
  return detail::build_filter_result(cloud, status);
}

}  // namespace locard
