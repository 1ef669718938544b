#include <locard/preprocess/voxel_grid.hpp>

#include <locard/core/error.hpp>

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

// floor(x) for |x| < 2^62 without a libm call (x86-64's baseline has no SSE4.1 round).
double fast_floor(double x) {
  const double truncated = static_cast<double>(static_cast<std::int64_t>(x));
  return truncated > x ? truncated - 1.0 : truncated;
}

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
  Eigen::Vector3d origin;        // minimum voxel coordinate
  std::uint64_t ny = 0, nz = 0;  // voxels along y and z
  std::uint64_t sentinel = 0;
  std::uint64_t key(const Eigen::Vector3f& p) const {
    if (!is_finite_point(p)) return sentinel;
    const auto axis = [&](float x, double o) {
      return static_cast<std::uint64_t>(fast_floor(x * inverse_voxel_size) - o);
    };
    return (axis(p.x(), origin.x()) * ny + axis(p.y(), origin.y())) * nz +
           axis(p.z(), origin.z());
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

// Sums of one key range, one entry per voxel (in order of first appearance).
template <typename Key>
struct RangeSums {
  std::vector<Key> key;
  std::vector<VoxelSum> sum;
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
    std::vector<Slot> old = std::move(slots_);
    log2_ = old.empty() ? 12 : log2_ + 1;
    slots_.assign(std::size_t{1} << log2_, Slot{kEmpty, 0});
    for (const Slot& entry : old) {
      if (entry.key == kEmpty) continue;
      std::size_t slot = hash(entry.key);
      while (slots_[slot].key != kEmpty) slot = (slot + 1) & (slots_.size() - 1);
      slots_[slot] = entry;
    }
  }

  std::vector<Slot> slots_;
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
  constexpr std::size_t kAhead = 16;  // table misses dominate large grids: prefetch the slot
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (i + kAhead < cloud.size() && table.large()) {
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
        if (gathered) {
          if (cloud.has_normals()) sums.normal.emplace_back(Eigen::Vector3d::Zero());
          sums.scalar.resize(sums.scalar.size() + fields, 0.0);
          sums.first.push_back(static_cast<std::uint32_t>(i));
        }
      }
    }
    VoxelSum& sum = sums.sum[id];
    sum.position += cloud.positions[i].cast<double>();
    if (with_colors) {
      sum.r += cloud.colors[i].r;
      sum.g += cloud.colors[i].g;
      sum.b += cloud.colors[i].b;
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
std::vector<std::uint32_t> key_order(const std::vector<Key>& keys) {
  std::vector<std::uint32_t> order(keys.size());
  if constexpr (sizeof(Key) <= 4) {
    // LSD radix sort on the key half, 11 bits a pass (keys are unique, so order is total).
    // Keys are taken relative to the smallest: a narrow key range sorts in fewer passes.
    std::vector<std::uint64_t> packed(keys.size()), scratch(keys.size());
    Key min_key = std::numeric_limits<Key>::max(), max_key = 0;
    for (const Key key : keys) {
      min_key = std::min(min_key, key);
      max_key = std::max(max_key, key);
    }
    for (std::size_t v = 0; v < keys.size(); ++v)
      packed[v] = (std::uint64_t{static_cast<Key>(keys[v] - min_key)} << 32) | v;
    const int bits = keys.empty() ? 0 : std::bit_width(static_cast<std::uint32_t>(max_key - min_key));
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
  const auto keys = std::make_unique_for_overwrite<Key[]>(n);
  const auto histogram = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, 65536), std::vector<std::size_t>(bins, 0),
      [&](const auto& range, std::vector<std::size_t> counts) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          keys[i] = static_cast<Key>(grid.key(cloud.positions[i]));
          if (keys[i] != grid.sentinel) ++counts[keys[i] >> shift];
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

// ---- large clouds: buckets that fit in the cache -------------------------------------------
// With millions of points and voxels, one hash table per key range is far larger than the
// cache and nearly every lookup misses. Large clouds are therefore first scattered (a stable
// counting sort, so each bucket keeps the input order) into a few hundred buckets of
// consecutive keys with about kBucketPoints points each; each bucket is then accumulated with a
// table that stays in L1/L2. Same sums, same order, same bits as the path above.
constexpr std::size_t kBucketedMinPoints = std::size_t{1} << 19;
constexpr std::size_t kBucketPoints = std::size_t{1} << 14;
constexpr std::size_t kScatterChunk = std::size_t{1} << 16;  // at least; never thread-dependent
constexpr int kFineBits = 14;

// The points of one bucket after the scatter, in input order.
template <typename Key>
struct Scattered {
  std::unique_ptr<Key[]> key;
  std::unique_ptr<Eigen::Vector3f[]> position;
  std::unique_ptr<Rgb8[]> color;           // when the cloud has colours
  std::unique_ptr<std::uint32_t[]> index;  // input index, when normals or scalars are gathered
};

template <typename Key>
RangeSums<Key> accumulate_bucket(const PointCloud& cloud, const Scattered<Key>& s,
                                 std::size_t begin, std::size_t end) {
  RangeSums<Key> sums;
  VoxelTable<Key> table;
  const std::size_t fields = cloud.scalars.size();
  const bool with_colors = cloud.has_colors();
  const bool gathered = cloud.has_normals() || fields > 0;
  sums.key.reserve((end - begin) / 4 + 16);
  sums.sum.reserve((end - begin) / 4 + 16);
  Key last_key = VoxelTable<Key>::kEmpty;
  std::uint32_t id = 0;
  for (std::size_t k = begin; k != end; ++k) {
    const Key key = s.key[k];
    if (key != last_key) {
      const auto next = static_cast<std::uint32_t>(sums.key.size());
      id = table.find_or_insert(key, next);
      last_key = key;
      if (id == next) {
        sums.key.push_back(key);
        sums.sum.push_back(VoxelSum{Eigen::Vector3d::Zero(), 0, 0, 0, 0});
        if (gathered) {
          if (cloud.has_normals()) sums.normal.emplace_back(Eigen::Vector3d::Zero());
          sums.scalar.resize(sums.scalar.size() + fields, 0.0);
          sums.first.push_back(s.index[k]);
        }
      }
    }
    VoxelSum& sum = sums.sum[id];
    sum.position += s.position[k].template cast<double>();
    if (with_colors) {
      sum.r += s.color[k].r;
      sum.g += s.color[k].g;
      sum.b += s.color[k].b;
    }
    ++sum.count;
    if (gathered) {
      const std::uint32_t i = s.index[k];
      if (cloud.has_normals()) sums.normal[id] += cloud.normals[i].cast<double>();
      for (std::size_t f = 0; f < fields; ++f) sums.scalar[id * fields + f] += cloud.scalars[f].values[i];
    }
  }
  return sums;
}

template <typename Key>
void voxel_grid_bucketed(const PointCloud& cloud, const KeyGrid& grid, int key_bits,
                         VoxelGridResult& result) {
  const std::size_t n = cloud.size();
  // At most 256 chunks, so the chunk x bucket offset table stays small on huge clouds.
  const std::size_t chunk_size = std::max(kScatterChunk, (n + 255) / 256);
  const std::size_t chunks = (n + chunk_size - 1) / chunk_size;
  const auto chunk_range = [&](std::size_t c) {
    return std::pair{c * chunk_size, std::min(n, (c + 1) * chunk_size)};
  };

  // Keys and a fine histogram of their top bits.
  const int shift = std::max(0, key_bits - kFineBits);
  const std::size_t fine_bins = (std::size_t{1} << (key_bits - shift)) + 1;
  const auto keys = std::make_unique_for_overwrite<Key[]>(n);
  const auto fine = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, 65536), std::vector<std::uint32_t>(fine_bins, 0),
      [&](const auto& range, std::vector<std::uint32_t> counts) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          const Key key = static_cast<Key>(grid.key(cloud.positions[i]));
          keys[i] = key;
          ++counts[key == grid.sentinel ? fine_bins - 1 : key >> shift];
        }
        return counts;
      },
      [](std::vector<std::uint32_t> a, const std::vector<std::uint32_t>& b) {
        for (std::size_t k = 0; k < a.size(); ++k) a[k] += b[k];
        return a;
      });

  // Consecutive fine bins merged into buckets of about kBucketPoints points; the non-finite
  // points (the last fine bin) go to a bucket of their own that is never accumulated.
  std::vector<std::uint16_t> bucket_of(fine_bins);
  std::vector<std::size_t> bucket_points;
  {
    std::size_t running = 0;
    for (std::size_t b = 0; b + 1 < fine_bins; ++b) {
      if (bucket_points.empty() ||
          (running > 0 && running + fine[b] > kBucketPoints && bucket_points.size() < 65534)) {
        bucket_points.push_back(0);
        running = 0;
      }
      bucket_of[b] = static_cast<std::uint16_t>(bucket_points.size() - 1);
      bucket_points.back() += fine[b];
      running += fine[b];
    }
    bucket_of[fine_bins - 1] = static_cast<std::uint16_t>(bucket_points.size());
    bucket_points.push_back(fine[fine_bins - 1]);
  }
  const std::size_t buckets = bucket_points.size();
  const auto bucket = [&](Key key) {
    return bucket_of[key == grid.sentinel ? fine_bins - 1 : key >> shift];
  };

  // Stable scatter: chunk c's points of bucket b go after those of chunks 0..c-1.
  std::vector<std::uint32_t> offsets(chunks * buckets, 0);
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    std::uint32_t* count = offsets.data() + c * buckets;
    const auto [begin, end] = chunk_range(c);
    for (std::size_t i = begin; i != end; ++i) ++count[bucket(keys[i])];
  });
  std::vector<std::size_t> bucket_begin(buckets + 1, 0);
  {
    std::size_t running = 0;
    for (std::size_t b = 0; b < buckets; ++b) {
      bucket_begin[b] = running;
      for (std::size_t c = 0; c < chunks; ++c) {
        const std::uint32_t count = offsets[c * buckets + b];
        offsets[c * buckets + b] = static_cast<std::uint32_t>(running);
        running += count;
      }
    }
    bucket_begin[buckets] = running;
  }
  const bool gathered = cloud.has_normals() || !cloud.scalars.empty();
  Scattered<Key> s;
  s.key = std::make_unique_for_overwrite<Key[]>(n);
  s.position = std::make_unique_for_overwrite<Eigen::Vector3f[]>(n);
  if (cloud.has_colors()) s.color = std::make_unique_for_overwrite<Rgb8[]>(n);
  if (gathered) s.index = std::make_unique_for_overwrite<std::uint32_t[]>(n);
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    std::uint32_t* next = offsets.data() + c * buckets;
    const auto [begin, end] = chunk_range(c);
    for (std::size_t i = begin; i != end; ++i) {
      const Key key = keys[i];
      const std::uint32_t k = next[bucket(key)]++;
      s.key[k] = key;
      s.position[k] = cloud.positions[i];
      if (s.color) s.color[k] = cloud.colors[i];
      if (gathered) s.index[k] = static_cast<std::uint32_t>(i);
    }
  });

  // Accumulate every bucket but the non-finite one, then write them in key order.
  const std::size_t finite_buckets = buckets - 1;
  std::vector<RangeSums<Key>> sums(finite_buckets);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, finite_buckets, 1), [&](const auto& r) {
    for (std::size_t b = r.begin(); b != r.end(); ++b)
      sums[b] = accumulate_bucket<Key>(cloud, s, bucket_begin[b], bucket_begin[b + 1]);
  });
  std::vector<std::size_t> base(finite_buckets + 1, 0);
  for (std::size_t b = 0; b < finite_buckets; ++b) base[b + 1] = base[b] + sums[b].key.size();

  PointCloud& out = result.cloud;
  out.positions.resize(base.back());
  if (cloud.has_normals()) out.normals.resize(base.back());
  if (cloud.has_colors()) out.colors.resize(base.back());
  for (const ScalarField& field : cloud.scalars) {
    out.scalars.push_back(ScalarField{field.name, std::vector<float>(base.back())});
  }
  result.points_per_voxel.resize(base.back());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, finite_buckets, 1), [&](const auto& r) {
    for (std::size_t b = r.begin(); b != r.end(); ++b) write_range(cloud, sums[b], base[b], result);
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

  // Checked before fast_floor's range matters: huge coordinates give huge extents.
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
  grid.origin = min_voxel;
  grid.ny = static_cast<std::uint64_t>(extent.y());
  grid.nz = static_cast<std::uint64_t>(extent.z());
  grid.sentinel = static_cast<std::uint64_t>(extent.x()) * grid.ny * grid.nz;

  // Keys must leave room for the table's empty marker (the all-ones value).
  const int key_bits = std::bit_width(grid.sentinel);
  const bool bucketed = cloud.size() >= kBucketedMinPoints;
  if (grid.sentinel < std::numeric_limits<std::uint32_t>::max()) {
    if (bucketed) voxel_grid_bucketed<std::uint32_t>(cloud, grid, key_bits, result);
    else voxel_grid_hashed<std::uint32_t>(cloud, grid, key_bits, result);
  } else {
    if (bucketed) voxel_grid_bucketed<std::uint64_t>(cloud, grid, key_bits, result);
    else voxel_grid_hashed<std::uint64_t>(cloud, grid, key_bits, result);
  }
  result.report.output_points = result.cloud.size();
  return result;
}

}  // namespace locard
