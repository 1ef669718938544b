// Uses the installed Locard: back-projects one synthetic pixel and checks the point, then
// writes it as E57 and reads it back (the E57 code links pugixml, a private dependency that
// find_package(Locard) must find for a static library's users).
#include <locard/core/camera_intrinsics.hpp>
#include <locard/core/rgbd_frame.hpp>
#include <locard/io/e57.hpp>
#include <locard/preprocess/depth_to_points.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>

int main() {
  locard::RgbdFrame frame;
  frame.intrinsics = locard::CameraIntrinsics::preset("kinect_v1");
  frame.depth = locard::DepthImage(frame.intrinsics.width, frame.intrinsics.height);
  frame.depth_scale = 1000.0;
  frame.depth.at(420, 240) = 2000;  // 2 m, 100.5 px right of the principal point
  const locard::PointCloud cloud = locard::depth_to_points(frame, {});
  if (cloud.size() != 1) return 1;
  const double expected_x = (420 - 319.5) * 2.0 / 525.0;
  std::printf("point %.6f %.6f %.6f\n", cloud.positions[0].x(), cloud.positions[0].y(),
              cloud.positions[0].z());
  if (std::abs(cloud.positions[0].x() - expected_x) >= 1e-6) return 1;
  const auto e57 = std::filesystem::temp_directory_path() / "locard-consumer-point.e57";
  locard::write_e57(e57, cloud, "pixel");
  const locard::PointCloud back = locard::read_e57_merged(e57);
  std::filesystem::remove(e57);
  return back.positions == cloud.positions ? 0 : 1;
}
