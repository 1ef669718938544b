#include <locard/core/error.hpp>
#include <locard/preprocess/depth_to_points.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <vector>

namespace locard {

PointCloud depth_to_points(const RgbdFrame& frame, const DepthToPointsOptions& options,
                           const Isometry3d& T_world_camera) {
  const DepthImage& depth = frame.depth;
  const CameraIntrinsics& k = frame.intrinsics;
  if (depth.empty()) return {};
  if (!k.valid()) throw Error("depth_to_points: frame " + std::to_string(frame.frame_index) +
                              " has no valid intrinsics");
  if (options.stride < 1) throw Error("depth_to_points: stride must be >= 1");
  if (!(frame.depth_scale > 0.0)) throw Error("depth_to_points: depth scale must be positive");
  const bool with_color = options.with_color && !frame.color.empty();
  if (with_color &&
      (frame.color.width() != depth.width() || frame.color.height() != depth.height()))
    throw Error("depth_to_points: colour " + std::to_string(frame.color.width()) + "x" +
                std::to_string(frame.color.height()) + " does not match depth " +
                std::to_string(depth.width()) + "x" + std::to_string(depth.height()));

  const int stride = options.stride;
  const int cols = (depth.width() + stride - 1) / stride;
  const int rows = (depth.height() + stride - 1) / stride;
  // Raw-unit bounds: the per-pixel test is then one integer compare pair.
  const double lo = std::ceil(options.min_depth_m * frame.depth_scale);
  const double hi = std::floor(options.max_depth_m * frame.depth_scale);
  const unsigned min_raw = static_cast<unsigned>(std::max(1.0, lo));
  const unsigned max_raw = static_cast<unsigned>(std::min(65535.0, std::max(0.0, hi)));

  // Per-column and per-row ray slopes: x = (u - cx) / fx * z, no division in the inner loop.
  std::vector<float> x_slope(static_cast<std::size_t>(cols));
  std::vector<float> y_slope(static_cast<std::size_t>(rows));
  for (int c = 0; c < cols; ++c) x_slope[c] = static_cast<float>((c * stride - k.cx) / k.fx);
  for (int r = 0; r < rows; ++r) y_slope[r] = static_cast<float>((r * stride - k.cy) / k.fy);

  // Pass 1 counts valid pixels per row; a prefix sum then gives every row its output slot, so
  // the result is in row-major order whatever the thread count.
  std::vector<std::size_t> row_start(static_cast<std::size_t>(rows) + 1, 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, rows, 16), [&](const tbb::blocked_range<int>& rr) {
    for (int r = rr.begin(); r != rr.end(); ++r) {
      const std::uint16_t* d = depth.row(r * stride);
      std::size_t n = 0;
      for (int c = 0; c < cols; ++c) {
        const unsigned z = d[c * stride];
        n += (z >= min_raw) & (z <= max_raw);
      }
      row_start[r + 1] = n;
    }
  });
  for (int r = 0; r < rows; ++r) row_start[r + 1] += row_start[r];

  PointCloud cloud;
  cloud.positions.resize(row_start[rows]);
  if (with_color) cloud.colors.resize(row_start[rows]);

  const Eigen::Matrix3f R = T_world_camera.linear().cast<float>();
  const Eigen::Vector3f t = T_world_camera.translation().cast<float>();
  const bool identity = T_world_camera.isApprox(Isometry3d::Identity(), 0.0);
  // Divide rather than multiply by 1/scale: 1500 / 1000 must be exactly 1.5 m.
  const float scale = static_cast<float>(frame.depth_scale);

  tbb::parallel_for(tbb::blocked_range<int>(0, rows, 16), [&](const tbb::blocked_range<int>& rr) {
    for (int r = rr.begin(); r != rr.end(); ++r) {
      const int v = r * stride;
      const std::uint16_t* d = depth.row(v);
      const std::uint8_t* rgb = with_color ? frame.color.row(v) : nullptr;
      const float ys = y_slope[r];
      std::size_t out = row_start[r];
      for (int c = 0; c < cols; ++c) {
        const int u = c * stride;
        const unsigned raw = d[u];
        if (raw < min_raw || raw > max_raw) continue;
        const float z = static_cast<float>(raw) / scale;
        const Eigen::Vector3f p(x_slope[c] * z, ys * z, z);
        cloud.positions[out] = identity ? p : Eigen::Vector3f(R * p + t);
        if (rgb) cloud.colors[out] = {rgb[3 * u], rgb[3 * u + 1], rgb[3 * u + 2]};
        ++out;
      }
    }
  });
  return cloud;
}

}  // namespace locard
