#pragma once
// Clean-up of a reconstructed mesh, and honest hole filling.
//  - remove_small_components: connected components (triangles sharing a vertex) with fewer
//    than `min_triangles` triangles are dropped (floating noise from depth outliers), then
//    unused vertices; vertex order otherwise kept.
//  - fill_holes: every boundary loop (edges used by one triangle only) with at most
//    `max_boundary_edges` edges is closed by a fan around a new vertex at the loop's centroid,
//    coloured with the loop's mean colour. Each added triangle is flagged in the returned
//    vector (1 = inferred, 0 = observed), so exports can show what was filled.
//  - decimate: quadric edge collapse (CGAL Surface_mesh_simplification, Garland-Heckbert
//    placement) down to a target triangle count; colours follow the nearest original vertex.
// All three are deterministic.

#include <locard/core/triangle_mesh.hpp>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace locard {

struct ComponentReport {
  std::size_t components = 0;
  std::size_t removed_components = 0;
  std::size_t removed_triangles = 0;
};
ComponentReport remove_small_components(TriangleMesh& mesh, std::size_t min_triangles);

// Drops vertices no triangle uses (keeps the order of the others).
void remove_unused_vertices(TriangleMesh& mesh);

struct HoleFillReport {
  std::size_t boundary_loops = 0;
  std::size_t filled_loops = 0;
  std::size_t added_triangles = 0;
  std::vector<std::uint8_t> inferred_triangles;  // one flag per triangle of the result
};
HoleFillReport fill_holes(TriangleMesh& mesh, std::size_t max_boundary_edges);

struct DecimationReport {
  std::size_t triangles_before = 0;
  std::size_t triangles_after = 0;
};
// Non-manifold input is reduced to its manifold part first (CGAL needs a polygon mesh).
DecimationReport decimate(TriangleMesh& mesh, std::size_t target_triangles);

}  // namespace locard
