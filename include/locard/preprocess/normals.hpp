#pragma once
// Surface normals by local PCA (Hoppe et al. 1992; Rusu 2009 thesis, section 4.3): the normal
// at p is the eigenvector of the smallest eigenvalue of the covariance of its neighbours
//   C = 1/k sum_j (p_j - pbar)(p_j - pbar)^T,
// computed in double, centred on the neighbourhood mean. Neighbours come from a hybrid search:
// the at most `max_neighbors` nearest points within `radius` (radius <= 0: plain k-NN).
// Surface variation (Pauly et al. 2002) curvature = lambda_0 / (lambda_0 + lambda_1 + lambda_2)
// is stored, when asked for, as the scalar field "curvature".
// Parallel over points (oneTBB); results do not depend on the thread count.

#include <locard/core/point_cloud.hpp>

#include <Eigen/Core>

#include <cstddef>

namespace locard {

class KdTree;

enum class NormalOrientation {
  TowardsViewpoint,  // flip so that dot(n, viewpoint - p) >= 0 (the sensor sees the front)
  AlongExisting,     // flip to agree with the cloud's current normals (re-estimation);
                     // falls back to TowardsViewpoint when the cloud has none
  None,              // the eigenvector's arbitrary sign
};

struct NormalOptions {
  float radius = 0.05f;   // metres, not squared; <= 0 for pure k-NN
  int max_neighbors = 30;
  NormalOrientation orientation = NormalOrientation::TowardsViewpoint;
  Eigen::Vector3f viewpoint = Eigen::Vector3f::Zero();  // the sensor position in the cloud's
                                                        // frame (the origin of a camera cloud)
  bool compute_curvature = false;
};

struct NormalReport {
  std::size_t points = 0;
  // Points with fewer than 3 neighbours or a degenerate (rank < 2) neighbourhood: their normal
  // is the unit vector towards the viewpoint (or +z when they sit on it), curvature 0.
  std::size_t degenerate = 0;
};

// Fills cloud.normals (and the "curvature" scalar field when asked). `tree`, when given, must
// be built over exactly cloud.positions; otherwise one is built. Positions must be finite
// (InputError otherwise; see remove_non_finite).
NormalReport estimate_normals(PointCloud& cloud, const NormalOptions& options,
                              const KdTree* tree = nullptr);

}  // namespace locard
