// The case's registered views as E57 (ASTM E2807), the exchange format of forensic scanners:
// one data3D per view, its points in the view's own frame, its pose the registered
// T_world_view - what another tool needs to re-register or re-mesh the case.
#include "forensics/reconstruct_stages.hpp"

#include <locard/io/e57.hpp>
#include <locard/preprocess/depth_to_points.hpp>
#include <locard/preprocess/voxel_grid.hpp>

#include <fmt/format.h>
#include <tbb/parallel_for.h>

namespace locard::forensics::detail {

namespace fs = std::filesystem;

void write_views_e57(CaseFolder& folder, const std::vector<E57View>& views,
                     const std::vector<std::string>& inputs, const std::string& parameters_json,
                     ReconstructSummary& summary) {
  const auto t0 = Clock::now();
  std::vector<E57Scan> scans(views.size());
  for (std::size_t i = 0; i < views.size(); ++i) {
    scans[i].name = views[i].name;
    scans[i].cloud = views[i].cloud;
    scans[i].cloud.normals.clear();  // E57 has no place for them
    scans[i].T_file_scan = views[i].T_world_view;
    scans[i].has_pose = true;
  }
  write_e57(folder.path("cloud/registered.e57"), scans);
  LogStep s;
  s.step = "export e57";
  s.parameters_json = parameters_json;
  s.duration_s = seconds_since(t0);
  for (const std::string& in : inputs) s.inputs.push_back(in);
  s.outputs = {"cloud/registered.e57"};
  folder.append_log_step(s);
  summary.stage_seconds.emplace_back("export e57", seconds_since(t0));
}

std::vector<E57View> rgbd_e57_views(const RgbdSequence& sequence,
                                    const std::vector<std::optional<Isometry3d>>& poses,
                                    const ReconstructParameters& P) {
  std::vector<std::size_t> posed;
  for (std::size_t i = 0; i < poses.size() && i < sequence.frames.size(); ++i)
    if (poses[i]) posed.push_back(i);
  std::vector<E57View> views(posed.size());
  tbb::parallel_for(std::size_t{0}, posed.size(), [&](std::size_t k) {
    const std::size_t i = posed[k];
    DepthToPointsOptions o;
    o.min_depth_m = P.alignment.min_depth_m;
    o.max_depth_m = P.alignment.max_depth_m;
    o.stride = std::max(1, P.alignment.stride);
    const PointCloud points = depth_to_points(sequence.load_frame(i), o);
    views[k].name = fmt::format("frame {}", sequence.frames[i].frame_index);
    views[k].cloud = P.cloud_voxel_m > 0.0
                         ? voxel_down_sample(points, static_cast<float>(P.cloud_voxel_m)).cloud
                         : points;
    views[k].T_world_view = *poses[i];
  });
  return views;
}

}  // namespace locard::forensics::detail
