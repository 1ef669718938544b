#pragma once
// Matrices in Locard's JSON files (pose graphs, stage reports, covariances, `register --json`):
// an array of rows, each an array of numbers, row-major as written on paper.

#include <locard/core/pose.hpp>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace locard {

nlohmann::json matrix_json(const Eigen::MatrixXd& m);
// A rigid pose as its 4x4 matrix (rotation, translation, last row 0 0 0 1).
nlohmann::json pose_json(const Isometry3d& T);

}  // namespace locard
