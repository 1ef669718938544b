#pragma once
// The Stanford 3D Scanning Repository's range-scan alignment file (e.g. bunny/data/bun.conf):
//   camera tx ty tz qx qy qz qw
//   bmesh FILE tx ty tz qx qy qz qw
// Measured convention (see ../shared/data/stanford-bunny/SOURCE.md): a scan's point p maps
// into the common frame as R(q)^T * p + t, i.e. T_world_scan = [R(q)^T | t].

#include <locard/core/pose.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace locard {

struct RangeScan {
  std::string name;                  // file name as written in the .conf ("bun045.ply")
  std::filesystem::path file;        // resolved next to the .conf
  Isometry3d T_world_scan = Isometry3d::Identity();
};

struct StanfordConf {
  std::optional<Isometry3d> camera;  // the `camera` line, same convention
  std::vector<RangeScan> scans;
};

StanfordConf read_stanford_conf(const std::filesystem::path& path);

}  // namespace locard
