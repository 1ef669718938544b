// Range-scan sets (see range_scans.hpp): which scans, in which files, with which poses.
#include <locard/io/range_scans.hpp>

#include <locard/core/error.hpp>
#include <locard/io/e57.hpp>
#include <locard/io/point_cloud_io.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/io/stanford_conf.hpp>

#include "io/text_lines.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <set>

namespace locard {
namespace {

namespace fs = std::filesystem;

RangeScanSet from_conf(const fs::path& input, const fs::path& conf_path) {
  const StanfordConf conf = read_stanford_conf(conf_path);
  RangeScanSet set;
  set.source = RangeScanSource::StanfordConf;
  set.viewpoint = ScanViewpoint::FarAlongZ;
  set.input = input;
  std::set<fs::path> files = {conf_path};
  for (const RangeScan& s : conf.scans) {
    set.scans.push_back({s.name, s.file, 0, s.T_world_scan});
    files.insert(s.file);
  }
  set.files.assign(files.begin(), files.end());
  return set;
}

std::optional<fs::path> first_conf(const fs::path& folder) {
  std::vector<fs::path> confs;
  for (const auto& e : fs::directory_iterator(folder))
    if (e.is_regular_file() && io_detail::lower_extension(e.path()) == ".conf")
      confs.push_back(e.path());
  if (confs.empty()) return std::nullopt;
  return *std::min_element(confs.begin(), confs.end());
}

RangeScanSet from_folder(const fs::path& folder) {
  RangeScanSet set;
  set.source = RangeScanSource::ScanFolder;
  set.input = folder;
  std::vector<fs::path> clouds;
  for (const auto& e : fs::directory_iterator(folder)) {
    const std::string ext = io_detail::lower_extension(e.path());
    if (e.is_regular_file() && (ext == ".ply" || ext == ".pcd")) clouds.push_back(e.path());
  }
  std::sort(clouds.begin(), clouds.end());
  for (const fs::path& c : clouds) set.scans.push_back({c.filename().string(), c, 0, std::nullopt});
  set.files = clouds;
  return set;
}

// An E57 file is a scan set when it holds two scans or more (one scan is a single cloud).
std::optional<RangeScanSet> from_e57(const fs::path& file) {
  const E57File e57 = read_e57(file);
  if (e57.scans.size() < 2) return std::nullopt;
  RangeScanSet set;
  set.source = RangeScanSource::E57;
  set.input = file;
  set.files = {file};
  for (std::size_t i = 0; i < e57.scans.size(); ++i) {
    const E57Scan& s = e57.scans[i];
    RangeScanEntry entry{s.name.empty() ? fmt::format("scan {}", i) : s.name, file, i,
                         std::nullopt};
    if (s.has_pose) entry.T_world_scan = s.T_file_scan;
    set.scans.push_back(std::move(entry));
  }
  return set;
}

}  // namespace

std::string_view to_string(RangeScanSource source) {
  switch (source) {
    case RangeScanSource::StanfordConf: return "Stanford .conf";
    case RangeScanSource::ScanFolder: return "folder of range scans";
    case RangeScanSource::E57: return "E57 scans";
  }
  return "unknown";
}

bool RangeScanSet::all_posed() const {
  return std::all_of(scans.begin(), scans.end(), [](const auto& s) { return s.T_world_scan; });
}

bool RangeScanSet::any_posed() const {
  return std::any_of(scans.begin(), scans.end(), [](const auto& s) { return s.T_world_scan; });
}

std::optional<RangeScanSet> find_range_scans(const fs::path& path) {
  switch (detect_format(path)) {
    case DatasetFormat::StanfordConf:
      if (fs::is_directory(path)) return from_conf(path, *first_conf(path));
      return from_conf(path, path);
    case DatasetFormat::RangeScanFolder: return from_folder(path);
    case DatasetFormat::E57Cloud: return from_e57(path);
    case DatasetFormat::Tum:
    case DatasetFormat::SevenScenes:
    case DatasetFormat::Redwood:
    case DatasetFormat::PlyCloud:
    case DatasetFormat::PcdCloud:
    case DatasetFormat::Unknown: break;
  }
  return std::nullopt;
}

std::vector<PointCloud> load_range_scans(const RangeScanSet& set) {
  std::vector<PointCloud> clouds;
  if (set.source == RangeScanSource::E57) {
    E57File e57 = read_e57(set.input);
    for (const RangeScanEntry& s : set.scans) clouds.push_back(std::move(e57.scans.at(s.index_in_file).cloud));
    return clouds;
  }
  for (const RangeScanEntry& s : set.scans) {
    if (!fs::is_regular_file(s.file)) throw_input_error(s.file, "scan file not found");
    clouds.push_back(read_point_cloud(s.file));
  }
  return clouds;
}

Eigen::Vector3f sensor_position(ScanViewpoint viewpoint, const PointCloud& scan) {
  switch (viewpoint) {
    case ScanViewpoint::Origin: return Eigen::Vector3f::Zero();
    case ScanViewpoint::FarAlongZ: {
      // A point far along +z from the scan's centre: every normal then faces +z's side.
      Eigen::Vector3d c = Eigen::Vector3d::Zero();
      for (const Eigen::Vector3f& p : scan.positions) c += p.cast<double>();
      if (!scan.positions.empty()) c /= static_cast<double>(scan.positions.size());
      return (c + Eigen::Vector3d(0.0, 0.0, 1.0e4)).cast<float>();
    }
  }
  return Eigen::Vector3f::Zero();
}

}  // namespace locard
