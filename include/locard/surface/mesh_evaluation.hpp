#pragma once
// How close a reconstructed mesh is to a ground-truth mesh (the measures of Seitz et al. 2006,
// "A comparison and evaluation of multi-view stereo reconstruction algorithms"):
//  - accuracy: distances from every vertex of the reconstruction to the ground-truth surface
//    (point-to-triangle, exact, through a CGAL AABB tree);
//  - completeness: the fraction of the ground-truth surface within `completeness_threshold` of
//    the reconstruction, measured on points sampled uniformly by area over the ground truth
//    (seeded, so the figure is reproducible). When views are given, only samples that at least
//    one view saw count (the surface the scanner could see): a sample is seen by a view when it
//    faces the camera (its triangle's counter-clockwise normal points towards the camera
//    centre), projects inside the image in front of the camera, and the view's depth at that
//    pixel agrees with the sample's depth within `visibility_tolerance` plus what the half-pixel
//    offset of that pixel's ray moves the depth on the sample's inclined surface. The fixed
//    1 cm is 2 sigma of Kinect v2 depth noise at 4 m and less than the thickness of a door or
//    window flush with a wall, whose wall behind is occluded, not seen (with the earlier 3 cm
//    it counted as seen and as missed by every mesh).
// Parallel over query points (oneTBB); results do not depend on the thread count.

#include <locard/core/camera_intrinsics.hpp>
#include <locard/core/image.hpp>
#include <locard/core/point_cloud.hpp>
#include <locard/core/pose.hpp>
#include <locard/core/triangle_mesh.hpp>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace locard {

struct EvaluationView {
  DepthImage depth;
  double depth_scale = 1000.0;
  CameraIntrinsics intrinsics;
  Isometry3d T_world_camera = Isometry3d::Identity();
};

struct MeshEvaluationOptions {
  double completeness_threshold = 0.02;  // metres
  double sample_spacing = 0.01;          // metres: one ground-truth sample per spacing^2 area
  std::uint64_t seed = 1;
  double visibility_tolerance = 0.01;    // metres (plus the slope term, see above)
  std::vector<EvaluationView> views;     // empty: the whole ground-truth surface counts
  bool keep_samples = false;             // fill MeshEvaluation::samples (diagnosis)
};

struct MeshEvaluation {
  std::size_t mesh_vertices = 0;
  double accuracy_mean = 0.0;    // metres
  double accuracy_median = 0.0;
  double accuracy_p90 = 0.0;
  double accuracy_max = 0.0;
  std::size_t gt_samples = 0;        // sampled on the ground truth
  std::size_t counted_samples = 0;   // of those, seen by a view (all when no views)
  double completeness = 0.0;         // fraction of counted samples within the threshold
  double completeness_mean_distance = 0.0;  // mean distance of counted samples to the mesh
  // With keep_samples: the counted samples, scalar fields "distance" (metres to the
  // reconstruction) and "views" (how many views saw the sample), to see where the mesh misses.
  PointCloud samples;
};

// Throws InputError when either mesh has no triangles.
MeshEvaluation evaluate_mesh(const TriangleMesh& ground_truth, const TriangleMesh& reconstruction,
                             const MeshEvaluationOptions& options = {});

// Points sampled uniformly by area on the mesh (about area / spacing^2 of them), seeded.
std::vector<Eigen::Vector3f> sample_surface(const TriangleMesh& mesh, double spacing,
                                            std::uint64_t seed);

}  // namespace locard
