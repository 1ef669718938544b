#pragma once
// PCL's PCD format, version 0.7 (and 0.6 headers): DATA ascii, binary and binary_compressed
// (LZF). Fields x y z, normal_x normal_y normal_z, rgb (packed float) or rgba (packed uint),
// any other field kept as a ScalarField. Unorganised and organised (HEIGHT > 1) clouds; NaN
// points of organised clouds are kept as read (callers filter). VIEWPOINT is not applied to
// the points (PCL does not either). Fields with COUNT > 1 other than x/y/z/normals/rgb are
// skipped; padding fields "_" too.
// Writers emit x y z [rgb] [normal_x normal_y normal_z] [scalars], all SIZE 4: rgb is TYPE F
// (packed 0x00RRGGBB bits) in binary bodies and TYPE U (the integer) in ascii, as PCL does.
// Errors throw InputError naming the file (and line for ascii); writers use AtomicFile.

#include <locard/core/point_cloud.hpp>

#include <filesystem>

namespace locard {

enum class PcdEncoding { Ascii, Binary, BinaryCompressed };

PointCloud read_pcd(const std::filesystem::path& path);
void write_pcd(const std::filesystem::path& path, const PointCloud& cloud,
               PcdEncoding encoding = PcdEncoding::Binary);

}  // namespace locard
