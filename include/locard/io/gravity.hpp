#pragma once
// Gravity as a dataset records it, so a case can be levelled (z up) in the data's own terms.
//
// 7-Scenes ships gravity-direction.txt beside its frames: three numbers, the direction gravity
// points in the dataset's world frame (the frame of its frame-*.pose.txt). Other layouts give
// none here (TUM's accelerometer.txt is per frame and is not in the shared subsets).
#include <locard/io/rgbd_sequence.hpp>

#include <Eigen/Core>

#include <optional>
#include <string>

namespace locard {

struct GravityDirection {
  Eigen::Vector3d down_world = -Eigen::Vector3d::UnitZ();  // unit, in the dataset's world frame
  std::string source;                                      // the file it came from
};

// The sequence's recorded gravity, or nothing when it has none. A file that is there but is
// not three finite numbers of length 0.5-1.5 (a unit vector, or g in units of g) is an
// InputError naming it.
std::optional<GravityDirection> read_gravity_direction(const RgbdSequence& sequence);

}  // namespace locard
