#include <locard/sim/scan_writer.hpp>

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/io/image_io.hpp>
#include <locard/io/ply.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/io/trajectory_io.hpp>
#include <locard/sim/scan_protocol.hpp>
#include <locard/sim/scan_simulator.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>

namespace locard::sim {
namespace {

namespace fs = std::filesystem;

std::string frame_name(std::size_t view) { return fmt::format("{:06d}.png", view); }

void write_index(const fs::path& path, const std::string& title, const Scene& scene,
                 const std::string& folder, const Trajectory& trajectory) {
  AtomicFile file(path, /*binary=*/false);
  auto& out = file.stream();
  out << "# " << title << "\n";
  out << "# simulated by locard scan-sim: scene '" << scene.name << "', seed "
      << scene.scanner.seed << "\n";
  out << "# timestamp filename\n";
  for (const StampedPose& pose : trajectory)
    out << fmt::format("{:.6f} {}/{}\n", pose.timestamp, folder,
                       frame_name(static_cast<std::size_t>(pose.frame_index)));
  file.commit();
}

nlohmann::ordered_json intrinsics_json(const CameraIntrinsics& K) {
  return {{"name", K.name}, {"width", K.width}, {"height", K.height}, {"fx", K.fx},
          {"fy", K.fy},     {"cx", K.cx},       {"cy", K.cy}};
}

// Everything needed to re-run the simulation, and nothing that changes between runs (no
// clock), so the file is byte-identical for a seed too.
void write_provenance(const fs::path& path, const ScanSimulator& sim, bool color_hd) {
  const Scene& scene = sim.scene();
  const KinectModel& m = sim.model();
  nlohmann::ordered_json doc;
  doc["generator"] = "locard scan-sim";
  doc["locard_version"] = LOCARD_VERSION;
  doc["scene"] = scene.name;
  doc["scene_source"] = scene.source.string();
  doc["seed"] = scene.scanner.seed;
  doc["views"] = sim.view_count();
  if (scene.scanner.ring_views.empty()) doc["views_per_pitch_row"] = scene.scanner.views;
  else doc["ring_views"] = scene.scanner.ring_views;
  doc["pitch_deg"] = scene.scanner.pitch_deg;
  doc["position"] = {scene.scanner.position.x(), scene.scanner.position.y(),
                     scene.scanner.position.z()};
  doc["yaw_jitter_deg"] = scene.scanner.yaw_jitter_deg;
  doc["position_jitter_m"] = scene.scanner.position_jitter_m;
  doc["frame_rate_hz"] = kSimulatedFrameRate;
  doc["noise"] = scene.scanner.noise;
  doc["color_hd"] = color_hd;
  nlohmann::ordered_json sensor;
  sensor["model"] = to_string(m.sensor);
  sensor["depth_intrinsics"] = intrinsics_json(m.intrinsics);
  if (color_hd) sensor["color_hd_intrinsics"] = intrinsics_json(m.color_hd_intrinsics);
  sensor["depth_scale"] = m.depth_scale;
  sensor["min_range_m"] = m.min_range_m;
  sensor["max_range_m"] = m.max_range_m;
  sensor["axial_noise"] = m.axial_noise;
  switch (m.sensor) {
    case ScannerModel::KinectV2:
      sensor["axial_noise_model"] =
          "Fankhauser et al. 2015: sigma_z[mm] = 1.5 - 0.5 z + 0.3 z^2 + "
          "0.1 z^1.5 theta^2 / (pi/2 - theta)^2";
      sensor["lateral_sigma_m"] = m.lateral_sigma_m;
      break;
    case ScannerModel::KinectV1:
      sensor["axial_noise_model"] =
          "Khoshelham & Elberink 2012, Nguyen et al. 2012: sigma_z[m] = 0.0012 + "
          "0.0019 (z - 0.4)^2 + 0.0001 / sqrt(z) theta^2 / (pi/2 - theta)^2";
      sensor["lateral_noise_model"] = "Nguyen et al. 2012: sigma_L[px] = base + grazing theta / "
                                      "(pi/2 - theta)";
      sensor["lateral_sigma_px"] = {{"base", m.lateral_base_px}, {"grazing", m.lateral_grazing_px}};
      sensor["disparity_step_px"] = m.disparity_step_px;
      sensor["disparity_focal_px"] = m.disparity_focal_px;
      sensor["baseline_m"] = m.baseline_m;
      break;
  }
  sensor["flying_pixel_probability"] = m.flying_pixel_probability;
  sensor["flying_pixel_min_jump_m"] = m.flying_pixel_min_jump_m;
  sensor["dropouts"] = m.dropouts;
  sensor["grazing_dropout_deg"] = {m.grazing_dropout_start_deg, m.grazing_dropout_full_deg};
  sensor["dark_dropout_luminance"] = {m.dark_dropout_start_luminance,
                                      m.dark_dropout_full_luminance};
  sensor["color_noise_sigma"] = m.color_noise_sigma;
  doc["sensor"] = sensor;
  AtomicFile file(path, /*binary=*/false);
  file.stream() << doc.dump(2) << "\n";
  file.commit();
}

// capture.json: the sequence traits a reader takes from the data (src/io/sequence_traits.cpp).
// Views are written ring after ring, as tripod_scan_trajectory plans them.
void write_capture(const fs::path& path, const ScanSimulator& sim) {
  const ScannerSpec& scanner = sim.scene().scanner;
  const DepthSensorKind depth_sensor = depth_sensor_kind(sim.model().sensor);
  nlohmann::ordered_json doc;
  doc["sensor"] = to_string(sim.model().sensor);
  doc["depth_sensor"] = to_string(depth_sensor);
  doc["capture"] = to_string(CaptureKind::TripodTurn);
  doc["color_registered_to_depth"] = true;  // rgb/ is rendered on the depth pixel grid
  std::vector<std::size_t> rings;
  for (std::size_t r = 0; r < scanner.pitch_deg.size(); ++r)
    rings.push_back(static_cast<std::size_t>(scanner.views_in_ring(r)));
  doc["ring_sizes"] = rings;
  AtomicFile file(path, /*binary=*/false);
  file.stream() << doc.dump(2) << "\n";
  file.commit();
}

void write_text(const fs::path& path, const std::string& text) {
  AtomicFile file(path, /*binary=*/true);
  file.stream() << text;
  file.commit();
}

}  // namespace

void check_output_folder(const fs::path& folder, bool force) {
  std::error_code ec;
  if (!fs::exists(folder, ec)) return;
  if (!fs::is_directory(folder, ec))
    throw_input_error(folder, "output exists and is not a folder");
  if (!force && !fs::is_empty(folder, ec))
    throw_input_error(folder, "output folder is not empty; pass --force to write into it");
}

ScanWriteSummary write_simulated_scan(const Scene& scene, const fs::path& folder,
                                      const ScanWriteOptions& options) {
  return write_simulated_scan(scene, folder, options, KinectModel::of(scene.scanner.model));
}

ScanWriteSummary write_simulated_scan(const Scene& scene, const fs::path& folder,
                                      const ScanWriteOptions& options,
                                      const KinectModel& model) {
  check_output_folder(folder, options.force);
  const ScanSimulator sim(scene, model);
  const Trajectory& trajectory = sim.trajectory();

  fs::create_directories(folder / "rgb");
  fs::create_directories(folder / "depth");
  if (options.color_hd) fs::create_directories(folder / "rgb_hd");

  ScanWriteSummary summary;
  summary.views = trajectory.size();
  summary.triangles = sim.renderer().scene_mesh().mesh.triangle_count();
  const auto measurements = sim.measurements();
  summary.measurements = measurements.size();

  write_ply(folder / "scene.ply", sim.renderer().scene_mesh().mesh);
  write_measurements_json(folder / "measurements.json", scene.name, measurements);
  write_text(folder / "scene.json", scene.source_text);
  write_provenance(folder / "simulation.json", sim, options.color_hd);
  write_capture(folder / "capture.json", sim);
  write_intrinsics_json(folder / "intrinsics.json", sim.model().intrinsics,
                        sim.model().depth_scale);
  if (options.color_hd)
    write_intrinsics_json(folder / "intrinsics_rgb_hd.json", sim.model().color_hd_intrinsics,
                          sim.model().depth_scale);

  // Views in parallel (each also renders its rows in parallel): PNG encoding is serial per
  // image, so two views at once keep two cores busy.
  std::atomic<std::size_t> done{0};
  std::atomic<std::size_t> valid{0};
  tbb::parallel_for(std::size_t{0}, trajectory.size(), [&](std::size_t view) {
    const SensorFrame frame = sim.render(view, options.color_hd);
    write_png(folder / "rgb" / frame_name(view), frame.color);
    write_png(folder / "depth" / frame_name(view), frame.depth);
    if (options.color_hd) write_png(folder / "rgb_hd" / frame_name(view), frame.color_hd);
    valid += static_cast<std::size_t>(
        std::count_if(frame.depth.data().begin(), frame.depth.data().end(),
                      [](std::uint16_t d) { return d != 0; }));
    const std::size_t n = ++done;
    if (options.progress) options.progress(n, trajectory.size());
  });
  summary.depth_pixels = trajectory.size() * static_cast<std::size_t>(sim.model().intrinsics.width) *
                         static_cast<std::size_t>(sim.model().intrinsics.height);
  summary.valid_depth_pixels = valid.load();

  write_tum_trajectory(folder / "groundtruth.txt", trajectory);
  if (options.color_hd)
    write_index(folder / "rgb_hd.txt", "color images, 1920x1080", scene, "rgb_hd", trajectory);
  write_index(folder / "depth.txt", "depth maps", scene, "depth", trajectory);
  write_index(folder / "rgb.txt", "color images", scene, "rgb", trajectory);
  return summary;
}

}  // namespace locard::sim
