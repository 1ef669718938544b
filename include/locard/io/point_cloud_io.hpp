#pragma once
// Format-agnostic entry points: the file extension (.ply, .pcd) picks the reader/writer.

#include <locard/core/point_cloud.hpp>

#include <filesystem>
#include <string>

namespace locard {

struct CloudWriteOptions {
  bool ascii = false;              // PLY ascii / PCD ascii
  bool compressed = false;         // PCD binary_compressed
};

PointCloud read_point_cloud(const std::filesystem::path& path);
void write_point_cloud(const std::filesystem::path& path, const PointCloud& cloud,
                       const CloudWriteOptions& options = {});
// True for extensions read_point_cloud understands.
bool is_point_cloud_file(const std::filesystem::path& path);

}  // namespace locard
