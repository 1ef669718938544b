#include <locard/io/trajectory_io.hpp>

#include <locard/core/error.hpp>

#include "test_support.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace locard {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

fs::path tum_groundtruth() {
  return test::shared_data() / "tum-fr1-xyz-metadata" / "groundtruth.txt";
}
fs::path open3d_rgbd(const std::string& name) {
  return test::shared_data() / "open3d-testdata" / "RGBD" / name;
}

void write_text(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

Isometry3d tum_pose(double tx, double ty, double tz, double qx, double qy, double qz, double qw) {
  return isometry_from_translation_quaternion({tx, ty, tz}, qx, qy, qz, qw);
}

void expect_same_pose(const Isometry3d& a, const Isometry3d& b, double tolerance) {
  EXPECT_LT((a.matrix() - b.matrix()).cwiseAbs().maxCoeff(), tolerance) << "\n"
                                                                        << a.matrix() << "\nvs\n"
                                                                        << b.matrix();
}

TEST(TrajectoryIo, ReadsTumGroundTruthWithHeaderLineLackingHash) {
  const Trajectory gt = read_tum_trajectory(tum_groundtruth());
  ASSERT_EQ(gt.size(), 3000u);
  // First line: 1305031098.6659 1.3563 0.6305 1.6380 0.6132 0.5962 -0.3311 -0.3986
  EXPECT_EQ(gt.front().frame_index, 0);
  EXPECT_DOUBLE_EQ(gt.front().timestamp, 1305031098.6659);
  expect_same_pose(gt.front().T_world_camera,
                   tum_pose(1.3563, 0.6305, 1.6380, 0.6132, 0.5962, -0.3311, -0.3986), 1e-12);
  EXPECT_EQ(gt.back().frame_index, 2999);
  EXPECT_DOUBLE_EQ(gt.back().timestamp, 1305031128.7555);
  // Rotations are orthonormal after normalising the 4-digit quaternions.
  for (const auto& pose : gt)
    ASSERT_LT((pose.T_world_camera.linear().transpose() * pose.T_world_camera.linear() -
               Eigen::Matrix3d::Identity())
                  .norm(),
              1e-12);
}

TEST(TrajectoryIo, TumWriteReadRoundTripKeepsFullPrecision) {
  const Trajectory gt = read_tum_trajectory(tum_groundtruth());
  const fs::path path = test::scratch_dir() / "traj.txt";
  write_tum_trajectory(path, gt);
  const Trajectory back = read_tum_trajectory(path);
  ASSERT_EQ(back.size(), gt.size());
  for (std::size_t i = 0; i < gt.size(); ++i) {
    EXPECT_EQ(back[i].timestamp, gt[i].timestamp);  // 9 decimals suffice for exact doubles here
    expect_same_pose(back[i].T_world_camera, gt[i].T_world_camera, 1e-14);
  }
  EXPECT_EQ(test::list_folder(path.parent_path()), "traj.txt\n");
}

TEST(TrajectoryIo, ReadsOpen3dOdometryLog) {
  const Trajectory log = read_redwood_log(open3d_rgbd("odometry.log"));
  ASSERT_EQ(log.size(), 5u);
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(log[i].frame_index, static_cast<std::int64_t>(i));
    EXPECT_DOUBLE_EQ(log[i].timestamp, static_cast<double>(i) / 30.0);
  }
  // Entry "2 2 3" of odometry.log.
  Eigen::Matrix4d expected;
  expected << 0.999954, -7.8978e-005, 0.0096394, 1.99935,  //
      -0.000149351, 0.99972, 0.0236841, 1.95353,           //
      -0.00963857, -0.0236844, 0.999673, -0.301586,        //
      0, 0, 0, 1;
  EXPECT_EQ(log[2].T_world_camera.matrix(), expected);
}

TEST(TrajectoryIo, RedwoodLogRoundTripIsExact) {
  Trajectory trajectory = read_redwood_log(open3d_rgbd("trajectory.log"));
  ASSERT_EQ(trajectory.size(), 5u);
  trajectory[3].frame_index = 17;  // sparse subsets keep their frame numbers
  const fs::path path = test::scratch_dir() / "out.log";
  write_redwood_log(path, trajectory);
  const Trajectory back = read_redwood_log(path);
  ASSERT_EQ(back.size(), 5u);
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(back[i].frame_index, trajectory[i].frame_index);
    EXPECT_EQ(back[i].T_world_camera.matrix(), trajectory[i].T_world_camera.matrix());
  }
}

TEST(TrajectoryIo, NonMonotonicTimestampsNameFileAndLine) {
  const fs::path path = test::scratch_dir() / "gt.txt";
  write_text(path,
             "# timestamp tx ty tz qx qy qz qw\n"
             "1.0 0 0 0 0 0 0 1\n"
             "2.0 0 0 0 0 0 0 1\n"
             "1.5 0 0 0 0 0 0 1\n");
  EXPECT_THAT([&] { read_tum_trajectory(path); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("gt.txt:4"), HasSubstr("line 3"))));
}

TEST(TrajectoryIo, UnparsableTumLinesNameFileAndLine) {
  const fs::path dir = test::scratch_dir();
  write_text(dir / "short.txt", "timestamp tx ty tz qx qy qz qw\n1.0 0 0 0 0 0 0 1\n2.0 0 0 0\n");
  EXPECT_THAT([&] { read_tum_trajectory(dir / "short.txt"); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("short.txt:3"), HasSubstr("found 4"))));
  write_text(dir / "word.txt", "1.0 0 0 0 0 0 0 1\n2.0 0 0 zero 0 0 0 1\n");
  EXPECT_THAT([&] { read_tum_trajectory(dir / "word.txt"); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("word.txt:2"), HasSubstr("'zero'"))));
  // Once data has started, a non-numeric line is an error, not a header.
  write_text(dir / "late.txt", "1.0 0 0 0 0 0 0 1\ngarbage here\n");
  EXPECT_THAT([&] { read_tum_trajectory(dir / "late.txt"); },
              ThrowsMessage<InputError>(HasSubstr("late.txt:2")));
  write_text(dir / "quat.txt", "1.0 0 0 0 0 0 0 0\n");
  EXPECT_THAT([&] { read_tum_trajectory(dir / "quat.txt"); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("quat.txt:1"), HasSubstr("norm"))));
}

TEST(TrajectoryIo, MalformedRedwoodLogsNameFileAndLine) {
  const fs::path dir = test::scratch_dir();
  write_text(dir / "cut.log", "0 0 1\n1 0 0 0\n0 1 0 0\n");
  EXPECT_THAT([&] { read_redwood_log(dir / "cut.log"); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("cut.log"), HasSubstr("ends inside"))));
  write_text(dir / "row.log", "0 0 1\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1 1\n");
  EXPECT_THAT([&] { read_redwood_log(dir / "row.log"); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("row.log:5"), HasSubstr("0 0 0 1"))));
  write_text(dir / "rot.log", "0 0 1\n2 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  EXPECT_THAT([&] { read_redwood_log(dir / "rot.log"); },
              ThrowsMessage<InputError>(AllOf(HasSubstr("rot.log:1"), HasSubstr("orthonormal"))));
  write_text(dir / "three.log", "0 0 1\n1 0 0\n");
  EXPECT_THAT([&] { read_redwood_log(dir / "three.log"); },
              ThrowsMessage<InputError>(HasSubstr("three.log:2")));
}

TEST(TrajectoryIo, MissingFileAndMissingOutputFolder) {
  const fs::path dir = test::scratch_dir();
  EXPECT_THAT([&] { read_tum_trajectory(dir / "absent.txt"); },
              ThrowsMessage<InputError>(HasSubstr("absent.txt")));
  EXPECT_THROW(write_tum_trajectory(dir / "no" / "t.txt", Trajectory(1)), InputError);
  EXPECT_EQ(test::list_folder(dir), "");
}

}  // namespace
}  // namespace locard
