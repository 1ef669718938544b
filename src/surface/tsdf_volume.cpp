// Sparse-block TSDF fusion and coloured marching cubes; see tsdf_volume.hpp for the maths.
#include <locard/core/error.hpp>
#include <locard/surface/tsdf_volume.hpp>

#include "core/floor_to_int.hpp"
#include "surface/marching_cubes_cases.hpp"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

namespace locard {
namespace {

constexpr int kSide = TsdfVolume::kBlockSide;
constexpr int kVoxels = kSide * kSide * kSide;
constexpr int kKeyBits = 21;
constexpr std::int64_t kKeyOffset = std::int64_t{1} << (kKeyBits - 1);
constexpr std::uint64_t kKeyMask = (std::uint64_t{1} << kKeyBits) - 1;

// Stored voxel: colour as 8.8 fixed point so the running mean keeps moving after many frames.
struct Cell {
  float tsdf = 1.f;
  float weight = 0.f;
  std::array<std::uint16_t, 3> rgb{};
  std::uint16_t pad = 0;
};
static_assert(sizeof(Cell) == 16);

struct Block {
  std::array<Cell, kVoxels> cells;
};

// Packs block coordinates (each in [-2^20, 2^20)) into 63 bits; sorting keys sorts by z, y, x.
std::uint64_t pack(int x, int y, int z) {
  return static_cast<std::uint64_t>(x + kKeyOffset) |
         (static_cast<std::uint64_t>(y + kKeyOffset) << kKeyBits) |
         (static_cast<std::uint64_t>(z + kKeyOffset) << (2 * kKeyBits));
}
Eigen::Vector3i unpack(std::uint64_t key) {
  return {static_cast<int>(static_cast<std::int64_t>(key & kKeyMask) - kKeyOffset),
          static_cast<int>(static_cast<std::int64_t>((key >> kKeyBits) & kKeyMask) - kKeyOffset),
          static_cast<int>(static_cast<std::int64_t>((key >> (2 * kKeyBits)) & kKeyMask) -
                           kKeyOffset)};
}
bool in_key_range(int c) { return c >= -kKeyOffset + 1 && c < kKeyOffset - 1; }

// The block coordinate floor(x) of a position in block units; NaN, infinities and |x| >= 2^31
// give INT_MIN, which no key accepts.
int block_coordinate(float x) {
  if (!(std::abs(x) < 2147483520.f)) return std::numeric_limits<int>::min();
  return detail::floor_to_int<int>(x);
}

int floor_div(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

constexpr int local_index(int x, int y, int z) { return x + kSide * (y + kSide * z); }

using Float4 = float __attribute__((vector_size(16)));

// 1 / (w + 1) for the first weights, the same bits as the division (the update divides by
// the new weight once per voxel and frame; a table load is much cheaper than a division).
constexpr int kInverseCounts = 1024;
const std::array<float, kInverseCounts> inverse_count = [] {
  std::array<float, kInverseCounts> table{};
  for (int w = 0; w < kInverseCounts; ++w) table[w] = 1.f / (static_cast<float>(w) + 1.f);
  return table;
}();

std::uint8_t to_u8(std::uint16_t fixed) {
  return static_cast<std::uint8_t>(std::min(255, (fixed + 128) >> 8));
}

}  // namespace

struct TsdfVolume::Impl {
  TsdfOptions options;
  std::unordered_map<std::uint64_t, std::uint32_t> index;  // block key -> blocks[i]
  std::vector<std::unique_ptr<Block>> blocks;
  std::vector<std::uint64_t> keys;  // key of blocks[i]
  std::size_t frames = 0;
  bool has_color = false;

  std::uint32_t find_or_add(std::uint64_t key) {
    auto [it, added] = index.try_emplace(key, static_cast<std::uint32_t>(blocks.size()));
    if (added) {
      blocks.push_back(std::make_unique<Block>());
      keys.push_back(key);
    }
    return it->second;
  }
  const Block* find(std::uint64_t key) const {
    auto it = index.find(key);
    return it == index.end() ? nullptr : blocks[it->second].get();
  }
};

namespace {

// Per pixel: depth in metres (0 = no reading or out of range) and, with a reading, the ray's
// length per metre of depth, sqrt(1 + xs^2 + ys^2), which turns a depth difference into the
// signed distance along the ray. Side by side: the update reads both, one cache miss.
struct PixelDepth {
  float depth;
  float ray_factor;
};

// One frame as the update reads it: its pixels' depths, the pinhole model and the band.
struct FrameView {
  int width = 0;
  int height = 0;
  float fx = 0.f, fy = 0.f, cx = 0.f, cy = 0.f;
  float voxel = 0.f;
  float trunc = 0.f;
  std::vector<PixelDepth> pixels;
  std::vector<float> x_slope, y_slope;  // (u - cx) / fx, (v - cy) / fy
};

// --- 1. allocation: blocks within the truncation band of every valid pixel (fills the view's
// pixels on the way). The keys come back sorted and unique.
std::vector<std::uint64_t> touched_block_keys(const DepthImage& depth, float scale, float min_d,
                                              float max_d, const Eigen::Matrix3f& R_wc,
                                              const Eigen::Vector3f& t_wc, FrameView& view) {
  const int width = view.width;
  const int height = view.height;
  const float trunc = view.trunc;
  const float block_size = view.voxel * kSide;
  std::vector<PixelDepth>& pixels = view.pixels;
  const std::vector<float>& x_slope = view.x_slope;
  const std::vector<float>& y_slope = view.y_slope;
  tbb::combinable<std::vector<std::uint64_t>> touched;
  tbb::parallel_for(tbb::blocked_range<int>(0, height, 8), [&](const tbb::blocked_range<int>& rr) {
    std::vector<std::uint64_t>& out = touched.local();
    // Neighbouring pixels touch the same blocks: a small direct-mapped cache of the keys
    // pushed last keeps most repeats out of the list (which is sorted and made unique below,
    // so the cache only saves work, it decides nothing).
    constexpr std::size_t kSeen = 512;
    std::array<std::uint64_t, kSeen> seen;
    seen.fill(~std::uint64_t{0});
    // Locals, not the captured references (which the stores below would force reloading).
    const Eigen::Matrix3f R_blocks = R_wc / block_size;  // camera ray -> block units
    const Eigen::Vector3f t_blocks = t_wc / block_size;
    const float* const xs = x_slope.data();
    const float* const ys = y_slope.data();
    const float trunc_ = trunc, per_block = 2.f / block_size, min_d_ = min_d, max_d_ = max_d;
    const float scale_ = scale;
    for (int v = rr.begin(); v != rr.end(); ++v) {
      const std::uint16_t* row = depth.row(v);
      PixelDepth* prow = pixels.data() + static_cast<std::size_t>(v) * width;
      for (int u = 0; u < width; ++u) {
        const float d = static_cast<float>(row[u]) / scale_;
        const bool ok = row[u] != 0 && d >= min_d_ && d <= max_d_;
        prow[u].depth = ok ? d : 0.f;
        if (!ok) continue;
        const float ray_length = std::sqrt(1.f + xs[u] * xs[u] + ys[v] * ys[v]);
        prow[u].ray_factor = ray_length;
        // Samples along the ray from d - truncation to d + truncation, at most half a block
        // apart: the blocks the band crosses (the voxel-hashing allocation of Niessner 2013).
        // In block units, with one division per pixel: this loop runs ~4 times per pixel.
        const Eigen::Vector3f ray = R_blocks * Eigen::Vector3f(xs[u], ys[v], 1.f);
        const float band_lo = std::max(d - trunc_, 1e-3f), band_hi = d + trunc_;
        const int steps = 1 + static_cast<int>((band_hi - band_lo) * ray_length * per_block);
        const float spacing = (band_hi - band_lo) / static_cast<float>(steps);
        for (int step = 0; step <= steps; ++step) {
          const float depth_k = band_lo + spacing * static_cast<float>(step);
          const Eigen::Vector3f q = ray * depth_k + t_blocks;
          // (A non-finite or huge coordinate floors to INT_MIN, outside the key range.)
          const int bx = block_coordinate(q.x());
          const int by = block_coordinate(q.y());
          const int bz = block_coordinate(q.z());
          if (!in_key_range(bx) || !in_key_range(by) || !in_key_range(bz)) continue;
          const std::uint64_t key = pack(bx, by, bz);
          std::uint64_t& slot = seen[(key * 0x9E3779B97F4A7C15ull) >> 55];
          if (slot == key) continue;
          slot = key;
          out.push_back(key);
        }
      }
    }
  });
  // Each thread's list is sorted and made unique once, here, rather than after every task (a
  // thread runs dozens of row tasks, and re-sorting its growing list each time was most of
  // the merge's cost).
  std::vector<std::vector<std::uint64_t>*> lists;
  touched.combine_each([&lists](std::vector<std::uint64_t>& v) { lists.push_back(&v); });
  tbb::parallel_for(std::size_t{0}, lists.size(), [&lists](std::size_t l) {
    std::vector<std::uint64_t>& list = *lists[l];
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  });
  std::vector<std::uint64_t> keys;
  for (const std::vector<std::uint64_t>* list : lists) {
    keys.insert(keys.end(), list->begin(), list->end());
  }
  tbb::parallel_sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  return keys;
}

// --- 2. update of one touched block: every voxel projected into the frame, its signed
// distance and colour averaged in.
void update_block(Block& block, const Eigen::Vector3i& b, const FrameView& view,
                  const Eigen::Matrix3f& R, const Eigen::Vector3f& t, const std::uint8_t* color) {
  // Locals, not the view's fields: the cell stores would otherwise make the compiler reload
  // each of them per voxel.
  const PixelDepth* const pixel_depth = view.pixels.data();
  const std::size_t stride = static_cast<std::size_t>(view.width);
  const float width_f = static_cast<float>(view.width), height_f = static_cast<float>(view.height);
  const float fx_ = view.fx, fy_ = view.fy, cx_ = view.cx, cy_ = view.cy, trunc_ = view.trunc;
  const float inv_trunc_ = 1.f / view.trunc;
  const float voxel = view.voxel;
  const bool with_color = color != nullptr;
  const Eigen::Vector3f step_x = R.col(0) * voxel;
  const Eigen::Vector3f step_y = R.col(1) * voxel;
  const Eigen::Vector3f step_z = R.col(2) * voxel;
  const Eigen::Vector3f origin =
      ((b * kSide).cast<float>() + Eigen::Vector3f::Constant(0.5f)) * voxel;
  const Eigen::Vector3f p0 = R * origin + t;
  for (int z = 0; z < kSide; ++z) {
    for (int y = 0; y < kSide; ++y) {
      // The row's 8 voxels in camera coordinates (stepped one voxel at a time), then
      // projected as two 4-lane vectors: lane-wise the same IEEE operations as one voxel
      // at a time, so the same pixels, with a quarter of the divisions.
      alignas(16) float px[kSide], py[kSide], pz[kSide];
      Eigen::Vector3f p = p0 + step_z * static_cast<float>(z) + step_y * static_cast<float>(y);
      for (int x = 0; x < kSide; ++x, p += step_x) {
        px[x] = p.x();
        py[x] = p.y();
        pz[x] = p.z();
      }
      alignas(16) float us[kSide], vs[kSide];
      for (int x = 0; x < kSide; x += 4) {
        Float4 x4, y4, z4;
        std::memcpy(&x4, px + x, sizeof(x4));
        std::memcpy(&y4, py + x, sizeof(y4));
        std::memcpy(&z4, pz + x, sizeof(z4));
        const Float4 positive = z4 > 0.f ? z4 : Float4{1.f, 1.f, 1.f, 1.f};
        const Float4 inv_z = 1.f / positive;
        const Float4 u4 = fx_ * x4 * inv_z + cx_ + 0.5f;
        const Float4 v4 = fy_ * y4 * inv_z + cy_ + 0.5f;
        std::memcpy(us + x, &u4, sizeof(u4));
        std::memcpy(vs + x, &v4, sizeof(v4));
      }
      Cell* cell = &block.cells[local_index(0, y, z)];
      for (int x = 0; x < kSide; ++x, ++cell) {
        const float pz_x = pz[x];
        if (pz_x <= 0.f) continue;
        const float uf = us[x];
        const float vf = vs[x];
        if (!(uf >= 0.f && vf >= 0.f && uf < width_f && vf < height_f)) continue;
        const int u = static_cast<int>(uf);
        const int v = static_cast<int>(vf);
        const std::size_t pixel = static_cast<std::size_t>(v) * stride + u;
        const PixelDepth observed_depth = pixel_depth[pixel];
        const float d = observed_depth.depth;
        if (d <= 0.f) continue;
        const float sdf = (d - pz_x) * observed_depth.ray_factor;
        if (sdf <= -trunc_) continue;
        const float tsdf = std::min(1.f, sdf * inv_trunc_);
        const float w = cell->weight;  // a whole number of observations
        const float inv_w = w < kInverseCounts ? inverse_count[static_cast<int>(w)]
                                               : 1.f / (w + 1.f);
        cell->tsdf = (cell->tsdf * w + tsdf) * inv_w;
        if (with_color) {
          // The three channels as one 4-lane vector (lane-wise the same IEEE operations
          // as a loop over the channels, so the same bits, in a third of the instructions).
          const std::uint8_t* rgb = color + 3 * pixel;
          const Float4 old_mean = {static_cast<float>(cell->rgb[0]),
                                   static_cast<float>(cell->rgb[1]),
                                   static_cast<float>(cell->rgb[2]), 0.f};
          const Float4 observed = {static_cast<float>(rgb[0]), static_cast<float>(rgb[1]),
                                   static_cast<float>(rgb[2]), 0.f};
          Float4 mean = (old_mean * w + observed * 256.f) * inv_w + 0.5f;
          mean = mean < 65535.f ? mean : Float4{65535.f, 65535.f, 65535.f, 65535.f};
          for (int c = 0; c < 3; ++c) cell->rgb[c] = static_cast<std::uint16_t>(mean[c]);
        }
        cell->weight = w + 1.f;
      }
    }
  }
}

}  // namespace

namespace {

constexpr std::uint32_t kNoBlock = std::numeric_limits<std::uint32_t>::max();

// The volume's blocks in key order (the output order then depends neither on the integration
// history's allocation order nor on the thread count), with each block's 2x2x2 neighbourhood
// (self and the +x, +y, +z neighbours) by sorted rank.
struct SortedBlocks {
  const std::vector<std::unique_ptr<Block>>& blocks;
  const std::unordered_map<std::uint64_t, std::uint32_t>& index;
  std::vector<std::uint64_t> sorted_keys;
  std::unordered_map<std::uint64_t, std::uint32_t> rank;  // key -> position in sorted_keys

  SortedBlocks(const std::vector<std::unique_ptr<Block>>& blocks_,
               const std::unordered_map<std::uint64_t, std::uint32_t>& index_,
               const std::vector<std::uint64_t>& keys)
      : blocks(blocks_), index(index_), sorted_keys(keys) {
    std::sort(sorted_keys.begin(), sorted_keys.end());
    rank.reserve(sorted_keys.size());
    for (std::size_t i = 0; i < sorted_keys.size(); ++i)
      rank.emplace(sorted_keys[i], static_cast<std::uint32_t>(i));
  }
  std::array<std::uint32_t, 8> neighbours(std::size_t r) const {
    const Eigen::Vector3i b = unpack(sorted_keys[r]);
    std::array<std::uint32_t, 8> out;
    for (int n = 0; n < 8; ++n) {
      const int x = b.x() + (n & 1), y = b.y() + ((n >> 1) & 1), z = b.z() + ((n >> 2) & 1);
      if (!in_key_range(x) || !in_key_range(y) || !in_key_range(z)) {
        out[n] = kNoBlock;
        continue;
      }
      auto it = rank.find(pack(x, y, z));
      out[n] = it == rank.end() ? kNoBlock : it->second;
    }
    return out;
  }
  const Block& block_at(std::uint32_t r) const { return *blocks[index.at(sorted_keys[r])]; }
};

// Pass A's output for one block: one vertex per crossed edge owned by a voxel of the block.
struct BlockVertices {
  std::vector<std::uint32_t> edge;  // local voxel index * 3 + axis, increasing
  std::vector<Eigen::Vector3f> position;
  std::vector<Rgb8> color;
};

// --- pass A for the block of rank r
void find_block_vertices(const SortedBlocks& sorted, std::size_t r, float voxel, BlockVertices& out) {
  constexpr std::uint32_t kNone = kNoBlock;
  const auto nb = sorted.neighbours(r);
  const Block& self = sorted.block_at(static_cast<std::uint32_t>(r));
  const Eigen::Vector3i origin = unpack(sorted.sorted_keys[r]) * kSide;
  for (int z = 0; z < kSide; ++z)
    for (int y = 0; y < kSide; ++y)
      for (int x = 0; x < kSide; ++x) {
        const Cell& c0 = self.cells[local_index(x, y, z)];
        if (c0.weight <= 0.f) continue;
        for (int axis = 0; axis < 3; ++axis) {
          int n[3] = {x, y, z};
          ++n[axis];
          const Cell* c1;
          if (n[axis] < kSide) {
            c1 = &self.cells[local_index(n[0], n[1], n[2])];
          } else {
            const std::uint32_t other = nb[1 << axis];
            if (other == kNone) continue;
            n[axis] = 0;
            c1 = &sorted.block_at(other).cells[local_index(n[0], n[1], n[2])];
          }
          if (c1->weight <= 0.f || (c0.tsdf < 0.f) == (c1->tsdf < 0.f)) continue;
          const float s = c0.tsdf / (c0.tsdf - c1->tsdf);
          Eigen::Vector3f p = ((origin + Eigen::Vector3i(x, y, z)).cast<float>() +
                               Eigen::Vector3f::Constant(0.5f)) * voxel;
          p[axis] += s * voxel;
          out.edge.push_back(static_cast<std::uint32_t>(local_index(x, y, z) * 3 + axis));
          out.position.push_back(p);
          Rgb8 col;
          std::uint8_t* dst[3] = {&col.r, &col.g, &col.b};
          for (int ch = 0; ch < 3; ++ch) {
            const float v0 = c0.rgb[ch], v1 = c1->rgb[ch];
            *dst[ch] = to_u8(static_cast<std::uint16_t>(v0 + s * (v1 - v0) + 0.5f));
          }
          out.color.push_back(col);
        }
      }
}

// Corner c (bit 0: +x, 1: +y, 2: +z) of the cube whose origin voxel is (x, y, z): its local
// voxel coordinates in `p`, wrapped into the neighbour block it falls in, and which neighbour
// (bit a set: the +a one; 0: this block).
int cube_corner(int x, int y, int z, int c, int p[3]) {
  p[0] = x + (c & 1);
  p[1] = y + ((c >> 1) & 1);
  p[2] = z + ((c >> 2) & 1);
  int which = 0;
  for (int a = 0; a < 3; ++a)
    if (p[a] == kSide) {
      p[a] = 0;
      which |= 1 << a;
    }
  return which;
}

// --- pass B for the block of rank r: triangles of every cube whose origin voxel lies in it
void find_block_triangles(const SortedBlocks& sorted, std::size_t r,
                          const std::vector<BlockVertices>& vertices,
                          const std::vector<std::size_t>& vertex_offset,
                          std::vector<std::array<std::uint32_t, 3>>& out) {
  constexpr std::uint32_t kNone = kNoBlock;
  const auto& cases = detail::marching_cubes_cases();
  const auto nb = sorted.neighbours(r);
  std::array<const Block*, 8> nblock;
  for (int n = 0; n < 8; ++n) nblock[n] = nb[n] == kNone ? nullptr : &sorted.block_at(nb[n]);
  for (int z = 0; z < kSide; ++z)
    for (int y = 0; y < kSide; ++y)
      for (int x = 0; x < kSide; ++x) {
        std::array<const Cell*, 8> corner;
        int cube = 0;
        bool complete = true;
        for (int c = 0; c < 8 && complete; ++c) {
          int p[3];
          const Block* blk = nblock[cube_corner(x, y, z, c, p)];
          if (!blk) {
            complete = false;
            break;
          }
          corner[c] = &blk->cells[local_index(p[0], p[1], p[2])];
          if (corner[c]->weight <= 0.f) complete = false;
          if (corner[c]->tsdf < 0.f) cube |= 1 << c;
        }
        if (!complete || cube == 0 || cube == 255) continue;
        const detail::MarchingCubesCase& mc = cases[cube];
        std::array<std::uint32_t, 12> edge_vertex;
        edge_vertex.fill(kNone);
        for (int t = 0; t < mc.triangle_count; ++t) {
          std::array<std::uint32_t, 3> tri;
          for (int j = 0; j < 3; ++j) {
            const int e = mc.triangles[t][j];
            if (edge_vertex[e] == kNone) {
              const int lo = detail::edge_low_corner(e);
              int p[3];
              const std::uint32_t owner = nb[cube_corner(x, y, z, lo, p)];
              const BlockVertices& bv = vertices[owner];
              const std::uint32_t id = static_cast<std::uint32_t>(
                  local_index(p[0], p[1], p[2]) * 3 + detail::edge_axis(e));
              const auto it = std::lower_bound(bv.edge.begin(), bv.edge.end(), id);
              edge_vertex[e] = static_cast<std::uint32_t>(vertex_offset[owner] +
                                                          (it - bv.edge.begin()));
            }
            tri[j] = edge_vertex[e];
          }
          out.push_back(tri);
        }
      }
}

// --- gather, dropping vertices no triangle uses (edges of incomplete cubes)
TriangleMesh gather_mesh(const std::vector<BlockVertices>& vertices,
                         const std::vector<std::size_t>& vertex_offset,
                         const std::vector<std::vector<std::array<std::uint32_t, 3>>>& triangles,
                         bool has_color) {
  constexpr std::uint32_t kNone = kNoBlock;
  const std::size_t n_blocks = vertices.size();
  const std::size_t total_vertices = vertex_offset[n_blocks];
  std::vector<std::uint32_t> remap(total_vertices, 0);
  std::size_t total_triangles = 0;
  for (const auto& t : triangles) {
    total_triangles += t.size();
    for (const auto& tri : t)
      for (std::uint32_t v : tri) remap[v] = 1;
  }
  std::uint32_t next = 0;
  for (auto& m : remap) m = m ? next++ : kNone;

  TriangleMesh mesh;
  mesh.vertices.resize(next);
  if (has_color) mesh.vertex_colors.resize(next);
  tbb::parallel_for(std::size_t{0}, n_blocks, [&](std::size_t r) {
    const BlockVertices& bv = vertices[r];
    for (std::size_t i = 0; i < bv.edge.size(); ++i) {
      const std::uint32_t m = remap[vertex_offset[r] + i];
      if (m == kNone) continue;
      mesh.vertices[m] = bv.position[i];
      if (has_color) mesh.vertex_colors[m] = bv.color[i];
    }
  });
  mesh.triangles.reserve(total_triangles);
  for (const auto& t : triangles)
    for (const auto& tri : t) mesh.triangles.push_back({remap[tri[0]], remap[tri[1]], remap[tri[2]]});
  return mesh;
}

}  // namespace

TsdfVolume::TsdfVolume(const TsdfOptions& options) : impl_(std::make_unique<Impl>()) {
  if (!(options.voxel_size > 0.0) || !std::isfinite(options.voxel_size))
    throw InputError("TSDF: the voxel size must be a positive number of metres, got " +
                     std::to_string(options.voxel_size));
  if (!(options.truncation >= options.voxel_size) || !std::isfinite(options.truncation))
    throw InputError("TSDF: the truncation must be at least one voxel (" +
                     std::to_string(options.voxel_size) + " m), got " +
                     std::to_string(options.truncation));
  if (!(options.max_depth_m > options.min_depth_m))
    throw InputError("TSDF: the maximum depth must exceed the minimum depth");
  impl_->options = options;
}
TsdfVolume::~TsdfVolume() = default;
TsdfVolume::TsdfVolume(TsdfVolume&&) noexcept = default;
TsdfVolume& TsdfVolume::operator=(TsdfVolume&&) noexcept = default;

const TsdfOptions& TsdfVolume::options() const { return impl_->options; }

Eigen::Vector3d TsdfVolume::voxel_center(const Eigen::Vector3i& g) const {
  return (g.cast<double>() + Eigen::Vector3d::Constant(0.5)) * impl_->options.voxel_size;
}

std::optional<TsdfVoxel> TsdfVolume::voxel(const Eigen::Vector3i& g) const {
  const Eigen::Vector3i b(floor_div(g.x(), kSide), floor_div(g.y(), kSide),
                          floor_div(g.z(), kSide));
  const Block* block = impl_->find(pack(b.x(), b.y(), b.z()));
  if (!block) return std::nullopt;
  const Eigen::Vector3i l = g - b * kSide;
  const Cell& c = block->cells[local_index(l.x(), l.y(), l.z())];
  return TsdfVoxel{c.tsdf, c.weight, Rgb8{to_u8(c.rgb[0]), to_u8(c.rgb[1]), to_u8(c.rgb[2])}, 0};
}

void TsdfVolume::set_voxel(const Eigen::Vector3i& g, const TsdfVoxel& value) {
  const Eigen::Vector3i b(floor_div(g.x(), kSide), floor_div(g.y(), kSide),
                          floor_div(g.z(), kSide));
  if (!in_key_range(b.x()) || !in_key_range(b.y()) || !in_key_range(b.z()))
    throw InputError("TSDF: voxel index out of range");
  Block& block = *impl_->blocks[impl_->find_or_add(pack(b.x(), b.y(), b.z()))];
  const Eigen::Vector3i l = g - b * kSide;
  Cell& c = block.cells[local_index(l.x(), l.y(), l.z())];
  c.tsdf = value.tsdf;
  c.weight = value.weight;
  c.rgb = {static_cast<std::uint16_t>(value.color.r << 8),
           static_cast<std::uint16_t>(value.color.g << 8),
           static_cast<std::uint16_t>(value.color.b << 8)};
  impl_->has_color = true;
}

TsdfStats TsdfVolume::stats() const {
  TsdfStats s;
  s.blocks = impl_->blocks.size();
  s.frames = impl_->frames;
  // Blocks, their owning pointers and keys, and the hash map's nodes and buckets.
  s.memory_bytes = s.blocks * (sizeof(Block) + sizeof(void*) + sizeof(std::uint64_t) +
                               sizeof(std::uint64_t) * 3) +
                   impl_->index.bucket_count() * sizeof(void*);
  return s;
}

void TsdfVolume::integrate(const RgbdFrame& frame, const Isometry3d& T_world_camera) {
  const TsdfOptions& opt = impl_->options;
  const DepthImage& depth = frame.depth;
  const CameraIntrinsics& k = frame.intrinsics;
  if (depth.empty()) return;
  if (!k.valid())
    throw InputError("TSDF: frame " + std::to_string(frame.frame_index) +
                     " has no valid intrinsics");
  if (k.width != depth.width() || k.height != depth.height())
    throw InputError("TSDF: frame " + std::to_string(frame.frame_index) + ": depth image " +
                     std::to_string(depth.width()) + "x" + std::to_string(depth.height()) +
                     " does not match the intrinsics " + std::to_string(k.width) + "x" +
                     std::to_string(k.height));
  const bool with_color = opt.integrate_color && !frame.color.empty() &&
                          frame.color.width() == depth.width() &&
                          frame.color.height() == depth.height();
  if (with_color) impl_->has_color = true;
  ++impl_->frames;

  FrameView view;
  view.width = depth.width();
  view.height = depth.height();
  view.fx = static_cast<float>(k.fx), view.fy = static_cast<float>(k.fy);
  view.cx = static_cast<float>(k.cx), view.cy = static_cast<float>(k.cy);
  view.voxel = static_cast<float>(opt.voxel_size);
  view.trunc = static_cast<float>(opt.truncation);
  view.pixels.resize(static_cast<std::size_t>(view.width) * view.height);
  view.x_slope.resize(view.width);
  view.y_slope.resize(view.height);
  for (int u = 0; u < view.width; ++u) view.x_slope[u] = (static_cast<float>(u) - view.cx) / view.fx;
  for (int v = 0; v < view.height; ++v) view.y_slope[v] = (static_cast<float>(v) - view.cy) / view.fy;
  const float scale = static_cast<float>(frame.depth_scale);
  const float min_d = static_cast<float>(opt.min_depth_m);
  const float max_d = static_cast<float>(opt.max_depth_m);

  const Eigen::Matrix3f R_wc = T_world_camera.linear().cast<float>();
  const Eigen::Vector3f t_wc = T_world_camera.translation().cast<float>();
  const std::vector<std::uint64_t> keys = touched_block_keys(depth, scale, min_d, max_d, R_wc, t_wc, view);
  std::vector<std::uint32_t> active(keys.size());
  for (std::size_t i = 0; i < keys.size(); ++i) active[i] = impl_->find_or_add(keys[i]);

  // --- 2. update, parallel over the touched blocks
  const Eigen::Isometry3f T_camera_world = T_world_camera.inverse().cast<float>();
  const Eigen::Matrix3f R = T_camera_world.linear();
  const Eigen::Vector3f t = T_camera_world.translation();
  const std::uint8_t* const color = with_color ? frame.color.row(0) : nullptr;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, active.size(), 4),
                    [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t a = range.begin(); a != range.end(); ++a)
      update_block(*impl_->blocks[active[a]], unpack(keys[a]), view, R, t, color);
  });
}

TriangleMesh TsdfVolume::extract_mesh() const {
  const Impl& impl = *impl_;
  const float voxel = static_cast<float>(impl.options.voxel_size);
  const std::size_t n_blocks = impl.blocks.size();
  const SortedBlocks sorted(impl.blocks, impl.index, impl.keys);
  std::vector<BlockVertices> vertices(n_blocks);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n_blocks, 4),
                    [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t r = range.begin(); r != range.end(); ++r)
      find_block_vertices(sorted, r, voxel, vertices[r]);
  });
  std::vector<std::size_t> vertex_offset(n_blocks + 1, 0);
  for (std::size_t r = 0; r < n_blocks; ++r)
    vertex_offset[r + 1] = vertex_offset[r] + vertices[r].edge.size();
  std::vector<std::vector<std::array<std::uint32_t, 3>>> triangles(n_blocks);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n_blocks, 4),
                    [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t r = range.begin(); r != range.end(); ++r)
      find_block_triangles(sorted, r, vertices, vertex_offset, triangles[r]);
  });
  return gather_mesh(vertices, vertex_offset, triangles, impl.has_color);
}

}  // namespace locard
