#include <locard/core/camera_intrinsics.hpp>
#include <locard/core/error.hpp>

#include <cmath>
#include <numbers>

namespace locard {
namespace {

CameraIntrinsics make(std::string name, int w, int h, double fx, double fy, double cx, double cy,
                      std::array<double, 5> distortion = {}) {
  CameraIntrinsics k;
  k.name = std::move(name);
  k.width = w;
  k.height = h;
  k.fx = fx;
  k.fy = fy;
  k.cx = cx;
  k.cy = cy;
  k.distortion = distortion;
  return k;
}

std::vector<CameraIntrinsics> all_presets() {
  return {
      // Kinect v2 time-of-flight depth: 512x424, 70.6 x 60 degrees (Microsoft's figures).
      CameraIntrinsics::from_fov(512, 424, 70.6, 60.0, "kinect_v2"),
      make("kinect_v1", 640, 480, 525.0, 525.0, 319.5, 239.5),
      // TUM RGB-D calibrations of the colour camera, to which depth is registered.
      make("tum_freiburg1", 640, 480, 517.3, 516.5, 318.6, 255.3,
           {0.2624, -0.9531, -0.0054, 0.0026, 1.1633}),
      make("tum_freiburg2", 640, 480, 520.9, 521.0, 325.1, 249.7,
           {0.2312, -0.7849, -0.0033, -0.0001, 0.9172}),
      make("tum_freiburg3", 640, 480, 535.4, 539.2, 320.1, 247.6),
      make("seven_scenes", 640, 480, 585.0, 585.0, 320.0, 240.0),
  };
}

}  // namespace

Eigen::Matrix3d CameraIntrinsics::K() const {
  Eigen::Matrix3d k;
  k << fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0;
  return k;
}

CameraIntrinsics CameraIntrinsics::scaled(double factor) const {
  CameraIntrinsics k = *this;
  k.width = static_cast<int>(std::lround(width * factor));
  k.height = static_cast<int>(std::lround(height * factor));
  k.fx = fx * factor;
  k.fy = fy * factor;
  // Pixel centres at integers: the image edge at -0.5 scales, so shift before and after.
  k.cx = (cx + 0.5) * factor - 0.5;
  k.cy = (cy + 0.5) * factor - 0.5;
  return k;
}

CameraIntrinsics CameraIntrinsics::from_fov(int width, int height, double hfov_deg,
                                            double vfov_deg, std::string name) {
  const double to_rad = std::numbers::pi / 180.0;
  // The field of view spans the outer pixel edges (-0.5 .. width - 0.5).
  const double fx = 0.5 * width / std::tan(0.5 * hfov_deg * to_rad);
  const double fy = 0.5 * height / std::tan(0.5 * vfov_deg * to_rad);
  return make(std::move(name), width, height, fx, fy, 0.5 * (width - 1), 0.5 * (height - 1));
}

double CameraIntrinsics::vertical_fov_deg() const {
  return 2.0 * std::atan(0.5 * height / std::abs(fy)) * 180.0 / std::numbers::pi;
}

std::optional<CameraIntrinsics> CameraIntrinsics::find_preset(std::string_view name) {
  for (auto& k : all_presets())
    if (k.name == name) return k;
  return std::nullopt;
}

CameraIntrinsics CameraIntrinsics::preset(std::string_view name) {
  if (auto k = find_preset(name)) return *k;
  std::string known;
  for (const auto& n : preset_names()) known += (known.empty() ? "" : ", ") + n;
  throw InputError("unknown camera preset '" + std::string(name) + "' (known: " + known + ")");
}

std::optional<std::string> CameraIntrinsics::matching_preset() const {
  for (const auto& k : all_presets())
    if (k.width == width && k.height == height && k.fx == fx && k.fy == fy && k.cx == cx &&
        k.cy == cy)
      return k.name;
  return std::nullopt;
}

std::vector<std::string> CameraIntrinsics::preset_names() {
  std::vector<std::string> names;
  for (const auto& k : all_presets()) names.push_back(k.name);
  return names;
}

}  // namespace locard
