#pragma once
// One RGB-D capture: depth in raw sensor units plus the colour registered to it.

#include <locard/core/camera_intrinsics.hpp>
#include <locard/core/image.hpp>

#include <cstdint>
#include <filesystem>

namespace locard {

struct RgbdFrame {
  ColorImage color;   // RGB8; may be empty (depth-only sequences); same size as depth when set
  DepthImage depth;   // raw units, 0 = no measurement
  double depth_scale = 1000.0;  // raw units per metre (1000 = millimetres, TUM uses 5000)
  CameraIntrinsics intrinsics;  // of the depth image
  double timestamp = 0.0;       // seconds (frame index / 30 Hz where the dataset has none)
  std::int64_t frame_index = -1;
  std::filesystem::path color_path;
  std::filesystem::path depth_path;

  double depth_m(int u, int v) const { return depth.at(u, v) / depth_scale; }
};

}  // namespace locard
