#pragma once
// The Kinect v2 model under its first name, KinectV2Model: KinectModel, whose default is the
// Kinect v2 (kinect_model.hpp holds both Kinect sensors).

#include <locard/sim/kinect_model.hpp>
