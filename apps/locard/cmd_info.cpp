// `locard info PATH`: what a dataset or cloud file holds, without changing anything.
#include "commands.hpp"

#include <locard/core/error.hpp>
#include <locard/core/progress.hpp>
#include <locard/io/e57.hpp>
#include <locard/io/image_io.hpp>
#include <locard/io/point_cloud_io.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/io/range_scans.hpp>
#include <locard/io/stanford_conf.hpp>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstdio>
#include <limits>
#include <mutex>
#include <numbers>

namespace locard::cli {
namespace {

struct InfoOptions {
  std::string path;
  bool json = false;
  int every = 1;
};

nlohmann::json intrinsics_json(const CameraIntrinsics& k) {
  return {{"name", k.name}, {"preset", k.matching_preset().value_or("")}, {"width", k.width}, {"height", k.height},
          {"fx", k.fx},     {"fy", k.fy},       {"cx", k.cx},
          {"cy", k.cy}};
}

// Min/max valid depth in metres over the frames (every `every`-th), read in parallel.
std::pair<double, double> depth_range(const RgbdSequence& seq, int every, bool quiet) {
  std::vector<std::size_t> picked;
  for (std::size_t i = 0; i < seq.frames.size(); i += static_cast<std::size_t>(every))
    picked.push_back(i);
  ProgressBar bar("reading depth", picked.size(), ProgressBar::should_show(quiet));
  std::mutex mutex;
  unsigned lo = std::numeric_limits<unsigned>::max(), hi = 0;
  tbb::parallel_for(std::size_t{0}, picked.size(), [&](std::size_t j) {
    const DepthImage depth = seq.load_depth(picked[j]);
    unsigned flo = std::numeric_limits<unsigned>::max(), fhi = 0;
    for (const std::uint16_t d : depth.data())
      if (d) {
        flo = std::min<unsigned>(flo, d);
        fhi = std::max<unsigned>(fhi, d);
      }
    {
      std::lock_guard lock(mutex);
      lo = std::min(lo, flo);
      hi = std::max(hi, fhi);
    }
    bar.advance();
  });
  bar.finish();
  if (hi == 0) return {0.0, 0.0};
  return {lo / seq.depth_scale, hi / seq.depth_scale};
}

int info_sequence(const InfoOptions& opt, const GlobalOptions& global) {
  const RgbdSequence seq = open_rgbd_sequence(opt.path);
  const auto [dmin, dmax] = depth_range(seq, opt.every, global.quiet);
  const auto& k = seq.intrinsics;
  if (opt.json) {
    nlohmann::json j = {{"path", opt.path},
                        {"format", std::string(to_string(seq.format))},
                        {"frames", seq.frames.size()},
                        {"resolution", {k.width, k.height}},
                        {"intrinsics", intrinsics_json(k)},
                        {"intrinsics_source", seq.intrinsics_source},
                        {"depth_scale", seq.depth_scale},
                        {"depth_range_m", {dmin, dmax}},
                        {"ground_truth", seq.has_ground_truth()},
                        {"ground_truth_poses", seq.ground_truth.size()},
                        {"absent_tail_frames", seq.absent_tail_frames},
                        {"traits",
                         {{"sensor", std::string(to_string(seq.traits.sensor))},
                          {"capture", std::string(to_string(seq.traits.capture))},
                          {"color_registered_to_depth", seq.traits.color_registered_to_depth},
                          {"ring_sizes", seq.traits.ring_sizes},
                          {"source", seq.traits.source}}}};
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  const std::size_t with_pose =
      std::count_if(seq.frames.begin(), seq.frames.end(),
                    [](const FrameEntry& f) { return f.T_world_camera.has_value(); });
  fmt::print("path:          {}\n", opt.path);
  fmt::print("format:        {}\n", to_string(seq.format));
  fmt::print("frames:        {} with images\n", seq.frames.size());
  if (seq.absent_tail_frames)
    fmt::print("               (+{} listed after the last present depth image: left out)\n",
               seq.absent_tail_frames);
  if (!seq.frames.empty())
    fmt::print("time span:     {:.3f} s .. {:.3f} s\n", seq.frames.front().timestamp,
               seq.frames.back().timestamp);
  fmt::print("resolution:    {}x{}\n", k.width, k.height);
  const auto preset = k.matching_preset();
  fmt::print("intrinsics:    fx={} fy={} cx={} cy={} (from {}{})\n", k.fx, k.fy, k.cx, k.cy,
             seq.intrinsics_source, preset ? "; = preset " + *preset : std::string());
  fmt::print("depth scale:   {} units per metre\n", seq.depth_scale);
  fmt::print("depth range:   {:.3f} m .. {:.3f} m{}\n", dmin, dmax,
             opt.every > 1 ? fmt::format(" (every {}th frame)", opt.every) : "");
  if (seq.has_ground_truth())
    fmt::print("ground truth:  yes, {} poses ({} of the frames with images have one)\n",
               seq.ground_truth.size(), with_pose);
  else
    fmt::print("ground truth:  no\n");
  const SequenceTraits& t = seq.traits;
  fmt::print("depth sensor:  {}\n", to_string(t.sensor));
  fmt::print("capture:       {}{}\n", to_string(t.capture),
             t.ring_sizes.empty() ? std::string()
                                  : fmt::format(" (rings of {} views)", fmt::join(t.ring_sizes, ", ")));
  fmt::print("colour:        {}\n", t.color_registered_to_depth ? "registered to depth"
                                                                 : "not registered to depth");
  fmt::print("traits from:   {}\n", t.source);
  return 0;
}

// One line per E57 scan: points kept of records stored, fields, pose.
std::string e57_scan_line(std::size_t i, const E57Scan& s) {
  const E57ScanFields& f = s.fields;
  std::string fields = f.coordinates == E57Coordinates::Spherical ? "spherical" : "cartesian";
  if (f.color) fields += ", colour";
  if (f.intensity) fields += ", intensity";
  if (f.row_column) fields += ", row/column";
  std::string pose = "none (identity)";
  if (s.has_pose) {
    const Eigen::AngleAxisd r(s.T_file_scan.linear());
    const Eigen::Vector3d t = s.T_file_scan.translation();
    pose = fmt::format("t [{:.4f} {:.4f} {:.4f}] m, rotation {:.3f} deg about [{:.3f} {:.3f} {:.3f}]",
                       t.x(), t.y(), t.z(), r.angle() * 180.0 / std::numbers::pi, r.axis().x(), r.axis().y(),
                       r.axis().z());
  }
  return fmt::format("  [{}] '{}': {} points of {} records; {}; pose {}", i, s.name,
                     s.cloud.size(), s.record_count, fields, pose);
}

nlohmann::json e57_scan_json(const E57Scan& s) {
  nlohmann::json pose = nullptr;
  if (s.has_pose) {
    const Eigen::Quaterniond q(s.T_file_scan.linear());
    const Eigen::Vector3d t = s.T_file_scan.translation();
    pose = {{"translation", {t.x(), t.y(), t.z()}}, {"rotation_wxyz", {q.w(), q.x(), q.y(), q.z()}}};
  }
  const E57ScanFields& f = s.fields;
  return {{"name", s.name},
          {"guid", s.guid},
          {"records", s.record_count},
          {"points", s.cloud.size()},
          {"coordinates", f.coordinates == E57Coordinates::Spherical ? "spherical" : "cartesian"},
          {"colors", f.color},
          {"intensity", f.intensity},
          {"row_column", f.row_column},
          {"pose", pose}};
}

int info_cloud(const InfoOptions& opt, DatasetFormat format) {
  PointCloud cloud;
  nlohmann::json e57_json;  // E57 only: scans and notes
  std::vector<std::string> e57_lines;
  if (format == DatasetFormat::E57Cloud) {
    E57File file = read_e57(opt.path);
    e57_json = {{"guid", file.guid}, {"scans", nlohmann::json::array()}, {"notes", file.notes}};
    e57_lines.push_back(fmt::format("scans:         {}", file.scans.size()));
    for (std::size_t i = 0; i < file.scans.size(); ++i) {
      e57_json["scans"].push_back(e57_scan_json(file.scans[i]));
      e57_lines.push_back(e57_scan_line(i, file.scans[i]));
    }
    for (const auto& note : file.notes) e57_lines.push_back("note:          " + note);
    cloud = merge_scans(std::move(file.scans));
  } else {
    cloud = read_point_cloud(opt.path);
  }
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
  Eigen::Vector3f hi = -lo;
  std::size_t non_finite = 0;  // NaN or infinite coordinates: said, never silently folded in
  for (const auto& p : cloud.positions)
    if (p.allFinite()) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    } else {
      ++non_finite;
    }
  std::vector<std::string> scalars;
  for (const auto& s : cloud.scalars) scalars.push_back(s.name);
  if (opt.json) {
    nlohmann::json j = {{"path", opt.path},
                        {"format", std::string(to_string(format))},
                        {"points", cloud.size()},
                        {"normals", cloud.has_normals()},
                        {"colors", cloud.has_colors()},
                        {"scalars", scalars},
                        {"non_finite_points", non_finite}};
    if (!cloud.empty()) j["bounds"] = {{lo.x(), lo.y(), lo.z()}, {hi.x(), hi.y(), hi.z()}};
    if (!e57_json.is_null()) j["e57"] = e57_json;
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  fmt::print("path:          {}\n", opt.path);
  fmt::print("format:        {}\n", to_string(format));
  for (const auto& line : e57_lines) fmt::print("{}\n", line);
  fmt::print("points:        {}{}\n", cloud.size(),
             e57_lines.empty() ? "" : " (all scans, in the file's frame)");
  fmt::print("attributes:    positions{}{}{}\n", cloud.has_normals() ? ", normals" : "",
             cloud.has_colors() ? ", colours" : "",
             scalars.empty() ? "" : ", " + fmt::format("{}", fmt::join(scalars, ", ")));
  if (non_finite < cloud.size())
    fmt::print("bounds:        [{:.4f} {:.4f} {:.4f}] .. [{:.4f} {:.4f} {:.4f}] m{}\n", lo.x(),
               lo.y(), lo.z(), hi.x(), hi.y(), hi.z(),
               non_finite ? " (of the finite points)" : "");
  if (non_finite)
    fmt::print("non-finite:    {} points with NaN or infinite coordinates\n", non_finite);
  fmt::print("ground truth:  no\n");
  return 0;
}

int info_conf(const InfoOptions& opt) {
  std::filesystem::path conf_path = opt.path;
  if (std::filesystem::is_directory(conf_path))
    for (const auto& e : std::filesystem::directory_iterator(conf_path))
      if (e.path().extension() == ".conf") conf_path = e.path();
  const StanfordConf conf = read_stanford_conf(conf_path);
  if (opt.json) {
    nlohmann::json scans = nlohmann::json::array();
    for (const auto& s : conf.scans)
      scans.push_back({{"name", s.name}, {"exists", std::filesystem::exists(s.file)}});
    std::printf("%s\n", nlohmann::json{{"path", conf_path.string()},
                                       {"format", "stanford-conf"},
                                       {"scans", scans},
                                       {"ground_truth", true}}
                            .dump(2)
                            .c_str());
    return 0;
  }
  fmt::print("path:          {}\n", conf_path.string());
  fmt::print("format:        stanford-conf (per-view range scans with alignment)\n");
  fmt::print("scans:         {}\n", conf.scans.size());
  for (const auto& s : conf.scans)
    fmt::print("  {:<14} {}\n", s.name, std::filesystem::exists(s.file) ? "" : "(missing)");
  fmt::print("ground truth:  yes, {} scan poses\n", conf.scans.size());
  return 0;
}

// A folder of range scans (io/range_scans.hpp): the scans `reconstruct` and `align` register.
int info_scan_folder(const InfoOptions& opt) {
  const std::optional<RangeScanSet> set = find_range_scans(opt.path);
  if (!set) throw_input_error(opt.path, "expected a folder of two or more .ply / .pcd scans");
  if (opt.json) {
    nlohmann::json scans = nlohmann::json::array();
    for (const auto& s : set->scans) scans.push_back({{"name", s.name}});
    std::printf("%s\n", nlohmann::json{{"path", opt.path}, {"format", "range-scan-folder"},
                                       {"scans", scans}, {"ground_truth", false}}
                            .dump(2)
                            .c_str());
    return 0;
  }
  fmt::print("path:          {}\n", opt.path);
  fmt::print("format:        range-scan-folder (scans in their own frames, no poses)\n");
  fmt::print("scans:         {}\n", set->scans.size());
  for (const auto& s : set->scans) fmt::print("  {}\n", s.name);
  return 0;
}

}  // namespace

void register_info(CLI::App& app, GlobalOptions& global) {
  auto opt = std::make_shared<InfoOptions>();
  CLI::App* sub = app.add_subcommand(
      "info", "Describe an RGB-D sequence (TUM, 7-Scenes, Redwood), a point cloud (PLY, PCD, E57) "
              "or a Stanford .conf scan set: format, frames, resolution, intrinsics, depth "
              "range, ground truth");
  sub->add_option("path", opt->path, "Dataset folder or file")->required();
  sub->add_flag("--json", opt->json, "Print machine-readable JSON");
  sub->add_option("--every", opt->every, "Read every N-th depth image for the depth range")
      ->check(CLI::PositiveNumber);
  set_runner(sub, [opt, &global]() {
    const DatasetFormat format = detect_format(opt->path);
    switch (format) {
      case DatasetFormat::Tum:
      case DatasetFormat::SevenScenes:
      case DatasetFormat::Redwood:
        return info_sequence(*opt, global);
      case DatasetFormat::PlyCloud:
      case DatasetFormat::PcdCloud:
      case DatasetFormat::E57Cloud:
        return info_cloud(*opt, format);
      case DatasetFormat::StanfordConf:
        return info_conf(*opt);
      case DatasetFormat::RangeScanFolder:
        return info_scan_folder(*opt);
      case DatasetFormat::Unknown:
        break;
    }
    if (!std::filesystem::exists(opt->path)) throw_input_error(opt->path, "no such file or folder");
    throw_input_error(opt->path,
                      "not a recognised dataset (looked for TUM rgb.txt/depth.txt or "
                      "associate.txt, 7-Scenes frame-*.pose.txt, Redwood color/ + depth/, .ply, "
                      ".pcd, .e57, .conf)");
  });
}

}  // namespace locard::cli
