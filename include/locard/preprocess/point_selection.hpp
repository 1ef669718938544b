#pragma once
// Subsets of a cloud, and the report every filter returns.
// Every filter in preprocess/ first drops points whose position has a NaN or Inf coordinate
// and counts them (FilterReport::non_finite): such points come from broken depth pixels or
// bad files, and a court-facing tool must say how many it discarded rather than hide them.

#include <locard/core/point_cloud.hpp>

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace locard {

struct FilterReport {
  std::size_t input_points = 0;
  std::size_t non_finite = 0;     // dropped: a NaN/Inf coordinate
  std::size_t rejected = 0;       // dropped by the filter's own criterion
  std::size_t output_points = 0;  // for the voxel grid: the number of occupied voxels
};

// The kept points and where they came from: cloud point i is input point indices[i]
// (increasing, so the input order is preserved).
struct FilterResult {
  PointCloud cloud;
  std::vector<std::uint32_t> indices;
  FilterReport report;
};

// True when all three coordinates are finite.
inline bool is_finite_point(const Eigen::Vector3f& p) { return p.allFinite(); }

// The points at `indices` (in that order) with every attribute: normals, colours, scalars.
PointCloud select_points(const PointCloud& cloud, std::span<const std::uint32_t> indices);

// Drops the points with a non-finite position; report.non_finite counts them and
// report.rejected stays 0. Throws locard::Error if the attribute arrays are out of step.
FilterResult remove_non_finite(const PointCloud& cloud);

}  // namespace locard
