#pragma once
// PCL's PCD format, version 0.7 (and 0.6 headers): DATA ascii, binary and binary_compressed
// (LZF). Fields x y z, normal_x normal_y normal_z, rgb (packed float) or rgba (packed uint),
// any other field kept as a ScalarField. Unorganised and organised (HEIGHT > 1) clouds; NaN
// points of organised clouds are kept as read (callers filter).

#include <locard/core/point_cloud.hpp>

#include <filesystem>

namespace locard {

enum class PcdEncoding { Ascii, Binary, BinaryCompressed };

PointCloud read_pcd(const std::filesystem::path& path);
void write_pcd(const std::filesystem::path& path, const PointCloud& cloud,
               PcdEncoding encoding = PcdEncoding::Binary);

}  // namespace locard
