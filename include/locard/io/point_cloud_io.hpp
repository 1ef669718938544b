#pragma once
// Format-agnostic entry points: the file extension (.ply, .pcd, .e57) picks the reader/writer.
// An E57 file is read with all its scans merged into the file's frame, and written as one scan
// with the identity pose (see io/e57.hpp for scans and poses).

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
