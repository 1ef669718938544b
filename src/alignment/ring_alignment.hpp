#pragma once
// A pitch ring of a tripod turn corrected as a whole against the rings before it
// (ring_alignment.cpp has the model and the math).
#include "alignment/alignment_stages.hpp"

#include <optional>
#include <vector>

namespace locard::alignment_detail {

struct RingCorrection {
  Eigen::Matrix3d E = Eigen::Matrix3d::Identity();    // camera frame, the same in every view
  Eigen::Matrix3d R_C = Eigen::Matrix3d::Identity();  // world, about the tripod's centre
  Eigen::Vector3d tau = Eigen::Vector3d::Zero();
  double E_deg = 0.0, C_deg = 0.0;
  double rmse = 0.0;  // point to plane, last iteration
  std::size_t correspondences = 0;
  Isometry3d apply(const Isometry3d& T_world_camera, const Eigen::Vector3d& centre) const;
};

// `ring` and `before`: frames (tracked poses); none when too little overlaps.
std::optional<RingCorrection> align_ring(const AlignmentState& s,
                                         const std::vector<std::size_t>& ring,
                                         const std::vector<std::size_t>& before,
                                         const Eigen::Vector3d& centre);

}  // namespace locard::alignment_detail
