// Picks the reader/writer from the file extension (case-insensitive).

#include <locard/core/error.hpp>
#include <locard/io/e57.hpp>
#include <locard/io/pcd.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/point_cloud_io.hpp>

#include <algorithm>
#include <cctype>

namespace locard {
namespace {

std::string lower_extension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

}  // namespace

bool is_point_cloud_file(const std::filesystem::path& path) {
  const std::string ext = lower_extension(path);
  return ext == ".ply" || ext == ".pcd" || ext == ".e57";
}

PointCloud read_point_cloud(const std::filesystem::path& path) {
  const std::string ext = lower_extension(path);
  if (ext == ".ply") return read_ply(path);
  if (ext == ".pcd") return read_pcd(path);
  if (ext == ".e57") return read_e57_merged(path);
  throw_input_error(path, "unknown point cloud extension '" + ext +
                              "' (expected .ply, .pcd or .e57)");
}

void write_point_cloud(const std::filesystem::path& path, const PointCloud& cloud,
                       const CloudWriteOptions& options) {
  const std::string ext = lower_extension(path);
  if (ext == ".ply") {
    // Compression is a PCD encoding; silently writing an uncompressed PLY would hide a mistake.
    if (options.compressed)
      throw_input_error(path, "binary_compressed is a PCD encoding; PLY cannot be compressed");
    write_ply(path, cloud, options.ascii ? PlyEncoding::Ascii : PlyEncoding::BinaryLittleEndian);
    return;
  }
  if (ext == ".pcd") {
    if (options.ascii && options.compressed)
      throw_input_error(path, "choose ascii or compressed, not both");
    write_pcd(path, cloud,
              options.ascii        ? PcdEncoding::Ascii
              : options.compressed ? PcdEncoding::BinaryCompressed
                                   : PcdEncoding::Binary);
    return;
  }
  if (ext == ".e57") {
    if (options.ascii || options.compressed)
      throw_input_error(path, "E57 is binary only; --ascii and --compressed do not apply");
    write_e57(path, cloud, path.stem().string());  // one scan in the file's frame
    return;
  }
  throw_input_error(path, "unknown point cloud extension '" + ext +
                              "' (expected .ply, .pcd or .e57)");
}

}  // namespace locard
