#pragma once
// The Kinect v2 model under its first name: KinectModel's default is the Kinect v2
// (kinect_model.hpp holds both Kinect sensors).

#include <locard/sim/kinect_model.hpp>

namespace locard::sim {

using KinectV2Model = KinectModel;

}  // namespace locard::sim
