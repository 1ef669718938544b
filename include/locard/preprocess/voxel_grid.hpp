#pragma once
// Voxel-grid down-sampling: one output point per occupied voxel, at the exact centroid of the
// input points in that voxel (accumulated in double), with the mean colour (rounded to the
// nearest integer), the mean normal (renormalised; a voxel whose normals cancel out gets the
// normal of its first point) and the mean of every scalar field.
//
// Voxels are anchored at the world origin: point p falls in voxel floor(p * (1 / voxel_size))
// (computed in double), so the same scene gives the same voxels whatever was cropped around
// it. The output is ordered by voxel index (x, then y, then z, each increasing) and is
// bit-for-bit identical for any thread count. Non-finite points are dropped and counted.
//
// Implementation: parallel voxel keys, with an estimate of the voxel count (HyperLogLog on a
// sample of the keys); the key space is split into ranges of equal point counts, and each range
// is accumulated by one task scanning the points in input order into an open-addressing hash
// table sized from the estimate, each slot holding a voxel's key and sums (so each voxel is
// summed in input order by exactly one task); each range's voxels are then sorted by key.

#include <locard/preprocess/point_selection.hpp>

namespace locard {

struct VoxelGridResult {
  PointCloud cloud;
  std::vector<std::uint32_t> points_per_voxel;  // input points averaged into each output point
  FilterReport report;
};

// Throws InputError if voxel_size is not a positive finite number or if the cloud spans more
// than 2^21 voxels along an axis (the voxel size is then too small for the scene).
VoxelGridResult voxel_down_sample(const PointCloud& cloud, float voxel_size);

}  // namespace locard
