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
//    pixel agrees with the sample's depth within `visibility_tolerance`.
// Parallel over query points (oneTBB); results do not depend on the thread count.

#include <locard/core/camera_intrinsics.hpp>
#include <locard/core/image.hpp>
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
  double visibility_tolerance = 0.03;    // metres
  std::vector<EvaluationView> views;     // empty: the whole ground-truth surface counts
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
};

// Throws InputError when either mesh has no triangles.
MeshEvaluation evaluate_mesh(const TriangleMesh& ground_truth, const TriangleMesh& reconstruction,
                             const MeshEvaluationOptions& options = {});

// Points sampled uniformly by area on the mesh (about area / spacing^2 of them), seeded.
std::vector<Eigen::Vector3f> sample_surface(const TriangleMesh& mesh, double spacing,
                                            std::uint64_t seed);

}  // namespace locard
