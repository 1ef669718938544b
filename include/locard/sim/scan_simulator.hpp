#pragma once
// A whole simulated scan of a scene: the ground-truth mesh, the tripod trajectory and the
// sensor, ready to render any of its views. Rendering is thread-safe and deterministic: view i
// is the same bytes whichever thread renders it, in whatever order.

#include <locard/core/pose.hpp>
#include <locard/core/rgbd_frame.hpp>
#include <locard/sim/kinect_model.hpp>
#include <locard/sim/measurements.hpp>
#include <locard/sim/scene.hpp>
#include <locard/sim/view_renderer.hpp>

#include <cstddef>

namespace locard::sim {

class ScanSimulator {
 public:
  // Builds the mesh and BVH and plans the views, with the sensor the scene names
  // (KinectModel::of(scene.scanner.model)). When scene.scanner.noise is false the model's
  // random effects are switched off (its intrinsics, range and quantisation stay).
  explicit ScanSimulator(Scene scene);
  // The same with a sensor model of the caller's (e.g. one effect switched off); it must be
  // the scene's sensor, or Error is thrown.
  ScanSimulator(Scene scene, const KinectModel& model);

  const Scene& scene() const { return scene_; }
  const KinectModel& model() const { return model_; }
  const ViewRenderer& renderer() const { return renderer_; }
  const Trajectory& trajectory() const { return trajectory_; }  // exact T_world_camera
  std::size_t view_count() const { return trajectory_.size(); }
  std::vector<Measurement> measurements() const { return scene_measurements(scene_); }

  SensorFrame render(std::size_t view, bool color_hd = false) const;
  // The view as an RgbdFrame (colour registered to depth, the model's depth scale and
  // intrinsics, frame_index = view), ready for fusion or back-projection at trajectory()[view].
  RgbdFrame render_frame(std::size_t view) const;

 private:
  Scene scene_;
  KinectModel model_;
  ViewRenderer renderer_;
  Trajectory trajectory_;
};

}  // namespace locard::sim
