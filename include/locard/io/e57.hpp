#pragma once
// E57 (ASTM E2807) point clouds: our own reader and writer.
//
// An E57 file is a sequence of 1024-byte pages, each ending in a CRC-32C of its first 1020
// bytes; stripping the CRCs gives the "logical" file. The logical file holds a 48-byte header,
// binary sections and an XML section that describes the data. Each scan is a `data3D` entry
// whose points live in a CompressedVector section: data packets that carry one bytestream per
// field (Float single/double, Integer and ScaledInteger bit-packed between a minimum and a
// maximum).
//
// Read: cartesianX/Y/Z or sphericalRange/Azimuth/Elevation (turned into cartesian), the
// invalid-state fields (only records with state 0 are kept; 1 "direction only" and 2 "invalid"
// are dropped), colorRed/Green/Blue (scaled to 8 bits by colorLimits), intensity (normalised to
// 0..1 by intensityLimits, kept as the scalar field "intensity"), the scan's pose, name and
// guid, any number of scans. images2D and fields Locard has no use for (rowIndex, timeStamp,
// ...) are not read; what was left out is said in E57File::notes.
// Write: one data3D per scan with its pose, cartesian xyz as single-precision floats (read back
// bit-identical), colour as 8-bit integers (colorLimits 0..255), the scalar field "intensity"
// as single floats. Normals and other scalar fields have no place in a standard E57 data3D and
// are not written.
//
// Every offset, length and count is checked against the file: a truncated or corrupt file
// throws InputError naming the file and the place (page, byte offset or XML element).

#include <locard/core/point_cloud.hpp>
#include <locard/core/pose.hpp>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace locard {

enum class E57Coordinates { Cartesian, Spherical };

// What a scan's point records held in the file (filled by the reader; ignored by the writer).
struct E57ScanFields {
  E57Coordinates coordinates = E57Coordinates::Cartesian;
  bool color = false;
  bool intensity = false;
  bool row_column = false;     // rowIndex/columnIndex (a structured scan's grid); not kept
  bool invalid_state = false;  // cartesianInvalidState or sphericalInvalidState
};

struct E57Scan {
  std::string name;
  std::string guid;  // writer: empty gives a fresh random guid
  PointCloud cloud;  // in the scan's own frame
  // Maps the scan's frame into the file's frame. A file scan without a pose, or whose pose has
  // no rotation (or no translation) element, gets the identity for the missing part.
  Isometry3d T_file_scan = Isometry3d::Identity();
  bool has_pose = false;
  // Reader only.
  E57ScanFields fields;
  std::uint64_t record_count = 0;  // records stored, before the invalid ones were dropped
};

struct E57File {
  std::string guid;
  std::vector<E57Scan> scans;
  std::vector<std::string> notes;  // what was in the file and not read
};

struct E57WriteOptions {
  std::string guid;  // the file's guid; empty gives a fresh random one
  // creationDateTime as GPS seconds (since 1980-01-06 UTC); unset: now. Set both this and the
  // guids to get the same bytes for the same scans.
  std::optional<double> creation_gps_time;
};

E57File read_e57(const std::filesystem::path& path);
// The scans in the file's frame (each moved by its pose), as one cloud. Colours and the
// intensity field are kept when every non-empty scan has them.
PointCloud merge_scans(std::vector<E57Scan> scans);
// merge_scans(read_e57(path).scans)
PointCloud read_e57_merged(const std::filesystem::path& path);
// Writes atomically (nothing is left behind on error). Throws InputError for a cloud whose
// attribute arrays do not match its positions.
void write_e57(const std::filesystem::path& path, const std::vector<E57Scan>& scans,
               const E57WriteOptions& options = {});
// One scan in the file's frame (no pose), without copying the cloud into an E57Scan.
void write_e57(const std::filesystem::path& path, const PointCloud& cloud,
               const std::string& name, const E57WriteOptions& options = {});

}  // namespace locard
