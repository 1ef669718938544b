#pragma once
// Camera trajectories in the TUM RGB-D format ("timestamp tx ty tz qx qy qz qw", comments with
// '#', non-numeric header lines skipped) and the Redwood / Open3D `.log` format (a line
// "id0 id1 frame" followed by a row-major 4x4 camera-to-world matrix).

#include <locard/core/pose.hpp>

#include <filesystem>

namespace locard {

Trajectory read_tum_trajectory(const std::filesystem::path& path);
// Writes with full precision, one pose per line, so the TUM evaluation tools read it unchanged.
void write_tum_trajectory(const std::filesystem::path& path, const Trajectory& trajectory);

Trajectory read_redwood_log(const std::filesystem::path& path);
void write_redwood_log(const std::filesystem::path& path, const Trajectory& trajectory);

}  // namespace locard
