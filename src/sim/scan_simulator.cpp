#include <locard/sim/scan_simulator.hpp>

#include <locard/core/error.hpp>
#include <locard/sim/scan_protocol.hpp>

#include <string>

namespace locard::sim {

ScanSimulator::ScanSimulator(Scene scene)
    : ScanSimulator(scene, KinectModel::of(scene.scanner.model)) {}

ScanSimulator::ScanSimulator(Scene scene, const KinectModel& model)
    : scene_(std::move(scene)),
      model_(scene_.scanner.noise ? model : model.without_noise()),
      renderer_(build_scene_mesh(scene_)),
      trajectory_(tripod_scan_trajectory(scene_.scanner)) {
  if (model_.sensor != scene_.scanner.model)
    throw Error("ScanSimulator: scene '" + scene_.name + "' is scanned with a " +
                std::string(to_string(scene_.scanner.model)) + " but the sensor model is a " +
                std::string(to_string(model_.sensor)));
}

SensorFrame ScanSimulator::render(std::size_t view, bool color_hd) const {
  if (view >= trajectory_.size())
    throw Error("ScanSimulator: view " + std::to_string(view) + " out of range (" +
                std::to_string(trajectory_.size()) + " views)");
  return renderer_.render(model_, trajectory_[view].T_world_camera, scene_.scanner.seed, view,
                          color_hd);
}

RgbdFrame ScanSimulator::render_frame(std::size_t view) const {
  SensorFrame sensor = render(view);
  RgbdFrame frame;
  frame.color = std::move(sensor.color);
  frame.depth = std::move(sensor.depth);
  frame.depth_scale = model_.depth_scale;
  frame.intrinsics = model_.intrinsics;
  frame.frame_index = static_cast<std::int64_t>(view);
  return frame;
}

}  // namespace locard::sim
