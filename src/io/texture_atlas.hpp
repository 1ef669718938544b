#pragma once
// Vertex colours baked into a texture, for formats whose readers ignore vertex colours (OBJ
// in CloudCompare and Unity). Every triangle gets its own right-triangle patch; two patches
// share a square cell of kCell x kCell pixels, cells in rows:
//
//   cell pixels (i, j), centres at integers, i right, j down (image rows)
//     lower patch L: corners at (0,0), (2,0), (0,2)  -> triangle corners 0, 1, 2
//     upper patch U: corners at (4,4), (2,4), (4,2)  -> triangle corners 0, 1, 2
//   A pixel with i + j <= 3 takes L's colour, i + j >= 5 U's; the diagonal i + j = 4 the mean.
//
// The colour of a patch pixel is the triangle's linear colour c0 + (c1-c0) s + (c2-c0) t,
// with (s, t) the pixel's coordinates along the patch's legs (half the pixel offset from
// corner 0), extended linearly beyond the patch and clamped to 0..255. Bilinear sampling at
// any point of L reads only pixels with i + j <= 3, all on L's plane, so it returns the
// triangle's interpolated vertex colours exactly (up to 8-bit rounding): no bleeding between
// neighbours, no seams. Exact as long as that extension, half a leg beyond the triangle (the
// colour 1.5 times as far from corner 0), stays within 0..255 - true for the small colour
// changes over one triangle of a scan; where it is clamped, points near the long edge are
// off by at most a quarter of the clamped amount, corners and centroid stay exact. Nearest
// sampling is off by at most half a pixel's colour step.

#include <locard/core/image.hpp>
#include <locard/core/triangle_mesh.hpp>

#include <Eigen/Core>

#include <array>
#include <vector>

namespace locard::detail {

struct TextureAtlas {
  static constexpr int kCell = 5;        // pixels per cell side (two triangles per cell)
  static constexpr int kMaxSide = 16384;  // widest texture GPUs and engines take
  ColorImage image;
  // Per triangle, its corners' texture coordinates: u to the right, v up (OBJ / OpenGL), in
  // 0..1, at pixel centres.
  std::vector<std::array<Eigen::Vector2f, 3>> uv;
};

// Throws locard::Error when the atlas would be wider than kMaxSide (over about 21 million
// triangles: decimate first). `colors` has one entry per vertex.
TextureAtlas bake_texture_atlas(const TriangleMesh& mesh, const std::vector<Rgb8>& colors);

}  // namespace locard::detail
