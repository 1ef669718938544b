#pragma once
// The paper's path for clouds without depth images (section III-G): a Delaunay-based
// triangulation of the merged, filtered cloud. CGAL's advancing-front surface reconstruction
// (Cohen-Steiner & Da, 2004) picks facets of the 3D Delaunay triangulation of the points,
// growing from the most plausible one; `radius_ratio_bound` rejects facets whose circumradius
// exceeds that multiple of the local edge length, `beta` (radians) bounds the angle between
// adjacent facets. Mesh vertices are the input points (same positions and colours); points
// no facet uses are dropped.

#include <locard/core/point_cloud.hpp>
#include <locard/core/triangle_mesh.hpp>

namespace locard {

struct AdvancingFrontOptions {
  double radius_ratio_bound = 5.0;
  double beta = 0.52;
};

// Throws InputError with fewer than 3 finite points.
TriangleMesh advancing_front_mesh(const PointCloud& cloud,
                                  const AdvancingFrontOptions& options = {});

}  // namespace locard
