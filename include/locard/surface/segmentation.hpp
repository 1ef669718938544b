#pragma once
// Region-growing segmentation of a point cloud with normals (Rabbani et al. 2006, "Segmentation
// of point clouds using smoothness constraint"; the paper's section III-F):
//  - seeds are taken in order of increasing curvature (ties by index), so flat regions start
//    first and the result does not depend on the thread count;
//  - a region grows from a point p to a neighbour q (within `radius`, at most `max_neighbors`)
//    when the angle between their normals is below `max_angle_deg` (|n_p . n_q|, normals may
//    be flipped) and q is still unlabelled;
//  - q becomes a new growth front only when its curvature is below `max_curvature` (edges and
//    corners stop the growth instead of leaking over them);
//  - regions smaller than `min_points` are dissolved (label -1).
// Labels are 0..segments-1 in order of decreasing size (ties by smallest point index).
// Curvature is the "curvature" scalar field (see estimate_normals with compute_curvature);
// normals must be present. Throws InputError otherwise.

#include <locard/core/point_cloud.hpp>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace locard {

struct RegionGrowingOptions {
  float radius = 0.05f;       // metres, not squared
  int max_neighbors = 30;
  double max_angle_deg = 8.0;
  double max_curvature = 0.02;
  std::size_t min_points = 50;
};

struct Segmentation {
  std::vector<std::int32_t> labels;  // one per point; -1 = in no segment
  std::vector<std::size_t> sizes;    // points per segment, decreasing
};

Segmentation region_growing(const PointCloud& cloud, const RegionGrowingOptions& options = {});

// Adds (or replaces) the scalar field "segment" with the labels, so PLY export keeps them.
void attach_segment_labels(PointCloud& cloud, const Segmentation& segmentation);

}  // namespace locard
