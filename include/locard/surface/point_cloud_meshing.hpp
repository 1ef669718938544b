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
#include <locard/preprocess/outlier_removal.hpp>
#include <locard/preprocess/point_selection.hpp>
#include <locard/surface/segmentation.hpp>

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace locard {

struct AdvancingFrontOptions {
  double radius_ratio_bound = 5.0;
  double beta = 0.52;
};

// Throws InputError with fewer than 3 finite points.
TriangleMesh advancing_front_mesh(const PointCloud& cloud,
                                  const AdvancingFrontOptions& options = {});

// Poisson surface reconstruction (Kazhdan et al. 2006) through CGAL's
// poisson_surface_reconstruction_delaunay: the cloud needs oriented normals (the side they
// point to is outside). Poisson closes every hole with a smooth guess, so the result is
// trimmed by point density: triangles with a vertex farther than `trim_distance` from every
// input point are removed (the surface no point supports). Colours: the nearest input point's.
struct PoissonOptions {
  double spacing = 0.0;        // metres; 0: the mean distance to the 6 nearest points
  double trim_distance = 0.0;  // metres; 0: 2 * spacing
  double sm_angle = 20.0;      // CGAL's surface-mesher bounds (degrees, spacings, spacings)
  double sm_radius = 30.0;
  double sm_distance = 0.375;
};
// Throws InputError without normals or with fewer than 10 finite points, Error when CGAL's
// solver fails.
TriangleMesh poisson_mesh(const PointCloud& cloud, const PoissonOptions& options = {});

// The whole path for a merged cloud (paper, sections III-F and III-G): statistical outlier
// removal, normals (PCA, oriented towards `viewpoint`, with curvature), region-growing
// segmentation (labels kept as the scalar field "segment" of the returned cloud), then the
// advancing-front (Delaunay) triangulation or Poisson. For Poisson, normals towards a viewpoint
// inside the cloud's bounding box (a room scanned from within) are flipped first, so that the
// free space around the sensor is the closed volume, and the triangles flipped back after, so
// they face the sensor as TSDF meshes do.
enum class CloudSurfaceMethod { Delaunay, Poisson };
struct CloudMeshingOptions {
  CloudSurfaceMethod method = CloudSurfaceMethod::Delaunay;
  StatisticalOutlierOptions outliers;
  float normal_radius = 0.05f;
  int normal_max_neighbors = 30;
  Eigen::Vector3f viewpoint = Eigen::Vector3f::Zero();
  RegionGrowingOptions segmentation;
  AdvancingFrontOptions advancing_front;
  PoissonOptions poisson;
};
struct CloudMeshingResult {
  PointCloud cloud;  // filtered, with normals, "curvature" and "segment"
  FilterReport outliers;
  Segmentation segmentation;
  TriangleMesh mesh;
  std::vector<std::int32_t> vertex_segments;  // the segment of each mesh vertex's nearest point
};
CloudMeshingResult mesh_point_cloud(const PointCloud& merged, const CloudMeshingOptions& options);

}  // namespace locard
