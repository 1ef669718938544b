#include <locard/preprocess/voxel_grid.hpp>

#include <locard/core/error.hpp>

#include "core/floor_to_int.hpp"
#include "core/huge_page_allocator.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <memory>

namespace locard {

namespace {

constexpr double kMaxVoxelsPerAxis = double(1 << 21);

// ---- voxel keys ------------------------------------------------------------------------------

// Bounds of the finite positions. floor(p * (1 / v)) is monotonic in p, so the voxel coordinate
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

// The linear key of a point, (x, y, z) lexicographic: ((ix * ny) + iy) * nz + iz, with the
// voxel coordinates floor(p * (1 / voxel_size)) (in double) taken relative to the minimum.
// Non-finite points get `sentinel` = the voxel count, which sorts after every voxel.
struct KeyGrid {
  double inverse_voxel_size = 0.0;
  std::int64_t ox = 0, oy = 0, oz = 0;  // minimum voxel coordinate
  std::int64_t ny = 0, nz = 0;          // voxels along y and z
  std::uint64_t sentinel = 0;
  std::uint64_t key(const Eigen::Vector3f& p) const {
    if (!is_finite_point(p)) return sentinel;
    const auto axis = [&](float x) {
      return detail::floor_to_int<std::int64_t>(x * inverse_voxel_size);
    };
    const std::int64_t ix = axis(p.x()) - ox, iy = axis(p.y()) - oy, iz = axis(p.z()) - oz;
    return static_cast<std::uint64_t>((ix * ny + iy) * nz + iz);
  }
};

// ---- accumulation --------------------------------------------------------------------------
// The key space is split into a few ranges of about equal point counts; each range is one task
// that scans the points in input order and accumulates the points whose key falls in its range
// into an open-addressing hash table. Every voxel therefore belongs to exactly one task and is
// summed in input order, whatever the thread count; the voxels of a range are then sorted by
// key, and the ranges follow each other in key order.

// Sums of one voxel: position, colour and count together (40 bytes, one or two cache lines).
struct VoxelSum {
  Eigen::Vector3d position;
  std::uint32_t r, g, b;
  std::uint32_t count;
};

template <typename T>
using LargeVector = std::vector<T, detail::HugePageAllocator<T>>;

// Sums of one key range, one entry per voxel (in order of first appearance).
template <typename Key>
struct RangeSums {
  LargeVector<Key> key;
  LargeVector<VoxelSum> sum;
  std::vector<Eigen::Vector3d> normal;  // when the cloud has normals
  std::vector<double> scalar;           // scalar-field sums, field-minor
  std::vector<std::uint32_t> first;     // first point (normal fallback)
};

// Open addressing with linear probing: key -> voxel id in RangeSums; grows at half load.
template <typename Key>
class VoxelTable {
 public:
  static constexpr Key kEmpty = std::numeric_limits<Key>::max();  // never a real key

  std::uint32_t find_or_insert(Key key, std::uint32_t next_id) {
    if (2 * (used_ + 1) > slots_.size()) grow();
    std::size_t slot = hash(key);
    while (slots_[slot].key != kEmpty) {
      if (slots_[slot].key == key) return slots_[slot].id;
      slot = (slot + 1) & (slots_.size() - 1);
    }
    slots_[slot] = Slot{key, next_id};
    ++used_;
    return next_id;
  }

  // Tables beyond the L2 cache miss on most lookups; their slots are worth prefetching.
  bool large() const { return slots_.size() >= (std::size_t{1} << 16); }
  void prefetch(Key key) const { __builtin_prefetch(&slots_[hash(key)]); }

 private:
  std::size_t hash(Key key) const {  // Fibonacci hashing
    return static_cast<std::size_t>((static_cast<std::uint64_t>(key) * 0x9E3779B97F4A7C15ull) >>
                                    (64 - log2_));
  }
  struct Slot {
    Key key;
    std::uint32_t id;
  };
  void grow() {
    LargeVector<Slot> old = std::move(slots_);
    log2_ = old.empty() ? 12 : log2_ + 1;
    slots_.assign(std::size_t{1} << log2_, Slot{kEmpty, 0});
    for (const Slot& entry : old) {
      if (entry.key == kEmpty) continue;
      std::size_t slot = hash(entry.key);
      while (slots_[slot].key != kEmpty) slot = (slot + 1) & (slots_.size() - 1);
      slots_[slot] = entry;
    }
  }

  LargeVector<Slot> slots_;
  int log2_ = 0;
  std::size_t used_ = 0;
};

template <typename Key>
RangeSums<Key> accumulate_range(const PointCloud& cloud, const Key* keys, Key low, Key high) {
  RangeSums<Key> sums;
  VoxelTable<Key> table;
  const std::size_t fields = cloud.scalars.size();
  const bool with_colors = cloud.has_colors();
  const bool gathered = cloud.has_normals() || fields > 0;
  Key last_key = VoxelTable<Key>::kEmpty;
  std::uint32_t id = 0;
  // Plain pointers, not the vectors behind `cloud`: the sum stores would otherwise make the
  // compiler reload them per point. `sum_data` moves only when a voxel is appended.
  const Eigen::Vector3f* const positions = cloud.positions.data();
  const Rgb8* const colors = cloud.colors.data();
  VoxelSum* sum_data = sums.sum.data();
  const std::size_t n = cloud.size();
  constexpr std::size_t kAhead = 16;  // table misses dominate large grids: prefetch the slot
  for (std::size_t i = 0; i < n; ++i) {
    if (i + kAhead < n && table.large()) {
      const Key ahead = keys[i + kAhead];
      if (ahead >= low && ahead < high) table.prefetch(ahead);
    }
    const Key key = keys[i];
    if (key < low || key >= high) continue;
    if (key != last_key) {  // consecutive points often share a voxel: skip the lookup
      const auto next = static_cast<std::uint32_t>(sums.key.size());
      id = table.find_or_insert(key, next);
      last_key = key;
      if (id == next) {
        sums.key.push_back(key);
        sums.sum.push_back(VoxelSum{Eigen::Vector3d::Zero(), 0, 0, 0, 0});
        sum_data = sums.sum.data();
        if (gathered) {
          if (cloud.has_normals()) sums.normal.emplace_back(Eigen::Vector3d::Zero());
          sums.scalar.resize(sums.scalar.size() + fields, 0.0);
          sums.first.push_back(static_cast<std::uint32_t>(i));
        }
      }
    }
    VoxelSum& sum = sum_data[id];
    sum.position += positions[i].cast<double>();
    if (with_colors) {
      sum.r += colors[i].r;
      sum.g += colors[i].g;
      sum.b += colors[i].b;
    }
    ++sum.count;
    if (gathered) {
      if (cloud.has_normals()) sums.normal[id] += cloud.normals[i].cast<double>();
      for (std::size_t f = 0; f < fields; ++f) {
        sums.scalar[id * fields + f] += cloud.scalars[f].values[i];
      }
    }
  }
  return sums;
}

std::uint8_t mean_channel(std::uint64_t sum, std::uint32_t count) {
  return static_cast<std::uint8_t>(std::lround(static_cast<double>(sum) / count));
}

// Voxel ids in increasing key order. 32-bit keys are sorted packed with their id in one 64-bit
// integer (direct comparisons, no indirection); wider keys as (key, id) pairs.
template <typename Key>
std::vector<std::uint32_t> key_order(const LargeVector<Key>& keys) {
  std::vector<std::uint32_t> order(keys.size());
  if constexpr (sizeof(Key) <= 4) {
    // LSD radix sort on the key half, 11 bits a pass (keys are unique, so order is total).
    std::vector<std::uint64_t> packed(keys.size()), scratch(keys.size());
    Key max_key = 0;
    for (std::size_t v = 0; v < keys.size(); ++v) {
      packed[v] = (std::uint64_t{keys[v]} << 32) | v;
      max_key = std::max(max_key, keys[v]);
    }
    const int bits = std::bit_width(static_cast<std::uint32_t>(max_key));
    for (int shift = 0; shift < bits; shift += 11) {
      std::array<std::size_t, 2049> count{};
      for (std::uint64_t item : packed) ++count[((item >> (32 + shift)) & 2047) + 1];
      for (std::size_t d = 0; d < 2048; ++d) count[d + 1] += count[d];
      for (std::uint64_t item : packed) scratch[count[(item >> (32 + shift)) & 2047]++] = item;
      packed.swap(scratch);
    }
    for (std::size_t k = 0; k < packed.size(); ++k) order[k] = static_cast<std::uint32_t>(packed[k]);
  } else {
    std::vector<std::pair<Key, std::uint32_t>> pairs(keys.size());
    for (std::size_t v = 0; v < keys.size(); ++v) pairs[v] = {keys[v], static_cast<std::uint32_t>(v)};
    std::sort(pairs.begin(), pairs.end());
    for (std::size_t k = 0; k < pairs.size(); ++k) order[k] = pairs[k].second;
  }
  return order;
}

// Writes the means of one range, in key order, from output index `base` on.
template <typename Key>
void write_range(const PointCloud& cloud, const RangeSums<Key>& sums, std::size_t base,
                 VoxelGridResult& result) {
  const std::vector<std::uint32_t> order = key_order(sums.key);
  PointCloud& out = result.cloud;
  const std::size_t fields = cloud.scalars.size();
  constexpr std::size_t kAhead = 8;  // key order is a random walk through the sums: prefetch
  for (std::size_t k = 0; k < order.size(); ++k) {
    if (k + kAhead < order.size()) __builtin_prefetch(&sums.sum[order[k + kAhead]]);
    const std::uint32_t id = order[k];
    const std::size_t v = base + k;
    const VoxelSum& sum = sums.sum[id];
    const std::uint32_t count = sum.count;
    result.points_per_voxel[v] = count;
    out.positions[v] = (sum.position / count).cast<float>();
    if (cloud.has_colors()) {
      out.colors[v] = Rgb8{mean_channel(sum.r, count), mean_channel(sum.g, count),
                           mean_channel(sum.b, count)};
    }
    if (cloud.has_normals()) {
      const Eigen::Vector3d& normal = sums.normal[id];
      const double norm = normal.norm();
      out.normals[v] = norm > 0.0 ? Eigen::Vector3f((normal / norm).cast<float>())
                                  : cloud.normals[sums.first[id]];
    }
    for (std::size_t f = 0; f < fields; ++f) {
      out.scalars[f].values[v] = static_cast<float>(sums.scalar[id * fields + f] / count);
    }
  }
}

template <typename Key>
void voxel_grid_hashed(const PointCloud& cloud, const KeyGrid& grid, int key_bits,
                       VoxelGridResult& result) {
  const std::size_t n = cloud.size();
  // Keys, and a histogram of their top bits to split the key space evenly.
  constexpr int kHistogramBits = 12;
  const int shift = std::max(0, key_bits - kHistogramBits);
  const std::size_t bins = (std::size_t{1} << (key_bits - shift)) + 1;  // + sentinel overflow
  const detail::LargeArray<Key> keys(n);
  const auto histogram = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, 65536), std::vector<std::size_t>(bins, 0),
      // The grid by value and plain pointers: the key stores would otherwise force reloads.
      [&, grid](const auto& range, std::vector<std::size_t> counts) {
        Key* const out = keys.get();
        const Eigen::Vector3f* const positions = cloud.positions.data();
        const auto sentinel = static_cast<Key>(grid.sentinel);
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          const auto key = static_cast<Key>(grid.key(positions[i]));
          out[i] = key;
          if (key != sentinel) ++counts[key >> shift];
        }
        return counts;
      },
      [](std::vector<std::size_t> a, const std::vector<std::size_t>& b) {
        for (std::size_t k = 0; k < a.size(); ++k) a[k] += b[k];
        return a;
      });

  // Ranges [bounds[r], bounds[r + 1]) of about equal point counts; the sentinel is excluded.
  const std::size_t ranges =
      static_cast<std::size_t>(std::max(1, tbb::this_task_arena::max_concurrency()));
  const std::size_t valid = n - result.report.non_finite;
  std::vector<Key> bounds{0};
  std::size_t running = 0;
  for (std::size_t b = 0; b + 1 < bins && bounds.size() < ranges; ++b) {
    running += histogram[b];
    if (running * ranges >= bounds.size() * valid && running < valid) {
      bounds.push_back(static_cast<Key>((b + 1) << shift));
    }
  }
  bounds.push_back(static_cast<Key>(grid.sentinel));

  std::vector<RangeSums<Key>> sums(bounds.size() - 1);
  tbb::parallel_for(std::size_t{0}, sums.size(), [&](std::size_t r) {
    sums[r] = accumulate_range<Key>(cloud, keys.get(), bounds[r], bounds[r + 1]);
  });
  std::vector<std::size_t> base(sums.size() + 1, 0);
  for (std::size_t r = 0; r < sums.size(); ++r) base[r + 1] = base[r] + sums[r].key.size();

  PointCloud& out = result.cloud;
  out.positions.resize(base.back());
  if (cloud.has_normals()) out.normals.resize(base.back());
  if (cloud.has_colors()) out.colors.resize(base.back());
  for (const ScalarField& field : cloud.scalars) {
    out.scalars.push_back(ScalarField{field.name, std::vector<float>(base.back())});
  }
  result.points_per_voxel.resize(base.back());
  tbb::parallel_for(std::size_t{0}, sums.size(), [&](std::size_t r) {
    write_range(cloud, sums[r], base[r], result);
  });
}

}  // namespace

VoxelGridResult voxel_down_sample(const PointCloud& cloud, float voxel_size) {
  if (!(voxel_size > 0.f) || !std::isfinite(voxel_size)) {
    throw InputError(fmt::format("voxel down-sampling: the voxel size must be a positive "
                                 "number of metres, got {}", voxel_size));
  }
  cloud.check_consistent();
  if (cloud.size() >= std::numeric_limits<std::uint32_t>::max()) {
    throw InputError("voxel down-sampling: 2^32 points or more");
  }
  const double inverse = 1.0 / static_cast<double>(voxel_size);
  VoxelGridResult result;
  result.report.input_points = cloud.size();

  const Bounds bounds = position_bounds(cloud);
  result.report.non_finite = bounds.non_finite;
  if (cloud.size() == bounds.non_finite) return result;

  // Checked before the key's floor_to_int range matters: huge coordinates give huge extents.
  const Eigen::Vector3d min_voxel(std::floor(bounds.min.x() * inverse),
                                  std::floor(bounds.min.y() * inverse),
                                  std::floor(bounds.min.z() * inverse));
  const Eigen::Vector3d max_voxel(std::floor(bounds.max.x() * inverse),
                                  std::floor(bounds.max.y() * inverse),
                                  std::floor(bounds.max.z() * inverse));
  const Eigen::Vector3d extent = max_voxel - min_voxel + Eigen::Vector3d::Ones();
  if ((extent.array() > kMaxVoxelsPerAxis).any() ||
      (min_voxel.array().abs() > 0x1p61).any() || (max_voxel.array().abs() > 0x1p61).any()) {
    throw InputError(fmt::format(
        "voxel down-sampling: a voxel size of {} m gives {:.0f} x {:.0f} x {:.0f} voxels; at most "
        "{:.0f} per axis are supported (use a larger voxel or crop the cloud)",
        voxel_size, extent.x(), extent.y(), extent.z(), kMaxVoxelsPerAxis));
  }
  KeyGrid grid;
  grid.inverse_voxel_size = inverse;
  grid.ox = static_cast<std::int64_t>(min_voxel.x());
  grid.oy = static_cast<std::int64_t>(min_voxel.y());
  grid.oz = static_cast<std::int64_t>(min_voxel.z());
  grid.ny = static_cast<std::int64_t>(extent.y());
  grid.nz = static_cast<std::int64_t>(extent.z());
  grid.sentinel = static_cast<std::uint64_t>(extent.x() * extent.y() * extent.z());

  // Keys must leave room for the table's empty marker (the all-ones value).
  const int key_bits = std::bit_width(grid.sentinel);
  // (A stable scatter into cache-sized buckets before accumulating was tried: on 8 M points it
  // lost to this path at 1 cm and 5 cm, the page faults of its temporaries costing more than
  // the table misses it saved.)
  if (grid.sentinel < std::numeric_limits<std::uint32_t>::max()) {
    voxel_grid_hashed<std::uint32_t>(cloud, grid, key_bits, result);
  } else {
    voxel_grid_hashed<std::uint64_t>(cloud, grid, key_bits, result);
  }
  result.report.output_points = result.cloud.size();
  return result;
}

}  // namespace locard
