#pragma once
// Pinhole intrinsics of a depth (or depth-registered colour) camera.
// Pixel convention: integer (u, v) is the centre of pixel column u, row v; a point
// (x, y, z) in the camera frame (x right, y down, z forward) projects to
// u = fx * x / z + cx, v = fy * y / z + cy.

#include <Eigen/Core>

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace locard {

struct CameraIntrinsics {
  int width = 0;
  int height = 0;
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  // Brown-Conrady k1 k2 p1 p2 k3 as published for the sensor; metadata only, back-projection
  // assumes undistorted images as every public RGB-D benchmark does.
  std::array<double, 5> distortion{};
  std::string name;  // preset name or where the values came from

  Eigen::Matrix3d K() const;
  bool valid() const { return width > 0 && height > 0 && fx > 0.0 && fy > 0.0; }
  // Same intrinsics for an image scaled by `factor` (e.g. 1920x1080 colour vs 512x424 depth).
  CameraIntrinsics scaled(double factor) const;
  bool operator==(const CameraIntrinsics&) const = default;

  // Named presets:
  //  kinect_v2       512x424 depth, field of view 70.6 x 60 degrees (fx, fy derived from it)
  //  kinect_v1       PrimeSense / Kinect v1 defaults, 640x480, 525/525/319.5/239.5
  //  tum_freiburg1/2/3  TUM RGB-D calibrations (vision.in.tum.de/data/datasets/rgbd-dataset)
  //  seven_scenes    Microsoft 7-Scenes depth camera, 640x480, 585/585/320/240
  // Throws InputError listing the known names when `name` is unknown.
  static CameraIntrinsics preset(std::string_view name);
  static std::optional<CameraIntrinsics> find_preset(std::string_view name);
  static std::vector<std::string> preset_names();
  // The preset with exactly these width, height, fx, fy, cx, cy, if any (so intrinsics read
  // from a dataset's own file can be recognised, e.g. 7-Scenes' camera-intrinsics.txt).
  std::optional<std::string> matching_preset() const;
  // Builds intrinsics from a horizontal and vertical field of view (degrees), centred.
  static CameraIntrinsics from_fov(int width, int height, double hfov_deg, double vfov_deg,
                                   std::string name = {});
  // The vertical field of view (degrees) over the outer pixel edges, from |fy| (ICL-NUIM's fy is
  // negative): the inverse of from_fov's vfov_deg.
  double vertical_fov_deg() const;
};

}  // namespace locard
