#pragma once
// Renders what the simulated Kinect records from one pose: the ideal geometry by ray casting
// (one ray per pixel through its centre, z-depth read straight off the hit distance), then the
// sensor model's errors on top.

#include <locard/core/image.hpp>
#include <locard/core/pose.hpp>
#include <locard/sim/kinect_model.hpp>
#include <locard/core/raycaster.hpp>
#include <locard/sim/scene_mesh.hpp>

#include <Eigen/Core>

#include <cstdint>

namespace locard::sim {

// A surface point hit by a ray, with what the sensors see there.
struct SurfaceSample {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // the triangle's stored (outward) normal
  Eigen::Vector3d albedo = Eigen::Vector3d::Zero();   // RGB 0..255, texture applied
  std::uint32_t part = 0;                             // index into SceneMesh::part_names
};

struct SensorFrame {
  ColorImage color;     // registered to depth: same size, same pixels
  DepthImage depth;     // raw units (KinectModel::depth_scale per metre), 0 = no return
  ColorImage color_hd;  // only when asked for: KinectModel::color_hd_intrinsics
};

class ViewRenderer {
 public:
  explicit ViewRenderer(SceneMesh mesh);

  const SceneMesh& scene_mesh() const { return mesh_; }
  const Raycaster& raycaster() const { return raycaster_; }

  SurfaceSample sample(const RayHit& hit, const Eigen::Vector3d& origin,
                       const Eigen::Vector3d& direction) const;
  // Colour the camera records for a sample (8-bit, before sensor noise).
  Eigen::Vector3d shaded_color(const SurfaceSample& sample) const;

  // Ideal depth for intrinsics `K` from T_world_camera; lateral noise, when the model has
  // it, moves each pixel's ray by a seeded sub-pixel offset.
  IdealDepth ideal_depth(const KinectModel& model, const Isometry3d& T_world_camera,
                         std::uint64_t seed, std::uint64_t view) const;
  // Colour image for any pinhole camera at the pose (depth resolution or HD).
  ColorImage color_image(const KinectModel& model, const CameraIntrinsics& K,
                         const Isometry3d& T_world_camera, std::uint64_t seed,
                         std::uint64_t view) const;

  SensorFrame render(const KinectModel& model, const Isometry3d& T_world_camera,
                     std::uint64_t seed, std::uint64_t view, bool color_hd = false) const;

 private:
  IdealDepth trace(const KinectModel& model, const Isometry3d& T_world_camera,
                   std::uint64_t seed, std::uint64_t view, ColorImage* color) const;
  void write_color(ColorImage& image, int u, int v, Eigen::Vector3d rgb,
                   const KinectModel& model, std::uint64_t seed, std::uint64_t view) const;

  SceneMesh mesh_;
  Raycaster raycaster_;
};

// Direction (not normalised, camera z component 1) of the ray through pixel (u, v), in the
// world frame: its hit distance t is the z-depth.
Eigen::Vector3d pixel_ray(const CameraIntrinsics& K, const Isometry3d& T_world_camera, double u,
                          double v);

}  // namespace locard::sim
