#include <locard/preprocess/voxel_grid.hpp>

#include <locard/core/error.hpp>

#include "core/parallel_radix_sort.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include <fmt/format.h>

#include <bit>
#include <cmath>
#include <limits>
#include <memory>

namespace locard {

namespace {

constexpr double kMaxVoxelsPerAxis = double(1 << 21);

// floor(x) for |x| < 2^62 without a libm call (x86-64's baseline has no SSE4.1 round).
double fast_floor(double x) {
  const double truncated = static_cast<double>(static_cast<std::int64_t>(x));
  return truncated > x ? truncated - 1.0 : truncated;
}

// Voxel coordinate of p along each axis: floor(p / voxel_size), in double.
Eigen::Vector3d voxel_coordinates(const Eigen::Vector3f& p, double voxel_size) {
  return Eigen::Vector3d(fast_floor(p.x() / voxel_size), fast_floor(p.y() / voxel_size),
                         fast_floor(p.z() / voxel_size));
}

// Bounds of the finite positions. floor(p / v) is monotonic in p, so the voxel coordinate
// bounds are those of the position bounds: one cheap float pass, no division per point.
struct Bounds {
  Eigen::Vector3f min = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
  Eigen::Vector3f max = Eigen::Vector3f::Constant(-std::numeric_limits<float>::infinity());
  std::size_t non_finite = 0;
  void join(const Bounds& other) {
    min = min.cwiseMin(other.min);
    max = max.cwiseMax(other.max);
    non_finite += other.non_finite;
  }
};

Bounds position_bounds(const PointCloud& cloud) {
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, cloud.size(), 65536), Bounds{},
      [&](const auto& range, Bounds bounds) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          const Eigen::Vector3f& p = cloud.positions[i];
          if (!is_finite_point(p)) {
            ++bounds.non_finite;
            continue;
          }
          bounds.min = bounds.min.cwiseMin(p);
          bounds.max = bounds.max.cwiseMax(p);
        }
        return bounds;
      },
      [](Bounds a, const Bounds& b) {
        a.join(b);
        return a;
      });
}

// The linear key of every point, (x, y, z) lexicographic: ((ix * ny) + iy) * nz + iz with
// voxel coordinates relative to the minimum; non-finite points get `sentinel` (sorts last).
struct KeyGrid {
  Eigen::Vector3d origin;          // minimum voxel coordinate
  std::uint64_t ny = 0, nz = 0;    // voxels along y and z
  std::uint64_t sentinel = 0;      // total voxel count
  std::uint64_t key(const Eigen::Vector3f& p, double voxel_size) const {
    if (!is_finite_point(p)) return sentinel;
    const Eigen::Vector3d v = voxel_coordinates(p, voxel_size) - origin;
    return (static_cast<std::uint64_t>(v.x()) * ny + static_cast<std::uint64_t>(v.y())) * nz +
           static_cast<std::uint64_t>(v.z());
  }
};

// Sorted (key, point index) pairs, whichever way they were stored.
struct SortedPoints {
  std::unique_ptr<std::uint64_t[]> packed;                       // key << 32 | index
  std::vector<std::pair<std::uint64_t, std::uint32_t>> wide;     // when keys need > 32 bits
  std::uint64_t key(std::size_t i) const { return packed ? packed[i] >> 32 : wide[i].first; }
  std::uint32_t index(std::size_t i) const {
    return packed ? static_cast<std::uint32_t>(packed[i]) : wide[i].second;
  }
};

SortedPoints sort_by_voxel(const PointCloud& cloud, const KeyGrid& grid, double voxel_size) {
  const std::size_t n = cloud.size();
  const int key_bits = std::bit_width(grid.sentinel);
  SortedPoints sorted;
  if (key_bits <= 32) {
    // Stable radix sort on the key bits: points of a voxel stay in input order.
    sorted.packed = std::make_unique_for_overwrite<std::uint64_t[]>(n);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 16384), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        sorted.packed[i] = (grid.key(cloud.positions[i], voxel_size) << 32) | i;
      }
    });
    detail::parallel_radix_sort(sorted.packed.get(), n, 32, key_bits);
  } else {
    // Sparse, very large grids: comparison sort on (key, index), unique hence deterministic.
    sorted.wide.resize(n);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 16384), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        sorted.wide[i] = {grid.key(cloud.positions[i], voxel_size), static_cast<std::uint32_t>(i)};
      }
    });
    tbb::parallel_sort(sorted.wide.begin(), sorted.wide.end());
  }
  return sorted;
}

// Start of every run of equal keys among the first `valid` sorted points, plus `valid`.
std::vector<std::size_t> run_starts(const SortedPoints& sorted, std::size_t valid) {
  constexpr std::size_t kChunk = 65536;
  const std::size_t chunks = (valid + kChunk - 1) / kChunk;
  std::vector<std::size_t> chunk_offset(chunks + 1, 0);
  const auto is_start = [&](std::size_t i) { return i == 0 || sorted.key(i) != sorted.key(i - 1); };
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    std::size_t count = 0;
    for (std::size_t i = c * kChunk; i < std::min(valid, (c + 1) * kChunk); ++i) count += is_start(i);
    chunk_offset[c + 1] = count;
  });
  for (std::size_t c = 0; c < chunks; ++c) chunk_offset[c + 1] += chunk_offset[c];
  std::vector<std::size_t> starts(chunk_offset[chunks] + 1);
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    std::size_t out = chunk_offset[c];
    for (std::size_t i = c * kChunk; i < std::min(valid, (c + 1) * kChunk); ++i) {
      if (is_start(i)) starts[out++] = i;
    }
  });
  starts.back() = valid;
  return starts;
}

}  // namespace

VoxelGridResult voxel_down_sample(const PointCloud& cloud, float voxel_size) {
  if (!(voxel_size > 0.f) || !std::isfinite(voxel_size)) {
    throw InputError(fmt::format("voxel down-sampling: the voxel size must be a positive "
                                 "number of metres, got {}", voxel_size));
  }
  cloud.check_consistent();
  if (cloud.size() > std::numeric_limits<std::uint32_t>::max()) {
    throw InputError("voxel down-sampling: more than 2^32 points");
  }
  const double voxel = voxel_size;
  VoxelGridResult result;
  result.report.input_points = cloud.size();

  const Bounds bounds = position_bounds(cloud);
  result.report.non_finite = bounds.non_finite;
  const std::size_t valid = cloud.size() - bounds.non_finite;
  if (valid == 0) return result;

  // Checked before fast_floor's range matters: huge coordinates give huge extents.
  const Eigen::Vector3d min_voxel(std::floor(bounds.min.x() / voxel),
                                  std::floor(bounds.min.y() / voxel),
                                  std::floor(bounds.min.z() / voxel));
  const Eigen::Vector3d max_voxel(std::floor(bounds.max.x() / voxel),
                                  std::floor(bounds.max.y() / voxel),
                                  std::floor(bounds.max.z() / voxel));
  const Eigen::Vector3d extent = max_voxel - min_voxel + Eigen::Vector3d::Ones();
  if ((extent.array() > kMaxVoxelsPerAxis).any() ||
      (min_voxel.array().abs() > 0x1p61).any() || (max_voxel.array().abs() > 0x1p61).any()) {
    throw InputError(fmt::format(
        "voxel down-sampling: a voxel size of {} m gives {:.0f} x {:.0f} x {:.0f} voxels; at most "
        "{:.0f} per axis are supported (use a larger voxel or crop the cloud)",
        voxel_size, extent.x(), extent.y(), extent.z(), kMaxVoxelsPerAxis));
  }
  KeyGrid grid;
  grid.origin = min_voxel;
  grid.ny = static_cast<std::uint64_t>(extent.y());
  grid.nz = static_cast<std::uint64_t>(extent.z());
  grid.sentinel = static_cast<std::uint64_t>(extent.x()) * grid.ny * grid.nz;

  const SortedPoints sorted = sort_by_voxel(cloud, grid, voxel);
  const std::vector<std::size_t> starts = run_starts(sorted, valid);
  const std::size_t voxels = starts.size() - 1;

  PointCloud& out = result.cloud;
  out.positions.resize(voxels);
  if (cloud.has_normals()) out.normals.resize(voxels);
  if (cloud.has_colors()) out.colors.resize(voxels);
  for (const ScalarField& field : cloud.scalars) {
    out.scalars.push_back(ScalarField{field.name, std::vector<float>(voxels)});
  }
  result.points_per_voxel.resize(voxels);

  // Per voxel: sums in double, in input order (the sort is stable), then means.
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, voxels, 1024), [&](const auto& range) {
    for (std::size_t v = range.begin(); v != range.end(); ++v) {
      const std::size_t begin = starts[v], end = starts[v + 1];
      const double count = static_cast<double>(end - begin);
      result.points_per_voxel[v] = static_cast<std::uint32_t>(end - begin);

      Eigen::Vector3d position_sum = Eigen::Vector3d::Zero();
      for (std::size_t i = begin; i < end; ++i) {
        position_sum += cloud.positions[sorted.index(i)].cast<double>();
      }
      out.positions[v] = (position_sum / count).cast<float>();

      if (cloud.has_normals()) {
        Eigen::Vector3d normal_sum = Eigen::Vector3d::Zero();
        for (std::size_t i = begin; i < end; ++i) {
          normal_sum += cloud.normals[sorted.index(i)].cast<double>();
        }
        const double norm = normal_sum.norm();
        out.normals[v] = norm > 0.0 ? (normal_sum / norm).cast<float>()
                                    : cloud.normals[sorted.index(begin)];
      }
      if (cloud.has_colors()) {
        std::uint64_t r = 0, g = 0, b = 0;
        for (std::size_t i = begin; i < end; ++i) {
          const Rgb8& c = cloud.colors[sorted.index(i)];
          r += c.r;
          g += c.g;
          b += c.b;
        }
        const auto mean = [count](std::uint64_t sum) {
          return static_cast<std::uint8_t>(std::lround(static_cast<double>(sum) / count));
        };
        out.colors[v] = Rgb8{mean(r), mean(g), mean(b)};
      }
      for (std::size_t f = 0; f < cloud.scalars.size(); ++f) {
        double sum = 0.0;
        for (std::size_t i = begin; i < end; ++i) sum += cloud.scalars[f].values[sorted.index(i)];
        out.scalars[f].values[v] = static_cast<float>(sum / count);
      }
    }
  });
  result.report.output_points = voxels;
  return result;
}

}  // namespace locard
