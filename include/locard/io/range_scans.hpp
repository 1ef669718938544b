#pragma once
// A set of range scans to register into one model (docs/laser-scans.md): each scan a cloud in
// its own sensor frame, with an initial pose when the input states one.
//  - a Stanford .conf (or a folder holding one, the first by name): its scans and their poses
//    (stanford_conf.hpp);
//  - a folder of PLY / PCD scans and nothing RGB-D (DatasetFormat::RangeScanFolder): every
//    .ply / .pcd in it, sorted by name, without poses;
//  - an E57 file with at least two scans: each data3D, with its pose when the file gives one.
// Where each scan's sensor sat is a typed fact of the source (ScanViewpoint), used to orient
// normals towards the sensor (the side the scanner saw is outside).

#include <locard/core/point_cloud.hpp>
#include <locard/core/pose.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace locard {

enum class RangeScanSource {
  StanfordConf,  // a .conf file and the scans it names
  ScanFolder,    // a folder of .ply / .pcd scans
  E57,           // one .e57 file holding several scans
};
std::string_view to_string(RangeScanSource source);

// Where the sensor that took a scan was, in the scan's frame.
enum class ScanViewpoint {
  Origin,      // at the origin of the scan's frame (terrestrial scanners, E57, PCD, PLY)
  FarAlongZ,   // far along +z, looking down -z (the Stanford repository's range grids:
               // the bunny's origin lies just below the object, not at the scanner)
};

struct RangeScanEntry {
  std::string name;              // file name or E57 scan name ("bun045.ply", "scan 1")
  std::filesystem::path file;    // where the points are
  std::size_t index_in_file = 0; // E57: which data3D
  std::optional<Isometry3d> T_world_scan;  // the input's initial pose, when it states one
};

struct RangeScanSet {
  RangeScanSource source = RangeScanSource::ScanFolder;
  ScanViewpoint viewpoint = ScanViewpoint::Origin;
  std::filesystem::path input;             // what was given (file or folder)
  std::vector<std::filesystem::path> files;  // every input file to hash, sorted, no repeats
  std::vector<RangeScanEntry> scans;
  bool all_posed() const;
  bool any_posed() const;
};

// The scan set at `path`, or nothing when it is not one (an RGB-D folder, a single cloud, an
// E57 with one scan). Throws InputError for a malformed .conf or E57.
std::optional<RangeScanSet> find_range_scans(const std::filesystem::path& path);

// Reads every scan's points (in its own frame). Throws InputError naming the file.
std::vector<PointCloud> load_range_scans(const RangeScanSet& set);

// The sensor position used to orient a scan's normals, in the scan's frame.
Eigen::Vector3f sensor_position(ScanViewpoint viewpoint, const PointCloud& scan);

}  // namespace locard
