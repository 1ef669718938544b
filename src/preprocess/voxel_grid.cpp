#include <locard/preprocess/voxel_grid.hpp>

#include <locard/core/error.hpp>

#include "core/distinct_counter.hpp"
#include "core/huge_page_allocator.hpp"
#include "preprocess/voxel_keys.hpp"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <utility>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

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
        const Eigen::Vector3f* const positions = cloud.positions.data();
#if defined(__SSE2__)
        // A point in one register: the three tests and the six comparisons at once.
        const __m128 zero = _mm_setzero_ps();
        __m128 low = _mm_setr_ps(bounds.min.x(), bounds.min.y(), bounds.min.z(), 0.f);
        __m128 high = _mm_setr_ps(bounds.max.x(), bounds.max.y(), bounds.max.z(), 0.f);
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          const Eigen::Vector3f& p = positions[i];
          const __m128 v = _mm_setr_ps(p.x(), p.y(), p.z(), 0.f);
          // v * 0 is 0 in every lane unless a coordinate is infinite or NaN.
          if (_mm_movemask_ps(_mm_cmpeq_ps(_mm_mul_ps(v, zero), zero)) != 0xF) {
            ++bounds.non_finite;
            continue;
          }
          low = _mm_min_ps(low, v);
          high = _mm_max_ps(high, v);
        }
        alignas(16) float l[4], h[4];
        _mm_store_ps(l, low);
        _mm_store_ps(h, high);
        bounds.min = Eigen::Vector3f(l[0], l[1], l[2]);
        bounds.max = Eigen::Vector3f(h[0], h[1], h[2]);
#else
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          const Eigen::Vector3f& p = positions[i];
          if (!is_finite_point(p)) {
            ++bounds.non_finite;
            continue;
          }
          bounds.min = bounds.min.cwiseMin(p);
          bounds.max = bounds.max.cwiseMax(p);
        }
#endif
        return bounds;
      },
      [](Bounds a, const Bounds& b) {
        a.join(b);
        return a;
      });
}

using detail::VoxelKeyGrid;  // keys and the batch kernel: voxel_keys.hpp

// ---- accumulation --------------------------------------------------------------------------
// The key space is split into a few ranges of about equal point counts; each range is one task
// that scans the points in input order and accumulates the points whose key falls in its range
// into an open-addressing hash table. Every voxel therefore belongs to exactly one task and is
// summed in input order, whatever the thread count; the voxels of a range are then sorted by
// key, and the ranges follow each other in key order.

// One voxel: its key and sums together in one hash-table slot, so that a point costs one
// cache miss (the slot) rather than two (a key -> id table, then the sums). count == 0 marks an
// empty slot, so zeroed memory is an empty table.
template <typename Key>
struct VoxelSlot {
  Key key;
  std::uint32_t count;
  std::uint32_t r, g, b;
  std::uint32_t id;  // index into the side arrays (normals, scalar fields, first point)
  Eigen::Vector3d position;
};
static_assert(sizeof(VoxelSlot<std::uint32_t>) == 48);

// Open addressing with linear probing; grows at half load (3/4 was tried: the longer probe
// chains cost more than the smaller table saved).
template <typename Key>
class VoxelTable {
 public:
  using Slot = VoxelSlot<Key>;
  static constexpr int kMinLog2 = 12;

  VoxelTable() = default;  // empty; allocates on the first insertion
  explicit VoxelTable(int log2) { allocate(log2); }
  // The size of a table that holds `voxels` without growing.
  static int log2_for(double voxels) {
    const auto slots = static_cast<std::uint64_t>(2.0 * voxels);
    return std::max(kMinLog2, static_cast<int>(std::bit_width(slots)));
  }
  VoxelTable(const VoxelTable&) = delete;
  VoxelTable& operator=(const VoxelTable&) = delete;
  VoxelTable(VoxelTable&& other) noexcept { swap(other); }
  VoxelTable& operator=(VoxelTable&& other) noexcept {
    swap(other);
    return *this;
  }
  ~VoxelTable() { release(); }

  // The slot of `key`; a new slot (count 0, key set) when the key is not in the table.
  Slot* find_or_insert(Key key) {
    if (2 * (used_ + 1) > capacity_) grow();
    const std::size_t mask = capacity_ - 1;
    for (std::size_t s = hash(key);; s = (s + 1) & mask) {
      Slot& slot = slots_[s];
      if (slot.count == 0) {
        slot.key = key;
        ++used_;
        return &slot;
      }
      if (slot.key == key) return &slot;
    }
  }

  // Tables beyond the L2 cache miss on most lookups; their slots are worth prefetching.
  bool large() const { return capacity_ >= (std::size_t{1} << 14); }
  void prefetch(Key key) const {
    const char* slot = reinterpret_cast<const char*>(&slots_[hash(key)]);
    __builtin_prefetch(slot);
    __builtin_prefetch(slot + sizeof(Slot) - 1);
  }

  std::size_t capacity() const { return capacity_; }
  std::size_t size() const { return used_; }
  const Slot* slots() const { return slots_; }

 private:
  std::size_t hash(Key key) const {  // Fibonacci hashing
    return static_cast<std::size_t>((static_cast<std::uint64_t>(key) * 0x9E3779B97F4A7C15ull) >>
                                    (64 - log2_));
  }
  void swap(VoxelTable& other) noexcept {
    std::swap(slots_, other.slots_);
    std::swap(log2_, other.log2_);
    std::swap(capacity_, other.capacity_);
    std::swap(used_, other.used_);
  }
  void allocate(int log2) {
    log2_ = log2;
    capacity_ = std::size_t{1} << log2;
    slots_ = static_cast<Slot*>(detail::allocate_large_zeroed(capacity_ * sizeof(Slot)));
  }
  void release() {
    if (slots_) detail::deallocate_large(slots_, capacity_ * sizeof(Slot));
  }
  void grow() {
    VoxelTable old;
    swap(old);
    allocate(old.slots_ ? old.log2_ + 1 : kMinLog2);
    used_ = old.used_;
    const std::size_t mask = capacity_ - 1;
    for (std::size_t k = 0; k < old.capacity_; ++k) {
      if (old.slots_[k].count == 0) continue;
      std::size_t s = hash(old.slots_[k].key);
      while (slots_[s].count != 0) s = (s + 1) & mask;
      slots_[s] = old.slots_[k];
    }
  }

  Slot* slots_ = nullptr;
  int log2_ = 0;
  std::size_t capacity_ = 0;
  std::size_t used_ = 0;
};

// The voxels of one key range: the table, and the sums that only some clouds have, by id
// (order of first appearance).
template <typename Key>
struct RangeSums {
  VoxelTable<Key> table;
  std::vector<Eigen::Vector3d> normal;  // when the cloud has normals
  std::vector<double> scalar;           // scalar-field sums, field-minor
  std::vector<std::uint32_t> first;     // first point (normal fallback)
};

// Whether none of keys[0..16) lies in [low, high) (32-bit keys).
inline bool block_out_of_range(const std::uint32_t* keys, std::uint32_t low, std::uint32_t high) {
#if defined(__SSE2__)
  // Unsigned comparisons as signed ones, with the top bit flipped.
  const __m128i flip = _mm_set1_epi32(static_cast<int>(0x80000000u));
  const __m128i first = _mm_set1_epi32(static_cast<int>(low ^ 0x80000000u));
  const __m128i last = _mm_set1_epi32(static_cast<int>((high - 1) ^ 0x80000000u));
  __m128i out = _mm_set1_epi32(-1);
  for (int k = 0; k < 4; ++k) {
    const __m128i key = _mm_xor_si128(
        _mm_loadu_si128(reinterpret_cast<const __m128i*>(keys + 4 * k)), flip);
    out = _mm_and_si128(out, _mm_or_si128(_mm_cmpgt_epi32(first, key), _mm_cmpgt_epi32(key, last)));
  }
  return _mm_movemask_epi8(out) == 0xFFFF;
#else
  for (int k = 0; k < 16; ++k) {
    if (keys[k] >= low && keys[k] < high) return false;
  }
  return true;
#endif
}

// `expected_voxels` sizes the table (an estimate: the table grows if there are more).
template <typename Key>
RangeSums<Key> accumulate_range(const PointCloud& cloud, const Key* keys, Key low, Key high,
                                double expected_voxels) {
  RangeSums<Key> sums;
  sums.table = VoxelTable<Key>(VoxelTable<Key>::log2_for(expected_voxels));
  VoxelTable<Key>& table = sums.table;
  const std::size_t fields = cloud.scalars.size();
  const bool with_colors = cloud.has_colors();
  const bool gathered = cloud.has_normals() || fields > 0;
  Key last_key = 0;
  VoxelSlot<Key>* slot = nullptr;
  // Plain pointers, not the vectors behind `cloud`: the sum stores would otherwise make the
  // compiler reload them per point.
  const Eigen::Vector3f* const positions = cloud.positions.data();
  const Rgb8* const colors = cloud.colors.data();
  const std::size_t n = cloud.size();
  constexpr std::size_t kAhead = 32;  // table misses dominate large grids: prefetch the slot
  for (std::size_t i = 0; i < n; ++i) {
    if constexpr (sizeof(Key) == 4) {
      // Ranges split the scene along x, so the points of another range come in long stretches:
      // blocks of 16 wholly out of range are skipped at four keys an instruction.
      if ((i & 15) == 0 && i + 16 <= n && block_out_of_range(keys + i, low, high)) {
        i += 15;
        continue;
      }
    }
    if (i + kAhead < n && table.large()) {
      const Key ahead = keys[i + kAhead];
      if (ahead >= low && ahead < high) table.prefetch(ahead);
    }
    const Key key = keys[i];
    if (key < low || key >= high) continue;
    if (slot == nullptr || key != last_key) {  // consecutive points often share a voxel
      slot = table.find_or_insert(key);
      last_key = key;
      if (slot->count == 0 && gathered) {
        slot->id = static_cast<std::uint32_t>(sums.first.size());
        if (cloud.has_normals()) sums.normal.emplace_back(Eigen::Vector3d::Zero());
        sums.scalar.resize(sums.scalar.size() + fields, 0.0);
        sums.first.push_back(static_cast<std::uint32_t>(i));
      }
    }
    slot->position += positions[i].cast<double>();
    if (with_colors) {
      slot->r += colors[i].r;
      slot->g += colors[i].g;
      slot->b += colors[i].b;
    }
    ++slot->count;
    if (gathered) {
      const std::uint32_t id = slot->id;
      if (cloud.has_normals()) sums.normal[id] += cloud.normals[i].cast<double>();
      for (std::size_t f = 0; f < fields; ++f) {
        sums.scalar[id * fields + f] += cloud.scalars[f].values[i];
      }
    }
  }
  return sums;
}

// lround(sum / count) without the libm call: the quotient is at least 1 / (2 count) from a
// half-integer unless it is one, far more than the rounding of the division or of the + 0.5
// (count < 2^32, quotient <= 255), so truncating quotient + 0.5 gives the same integer.
std::uint8_t mean_channel(std::uint64_t sum, std::uint32_t count) {
  const double mean = static_cast<double>(sum) / count;
  return static_cast<std::uint8_t>(static_cast<std::uint32_t>(mean + 0.5));
}

// The occupied slots in increasing key order. 32-bit keys are sorted packed with their slot in
// one 64-bit integer (direct comparisons, no indirection); wider keys as (key, slot) pairs.
template <typename Key>
std::vector<std::uint32_t> key_order(const VoxelTable<Key>& table) {
  const VoxelSlot<Key>* const slots = table.slots();
  std::vector<std::uint32_t> order(table.size());
  if constexpr (sizeof(Key) <= 4) {
    // LSD radix sort on the key half (keys are unique, so order is total).
    std::vector<std::uint64_t> packed(table.size()), scratch(table.size());
    Key max_key = 0;
    std::size_t v = 0;
    for (std::size_t s = 0; s < table.capacity(); ++s) {
      if (slots[s].count == 0) continue;
      packed[v++] = (std::uint64_t{slots[s].key} << 32) | s;
      max_key = std::max(max_key, slots[s].key);
    }
    // As few passes as digits of at most 13 bits allow (the counts stay in the L2 cache).
    const int bits = std::bit_width(static_cast<std::uint32_t>(max_key));
    const int passes = std::max(1, (bits + 12) / 13);
    const int digit = (bits + passes - 1) / passes;
    const std::uint64_t mask = (std::uint64_t{1} << digit) - 1;
    std::vector<std::size_t> count;
    for (int shift = 0; shift < bits; shift += digit) {
      count.assign(mask + 2, 0);
      for (std::uint64_t item : packed) ++count[((item >> (32 + shift)) & mask) + 1];
      for (std::size_t d = 0; d <= mask; ++d) count[d + 1] += count[d];
      for (std::uint64_t item : packed) scratch[count[(item >> (32 + shift)) & mask]++] = item;
      packed.swap(scratch);
    }
    for (std::size_t k = 0; k < packed.size(); ++k) order[k] = static_cast<std::uint32_t>(packed[k]);
  } else {
    std::vector<std::pair<Key, std::uint32_t>> pairs;
    pairs.reserve(table.size());
    for (std::size_t s = 0; s < table.capacity(); ++s) {
      if (slots[s].count != 0) pairs.emplace_back(slots[s].key, static_cast<std::uint32_t>(s));
    }
    std::sort(pairs.begin(), pairs.end());
    for (std::size_t k = 0; k < pairs.size(); ++k) order[k] = pairs[k].second;
  }
  return order;
}

// Writes the means of one range, in key order, from output index `base` on.
template <typename Key>
void write_range(const PointCloud& cloud, const RangeSums<Key>& sums, std::size_t base,
                 VoxelGridResult& result) {
  const std::vector<std::uint32_t> order = key_order(sums.table);
  const VoxelSlot<Key>* const slots = sums.table.slots();
  PointCloud& out = result.cloud;
  const std::size_t fields = cloud.scalars.size();
  constexpr std::size_t kAhead = 8;  // key order is a random walk through the table: prefetch
  for (std::size_t k = 0; k < order.size(); ++k) {
    if (k + kAhead < order.size()) {
      const char* ahead = reinterpret_cast<const char*>(&slots[order[k + kAhead]]);
      __builtin_prefetch(ahead);
      __builtin_prefetch(ahead + sizeof(VoxelSlot<Key>) - 1);
    }
    const VoxelSlot<Key>& sum = slots[order[k]];
    const std::size_t v = base + k;
    const std::uint32_t count = sum.count;
    result.points_per_voxel[v] = count;
    out.positions[v] = (sum.position / count).template cast<float>();
    if (cloud.has_colors()) {
      out.colors[v] = Rgb8{mean_channel(sum.r, count), mean_channel(sum.g, count),
                           mean_channel(sum.b, count)};
    }
    if (cloud.has_normals()) {
      const Eigen::Vector3d& normal = sums.normal[sum.id];
      const double norm = normal.norm();
      out.normals[v] = norm > 0.0 ? Eigen::Vector3f((normal / norm).cast<float>())
                                  : cloud.normals[sums.first[sum.id]];
    }
    for (std::size_t f = 0; f < fields; ++f) {
      out.scalars[f].values[v] = static_cast<float>(sums.scalar[sum.id * fields + f] / count);
    }
  }
}

template <typename Key>
void voxel_grid_hashed(const PointCloud& cloud, const VoxelKeyGrid& grid, bool batch_keys,
                       VoxelGridResult& result) {
  const std::size_t n = cloud.size();
  const int key_bits = std::bit_width(grid.sentinel);  // every key is below the sentinel
  // Keys; a histogram of their top bits, to split the key space evenly; and an estimate of the
  // voxel count, to size the hash tables (growing them while filling cost a fifth of the run).
  constexpr int kHistogramBits = 12;
  const int shift = std::max(0, key_bits - kHistogramBits);
  const std::size_t bins = (std::size_t{1} << (key_bits - shift)) + 1;  // + sentinel overflow
  const detail::LargeArray<Key> keys(n);
  struct KeyStats {
    std::vector<std::size_t> histogram;
    detail::DistinctCounter<6> voxels;  // one key in 64 sampled: ~1 ns a point
  };
  // Per thread, not per task: a reduction would copy the 64 KiB of histograms at every split.
  tbb::enumerable_thread_specific<KeyStats> per_thread(
      [&] { return KeyStats{std::vector<std::size_t>(2 * bins, 0), {}}; });
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, n, 65536), [&](const auto& range) {
        KeyStats& partial = per_thread.local();
        // Locals, not the captures: the key stores (unsigned) could alias the captured ints,
        // and the compiler would reload them per point.
        const VoxelKeyGrid g = grid;
        const int top_shift = shift;
        Key* const out = keys.get();
        const Eigen::Vector3f* const positions = cloud.positions.data();
        const auto sentinel = static_cast<Key>(g.sentinel);
        // Two histograms, for even and odd points: consecutive points mostly fall in one bin,
        // and incrementing one counter point after point waits on the last store each time.
        std::size_t* const counts[2] = {partial.histogram.data(),
                                        partial.histogram.data() + bins};
        const auto count = [&](std::size_t i, Key key) {
          if (key == sentinel) return;
          ++counts[i & 1][key >> top_shift];
          partial.voxels.add(key);
        };
        if constexpr (sizeof(Key) == 4) {
          if (batch_keys) {  // the keys in a batch, then counted from the cache
            voxel_keys_u32(g, positions + range.begin(), range.size(), out + range.begin());
            for (std::size_t i = range.begin(); i != range.end(); ++i) count(i, out[i]);
            return;
          }
        }
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          const auto key = static_cast<Key>(g.key(positions[i]));
          out[i] = key;
          count(i, key);
        }
      });
  KeyStats stats{std::vector<std::size_t>(2 * bins, 0), {}};
  per_thread.combine_each([&stats](const KeyStats& partial) {
    for (std::size_t k = 0; k < stats.histogram.size(); ++k) {
      stats.histogram[k] += partial.histogram[k];
    }
    stats.voxels.merge(partial.voxels);
  });

  // Ranges [bounds[r], bounds[r + 1]) of about equal point counts; the sentinel is excluded.
  // Each range expects the share of the voxels that its share of the points suggests.
  const std::size_t ranges =
      static_cast<std::size_t>(std::max(1, tbb::this_task_arena::max_concurrency()));
  const std::size_t valid = n - result.report.non_finite;
  std::vector<Key> bounds{0};
  std::vector<std::size_t> points{};
  std::size_t running = 0;
  for (std::size_t b = 0; b + 1 < bins && bounds.size() < ranges; ++b) {
    running += stats.histogram[b] + stats.histogram[bins + b];
    if (running * ranges >= bounds.size() * valid && running < valid) {
      bounds.push_back(static_cast<Key>((b + 1) << shift));
      points.push_back(running);
    }
  }
  bounds.push_back(static_cast<Key>(grid.sentinel));
  points.push_back(valid);
  // At most one voxel a point (the estimate's error could say a little more).
  const double voxels_per_point =
      std::min(1.0, stats.voxels.estimate() / static_cast<double>(valid));

  std::vector<RangeSums<Key>> sums(bounds.size() - 1);
  tbb::parallel_for(std::size_t{0}, sums.size(), [&](std::size_t r) {
    const std::size_t in_range = points[r] - (r == 0 ? 0 : points[r - 1]);
    sums[r] = accumulate_range<Key>(cloud, keys.get(), bounds[r], bounds[r + 1],
                                    voxels_per_point * static_cast<double>(in_range));
  });
  std::vector<std::size_t> base(sums.size() + 1, 0);
  for (std::size_t r = 0; r < sums.size(); ++r) base[r + 1] = base[r] + sums[r].table.size();

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
  const VoxelKeyGrid grid = VoxelKeyGrid::over(inverse, min_voxel, extent);

  // The sentinel (the key of non-finite points) must fit the key type too.
  // (A stable scatter into cache-sized buckets before accumulating was tried: on 8 M points it
  // lost to this path at 1 cm and 5 cm, the page faults of its temporaries costing more than
  // the table misses it saved.)
  if (grid.sentinel < std::numeric_limits<std::uint32_t>::max()) {
    const bool batch_keys = detail::batch_keys_apply(grid, min_voxel, max_voxel);
    voxel_grid_hashed<std::uint32_t>(cloud, grid, batch_keys, result);
  } else {
    voxel_grid_hashed<std::uint64_t>(cloud, grid, false, result);
  }
  result.report.output_points = result.cloud.size();
  return result;
}

}  // namespace locard
