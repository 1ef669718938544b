#pragma once
// Truncated signed distance fusion of RGB-D frames (Curless & Levoy 1996) in sparse voxel
// blocks (Niessner et al. 2013, "Real-time 3D reconstruction at scale using voxel hashing"),
// and coloured marching cubes over it.
//
// Voxel g (integer coordinates) has its centre at (g + 0.5) * voxel_size in the world frame.
// Voxels live in blocks of 8^3, allocated on demand in a hash map keyed by block coordinates.
//
// Integration of one frame with pose T_world_camera (camera-to-world):
//  1. allocation: every valid depth pixel touches the blocks its ray crosses within the
//     truncation band, depth - truncation to depth + truncation (sampled at half a block);
//  2. update, parallel over the touched blocks: each voxel centre is moved into the camera,
//     p_c = T_world_camera^-1 * p, projected to the nearest pixel (u, v) with depth d and
//        sdf = (d - z_c) * sqrt(1 + ((u - cx)/fx)^2 + ((v - cy)/fy)^2)   (distance along the ray)
//     and, when sdf > -truncation, the running weighted means
//        tsdf <- (tsdf * w + min(1, sdf / truncation)) / (w + 1),  colour likewise, w <- w + 1.
// Extraction runs marching cubes over every cube whose 8 corners have weight > 0: one vertex
// per crossed voxel edge (position and colour interpolated linearly to the zero crossing),
// shared by every cube that uses that edge, so the mesh is welded and, away from unobserved
// voxels, closed. The cube triangulation resolves ambiguous faces the same way on both sides
// of a face (the negative corners are kept apart), so neighbouring cubes never leave cracks.
// Triangles are counter-clockwise seen from the positive (free-space) side.
// Output order follows sorted block coordinates: the same frames give the same mesh, bit for
// bit, for any thread count.

#include <locard/core/pose.hpp>
#include <locard/core/rgbd_frame.hpp>
#include <locard/core/triangle_mesh.hpp>

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>

namespace locard {

struct TsdfOptions {
  double voxel_size = 0.01;   // metres
  double truncation = 0.04;   // metres; the band either side of the surface that is fused
  double max_depth_m = 4.0;   // farther readings are ignored (Open3D's depth_trunc)
  double min_depth_m = 0.0;   // closer readings are ignored
  bool integrate_color = true;
};

struct TsdfVoxel {
  float tsdf = 1.f;    // signed distance / truncation, in [-1, 1]; > 0 in front of surfaces
  float weight = 0.f;  // observations fused; 0 = never observed
  Rgb8 color;
  std::uint8_t pad = 0;
};

struct TsdfStats {
  std::size_t blocks = 0;
  std::size_t frames = 0;
  std::size_t memory_bytes = 0;  // voxel blocks plus the hash map, approximately
};

class TsdfVolume {
 public:
  static constexpr int kBlockSide = 8;  // voxels per block edge

  // Throws InputError when the voxel size or truncation is not positive and finite, or the
  // truncation is smaller than one voxel.
  explicit TsdfVolume(const TsdfOptions& options);
  ~TsdfVolume();
  TsdfVolume(TsdfVolume&&) noexcept;
  TsdfVolume& operator=(TsdfVolume&&) noexcept;
  TsdfVolume(const TsdfVolume&) = delete;
  TsdfVolume& operator=(const TsdfVolume&) = delete;

  const TsdfOptions& options() const;

  // Fuses one frame seen from T_world_camera. Colour is used when the frame has a colour
  // image of the depth image's size and options.integrate_color is set.
  void integrate(const RgbdFrame& frame, const Isometry3d& T_world_camera);

  // Marching cubes over the whole volume (see the header comment). Vertex colours are set when
  // colour was integrated; vertex normals are left empty.
  TriangleMesh extract_mesh() const;
  TsdfStats stats() const;

  // Direct voxel access (tests, tools). voxel() is empty when the block is not allocated.
  std::optional<TsdfVoxel> voxel(const Eigen::Vector3i& index) const;
  void set_voxel(const Eigen::Vector3i& index, const TsdfVoxel& value);
  // World position of a voxel centre.
  Eigen::Vector3d voxel_center(const Eigen::Vector3i& index) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace locard
