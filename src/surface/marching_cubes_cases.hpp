#pragma once
// Library-internal: the triangulation of every marching-cubes case, derived at start-up from
// the cube's topology rather than typed in as a table.
//
// Cube corners c = 0..7 sit at (c & 1, (c >> 1) & 1, (c >> 2) & 1). Edge e = 0..11 joins corner
// edge_low_corner(e) to that corner plus one step along edge_axis(e) (edges 0-3 run along x,
// 4-7 along y, 8-11 along z). A case index has bit c set when corner c is negative (inside).
//
// Derivation, per case: on each of the six faces the crossed edges are joined in pairs; a face
// with four crossed edges (an ambiguous face, two diagonal negative corners) pairs the edges
// around each negative corner, so the negative corners are kept apart. The rule depends only on
// the face's own four corners, hence both cubes sharing a face cut it the same way and the mesh
// has no cracks. Every crossed edge lies on exactly two faces, so the pairs close into cycles;
// each cycle is a polygon, oriented so that its normal points from negative to positive
// corners, and split into a triangle fan.

#include <array>
#include <cstdint>

namespace locard::detail {

struct MarchingCubesCase {
  std::uint8_t triangle_count = 0;
  std::array<std::array<std::uint8_t, 3>, 12> triangles{};  // cube edge indices, CCW seen
                                                            // from the positive side
};

// The 256 cases, built once (thread-safe static initialisation).
const std::array<MarchingCubesCase, 256>& marching_cubes_cases();

constexpr int edge_axis(int edge) { return edge / 4; }
// The lower corner of an edge (its bit for the edge's axis is clear).
int edge_low_corner(int edge);

}  // namespace locard::detail
