#pragma once
// Shared by filters_bench and features_bench: the fused 7-Scenes cloud they run on, and
// running a peer program (Open3D script, PCL program) that prints one JSON object.

#include <locard/core/point_cloud.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/preprocess/depth_to_points.hpp>

#include <nlohmann/json.hpp>

#include <sys/resource.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>

namespace locard::bench {

inline const std::filesystem::path kSevenScenes =
    std::filesystem::path(LOCARD_SHARED_DATA) / "7scenes-tsdf-fusion" / "data";

// `frames` frames spread evenly over the 374 with images, back-projected with colour and put
// in the world frame by their ground-truth poses, then concatenated.
inline PointCloud fused_seven_scenes(std::size_t frames) {
  const RgbdSequence sequence = open_rgbd_sequence(kSevenScenes);
  DepthToPointsOptions options;
  options.min_depth_m = 0.1;
  options.max_depth_m = 10.0;
  PointCloud fused;
  const std::size_t step = std::max<std::size_t>(1, sequence.frames.size() / frames);
  for (std::size_t i = 0; i < sequence.frames.size() && i / step < frames; i += step) {
    const RgbdFrame frame = sequence.load_frame(i);
    fused.append(depth_to_points(frame, options, *sequence.frames[i].T_world_camera));
  }
  return fused;
}

// Runs `command` and parses the last line that starts with '{'; a discarded json on failure.
inline nlohmann::json run_peer(const std::string& command) {
  FILE* pipe = ::popen((command + " 2>/dev/null").c_str(), "r");
  if (!pipe) return nlohmann::json(nlohmann::json::value_t::discarded);
  std::string out;
  std::array<char, 4096> buffer{};
  std::size_t n;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0) out.append(buffer.data(), n);
  if (::pclose(pipe) != 0 || out.rfind('{') == std::string::npos) {
    return nlohmann::json(nlohmann::json::value_t::discarded);
  }
  return nlohmann::json::parse(out.substr(out.rfind('{')), nullptr, false);
}

// CPU time of this process, all threads (user + system), in seconds. On a shared machine the
// ratio of CPU times is steadier than the ratio of wall times; both are printed.
inline double cpu_seconds() {
  rusage usage{};
  ::getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

inline std::string quoted(const std::filesystem::path& path) { return "'" + path.string() + "'"; }

}  // namespace locard::bench
