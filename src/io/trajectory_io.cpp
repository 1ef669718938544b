#include <locard/io/trajectory_io.hpp>

#include "io/text_lines.hpp"

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>

#include <fmt/format.h>

#include <cmath>

namespace locard {
namespace {

using io_detail::DataLines;
using io_detail::parse_integer;
using io_detail::parse_number;

// Files written with 6-8 significant digits deviate from orthonormal by ~1e-6; anything far
// beyond that is not a rotation and would corrupt every transform it touches.
constexpr double kRotationTolerance = 1e-3;
constexpr double kRedwoodFrameRate = 30.0;

double parse_or_fail(const DataLines& lines, std::string_view token, const char* what) {
  const auto value = parse_number(token);
  if (!value) lines.fail(std::string("cannot read ") + what + " '" + std::string(token) + "'");
  return *value;
}

// One matrix row of a .log entry: exactly four numbers.
Eigen::RowVector4d read_log_row(DataLines& lines, std::vector<std::string_view>& tokens) {
  if (!lines.next(tokens)) lines.fail("file ends inside a 4x4 matrix");
  if (tokens.size() != 4)
    lines.fail("expected a matrix row of 4 numbers, found " + std::to_string(tokens.size()) +
               " values");
  Eigen::RowVector4d row;
  for (int c = 0; c < 4; ++c)
    row[c] = parse_or_fail(lines, tokens[static_cast<std::size_t>(c)], "matrix value");
  return row;
}

}  // namespace

Trajectory read_tum_trajectory(const std::filesystem::path& path) {
  DataLines lines(path);
  io_detail::TimeOrderCheck order;
  Trajectory trajectory;
  std::vector<std::string_view> tokens;
  while (lines.next(tokens)) {
    if (tokens.size() != 8)
      lines.fail("expected 8 values 'timestamp tx ty tz qx qy qz qw', found " +
                 std::to_string(tokens.size()));
    double v[8];
    for (std::size_t i = 0; i < 8; ++i) v[i] = parse_or_fail(lines, tokens[i], "number");
    order.check(lines, v[0]);
    const double q_norm = std::sqrt(v[4] * v[4] + v[5] * v[5] + v[6] * v[6] + v[7] * v[7]);
    // Published files round to 4 digits, so only a clearly wrong norm is an error.
    if (std::abs(q_norm - 1.0) > 0.01)
      lines.fail("quaternion (qx qy qz qw) has norm " + fmt::format("{:.6g}", q_norm) +
                 ", expected 1");
    StampedPose pose;
    pose.frame_index = static_cast<std::int64_t>(trajectory.size());
    pose.timestamp = v[0];
    pose.T_world_camera =
        isometry_from_translation_quaternion({v[1], v[2], v[3]}, v[4], v[5], v[6], v[7]);
    trajectory.push_back(pose);
  }
  return trajectory;
}

void write_tum_trajectory(const std::filesystem::path& path, const Trajectory& trajectory) {
  AtomicFile file(path, false);
  auto& out = file.stream();
  out << "# timestamp tx ty tz qx qy qz qw\n";
  for (const auto& pose : trajectory) {
    Eigen::Quaterniond q(pose.T_world_camera.rotation());
    if (q.w() < 0) q.coeffs() = -q.coeffs();  // one of the two equal quaternions, consistently
    const Eigen::Vector3d t = pose.T_world_camera.translation();
    // Nanosecond timestamps; shortest round-trip form ("{}") for the pose values.
    out << fmt::format("{:.9f} {} {} {} {} {} {} {}\n", pose.timestamp, t.x(), t.y(), t.z(), q.x(),
                       q.y(), q.z(), q.w());
  }
  file.commit();
}

Trajectory read_redwood_log(const std::filesystem::path& path) {
  DataLines lines(path);
  Trajectory trajectory;
  std::vector<std::string_view> tokens;
  while (lines.next(tokens)) {
    if (tokens.size() != 3)
      lines.fail("expected an entry header 'id0 id1 frame' (3 integers), found " +
                 std::to_string(tokens.size()) + " values");
    const auto frame = parse_integer(tokens[0]);
    if (!frame || !parse_integer(tokens[1]) || !parse_integer(tokens[2]))
      lines.fail("entry header must be 3 integers");
    const long header_line = lines.line_number();
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r) m.row(r) = read_log_row(lines, tokens);
    if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-9)
      lines.fail("last matrix row must be '0 0 0 1'");
    const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
    if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() >
        kRotationTolerance)
      throw_input_error(path,
                        "matrix of the entry is not a rigid transform (rotation not orthonormal)",
                        header_line);
    StampedPose pose;
    pose.frame_index = *frame;
    pose.timestamp = static_cast<double>(*frame) / kRedwoodFrameRate;
    pose.T_world_camera.matrix() = m;
    trajectory.push_back(pose);
  }
  return trajectory;
}

void write_redwood_log(const std::filesystem::path& path, const Trajectory& trajectory) {
  AtomicFile file(path, false);
  auto& out = file.stream();
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const auto& pose = trajectory[i];
    // Open3D writes "i i i+1"; readers take the first number as the frame.
    const std::int64_t frame =
        pose.frame_index >= 0 ? pose.frame_index : static_cast<std::int64_t>(i);
    out << fmt::format("{} {} {}\n", frame, frame, frame + 1);
    const Eigen::Matrix4d m = pose.T_world_camera.matrix();
    for (int r = 0; r < 4; ++r)
      out << fmt::format("{} {} {} {}\n", m(r, 0), m(r, 1), m(r, 2), m(r, 3));
  }
  file.commit();
}

}  // namespace locard
