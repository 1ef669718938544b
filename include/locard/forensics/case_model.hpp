#pragma once
// The reconstructed scene as measurements see it: the mesh (for ray casting, rendering and
// the "is this point on the model" check) plus the registered views, so a measurement can go
// back to the raw depth points that observed a spot rather than the smoothed mesh.
//
// Uncertainty ingredients kept per view: the final T_world_camera and its 6x6 covariance
// (pose_covariance.hpp: left perturbation in the world frame, rotation then translation), and
// the sensor's noise model (axial sigma at range and incidence, lateral sigma).

#include <locard/alignment/pose_graph.hpp>
#include <locard/core/camera_intrinsics.hpp>
#include <locard/core/point_cloud.hpp>
#include <locard/core/pose.hpp>
#include <locard/core/triangle_mesh.hpp>
#include <locard/io/rgbd_sequence.hpp>

#include <Eigen/Core>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace locard {
class Raycaster;
}

namespace locard::forensics {

class CaseFolder;

// Depth noise of a sensor family, standard deviations in metres.
struct SensorNoiseModel {
  // "kinect_v2" (time of flight, Fankhauser et al. 2015), "structured_light" (Kinect v1 /
  // PrimeSense, Nguyen et al. 2012: 1.2 mm + 1.9 mm (z - 0.4 m)^2), "realsense" (stereo:
  // 0.8 % of z as sigma). Unknown names throw InputError.
  std::string name = "kinect_v2";
  double depth_step_m = 0.001;  // quantisation of the stored depth

  double axial_sigma_m(double z_m, double incidence_rad) const;
  double lateral_sigma_m(double z_m) const;
  // From the kind of depth sensor the reader found (SequenceTraits::sensor): time of flight ->
  // kinect_v2; structured light -> structured_light; synthetic and unknown -> structured_light
  // (ICL-NUIM's noisy release imitates a Kinect v1; for exact depth it overstates the noise,
  // never understates it).
  static SensorNoiseModel for_sensor(DepthSensorKind sensor);
};

struct ViewRecord {
  std::int64_t frame_index = -1;
  double timestamp = 0.0;
  Isometry3d T_world_camera = Isometry3d::Identity();
  Matrix6d covariance = Matrix6d::Zero();  // world-frame left perturbation (rot, trans)
  std::filesystem::path depth_path;        // the original depth image (may be gone)
};

// Raw depth points near a spot, in the world frame.
struct LocalPoints {
  std::vector<Eigen::Vector3d> points;
  std::vector<double> axial_sigma_m;   // per point
  std::vector<std::uint32_t> view;     // index into CaseModel::views()
  std::size_t views_observing = 0;
  bool from_raw_depth = true;          // false: mesh vertices (the inputs were not readable)
};

class CaseModel {
 public:
  // model_truncation_m: the fusion's truncation (0: four voxels, reconstruct's default).
  CaseModel(TriangleMesh mesh, std::vector<ViewRecord> views, CameraIntrinsics intrinsics,
            double depth_scale, SensorNoiseModel noise, double model_voxel_m,
            double model_truncation_m = 0.0);
  // Reads mesh/mesh.ply, alignment/trajectory.txt, alignment/pose_covariance.json and the
  // sensor description in case.json; the voxel and truncation from mesh/mesh.json. Throws
  // InputError naming a missing or bad file. The noise model is the recorded "noise_model";
  // without one, SensorNoiseModel::for_sensor of the recorded "depth_sensor"; a case.json
  // older than both (only "intrinsics_name") gets kinect_v2 when that name is exactly the
  // simulator's preset "kinect_v2", else structured_light (documented fallback for old cases
  // only).
  static CaseModel load(const CaseFolder& folder);
  ~CaseModel();
  CaseModel(CaseModel&&) noexcept;
  CaseModel& operator=(CaseModel&&) noexcept;

  const TriangleMesh& mesh() const;
  const Raycaster& raycaster() const;
  const std::vector<ViewRecord>& views() const;
  const CameraIntrinsics& intrinsics() const;
  const SensorNoiseModel& noise() const;
  double model_voxel_m() const;
  // The band either side of a surface that the fusion averaged depth over: where no plane or
  // edge was fitted, the mesh stands within about this of what the views saw (it rounds
  // corners and thin edges by up to it).
  double model_truncation_m() const;

  // Distance from p to the nearest mesh vertex (the "is it on the model" check).
  double distance_to_mesh(const Eigen::Vector3d& p) const;
  // The views that see p: inside the image, within the depth range, and the ray from the
  // camera reaches p (first mesh hit within `tolerance_m` of p).
  std::vector<std::uint32_t> observing_views(const Eigen::Vector3d& p,
                                             double tolerance_m = 0.03) const;
  // Raw depth points within `radius_m` of p from every observing view (depth images are read
  // once and cached); falls back to mesh vertices when the depth images cannot be read.
  LocalPoints local_points(const Eigen::Vector3d& p, double radius_m) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace locard::forensics
