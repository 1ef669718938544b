#pragma once
// Outlier removal (Rusu et al. 2008, "Towards 3D point cloud based object maps for household
// environments", section IV-A). Both filters are parallel (oneTBB) and keep the input order.
// Non-finite points are dropped first and counted in report.non_finite.

#include <locard/preprocess/point_selection.hpp>

namespace locard {

class KdTree;

// Keeps a point when at least `min_neighbors` OTHER points (the point itself not counted) lie
// within `radius` metres (plain distance, not squared).
struct RadiusOutlierOptions {
  float radius = 0.05f;
  int min_neighbors = 4;
};
FilterResult remove_radius_outliers(const PointCloud& cloud,
                                    const RadiusOutlierOptions& options);

// For each point, d_i = mean distance to its k nearest OTHER points. With mu and sigma the mean
// and sample standard deviation (n - 1) of all d_i, a point is kept when
//   d_i <= mu + std_ratio * sigma.
// Clouds with fewer than k + 1 points are returned unchanged (no statistics to speak of).
struct StatisticalOutlierOptions {
  int k = 20;
  double std_ratio = 2.0;
};
FilterResult remove_statistical_outliers(const PointCloud& cloud,
                                         const StatisticalOutlierOptions& options);

}  // namespace locard
