#include <locard/core/disjoint_sets.hpp>
#include <locard/core/error.hpp>
#include <locard/core/kdtree.hpp>
#include <locard/surface/mesh_cleanup.hpp>

#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/GarlandHeckbert_plane_policies.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

#include <algorithm>
#include <map>
#include <numeric>
#include <unordered_map>

namespace locard {
namespace {

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  return (static_cast<std::uint64_t>(a) << 32) | b;
}

}  // namespace

void remove_unused_vertices(TriangleMesh& mesh) {
  constexpr std::uint32_t kUnused = 0xFFFFFFFFu;
  std::vector<std::uint32_t> remap(mesh.vertices.size(), kUnused);
  for (const auto& t : mesh.triangles)
    for (std::uint32_t v : t) remap[v] = 0;
  std::uint32_t next = 0;
  for (std::size_t v = 0; v < remap.size(); ++v) {
    if (remap[v] == kUnused) continue;
    remap[v] = next;
    mesh.vertices[next] = mesh.vertices[v];
    if (!mesh.vertex_colors.empty()) mesh.vertex_colors[next] = mesh.vertex_colors[v];
    if (!mesh.vertex_normals.empty()) mesh.vertex_normals[next] = mesh.vertex_normals[v];
    ++next;
  }
  mesh.vertices.resize(next);
  if (!mesh.vertex_colors.empty()) mesh.vertex_colors.resize(next);
  if (!mesh.vertex_normals.empty()) mesh.vertex_normals.resize(next);
  for (auto& t : mesh.triangles)
    for (auto& v : t) v = remap[v];
}

ComponentReport remove_small_components(TriangleMesh& mesh, std::size_t min_triangles) {
  ComponentReport report;
  DisjointSets sets(mesh.vertices.size());
  for (const auto& t : mesh.triangles) {
    sets.unite(t[0], t[1]);
    sets.unite(t[1], t[2]);
  }
  std::unordered_map<std::uint32_t, std::size_t> size;
  for (const auto& t : mesh.triangles) ++size[sets.find(t[0])];
  report.components = size.size();
  for (const auto& [root, n] : size) report.removed_components += n < min_triangles;
  std::size_t kept = 0;
  for (const auto& t : mesh.triangles)
    if (size[sets.find(t[0])] >= min_triangles) mesh.triangles[kept++] = t;
  report.removed_triangles = mesh.triangles.size() - kept;
  mesh.triangles.resize(kept);
  remove_unused_vertices(mesh);
  return report;
}

HoleFillReport fill_holes(TriangleMesh& mesh, std::size_t max_boundary_edges) {
  HoleFillReport report;
  report.inferred_triangles.assign(mesh.triangles.size(), 0);
  // Directed edges; a boundary edge a->b has no b->a. Walking boundary edges b->a in the
  // reverse direction traces each hole's rim with the orientation its filling needs.
  std::unordered_map<std::uint64_t, std::uint32_t> directed;
  directed.reserve(mesh.triangles.size() * 3);
  for (const auto& t : mesh.triangles)
    for (int j = 0; j < 3; ++j) ++directed[edge_key(t[j], t[(j + 1) % 3])];
  // next_on_rim[b] = a for every boundary edge a->b: the filling runs b -> a.
  std::map<std::uint32_t, std::vector<std::uint32_t>> rim;  // ordered: deterministic walk
  for (const auto& t : mesh.triangles)
    for (int j = 0; j < 3; ++j) {
      const std::uint32_t a = t[j], b = t[(j + 1) % 3];
      if (!directed.count(edge_key(b, a))) rim[b].push_back(a);
    }
  std::map<std::uint32_t, std::size_t> used;  // per start vertex, rim edges consumed
  for (auto& [start, outs] : rim) {
    while (used[start] < outs.size()) {
      std::vector<std::uint32_t> loop{start};
      std::uint32_t current = outs[used[start]++];
      bool closed = false;
      while (loop.size() <= max_boundary_edges + 1) {
        if (current == start) {
          closed = true;
          break;
        }
        loop.push_back(current);
        auto it = rim.find(current);
        if (it == rim.end() || used[current] >= it->second.size()) break;
        current = it->second[used[current]++];
      }
      ++report.boundary_loops;
      if (!closed || loop.size() < 3 || loop.size() > max_boundary_edges) continue;
      // Fan around the centroid; colour = mean rim colour.
      Eigen::Vector3d centre = Eigen::Vector3d::Zero();
      Eigen::Vector3d colour = Eigen::Vector3d::Zero();
      for (std::uint32_t v : loop) {
        centre += mesh.vertices[v].cast<double>();
        if (!mesh.vertex_colors.empty())
          colour += Eigen::Vector3d(mesh.vertex_colors[v].r, mesh.vertex_colors[v].g,
                                    mesh.vertex_colors[v].b);
      }
      centre /= static_cast<double>(loop.size());
      colour /= static_cast<double>(loop.size());
      const auto c = static_cast<std::uint32_t>(mesh.vertices.size());
      mesh.vertices.push_back(centre.cast<float>());
      if (!mesh.vertex_colors.empty())
        mesh.vertex_colors.push_back({static_cast<std::uint8_t>(std::lround(colour.x())),
                                      static_cast<std::uint8_t>(std::lround(colour.y())),
                                      static_cast<std::uint8_t>(std::lround(colour.z()))});
      if (!mesh.vertex_normals.empty()) mesh.vertex_normals.push_back(Eigen::Vector3f::UnitZ());
      for (std::size_t i = 0; i < loop.size(); ++i) {
        mesh.triangles.push_back({loop[i], loop[(i + 1) % loop.size()], c});
        report.inferred_triangles.push_back(1);
      }
      ++report.filled_loops;
      report.added_triangles += loop.size();
    }
  }
  return report;
}

DecimationReport decimate(TriangleMesh& mesh, std::size_t target_triangles) {
  using Kernel = CGAL::Simple_cartesian<double>;
  using Surface = CGAL::Surface_mesh<Kernel::Point_3>;
  namespace SMS = CGAL::Surface_mesh_simplification;
  DecimationReport report;
  report.triangles_before = mesh.triangles.size();
  if (mesh.triangles.size() <= target_triangles) {
    report.triangles_after = mesh.triangles.size();
    return report;
  }
  Surface surface;
  std::vector<Surface::Vertex_index> vertex(mesh.vertices.size());
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
    vertex[i] = surface.add_vertex(
        Kernel::Point_3(mesh.vertices[i].x(), mesh.vertices[i].y(), mesh.vertices[i].z()));
  for (const auto& t : mesh.triangles)
    (void)surface.add_face(vertex[t[0]], vertex[t[1]], vertex[t[2]]);  // non-manifold: skipped
  surface.collect_garbage();
  // CGAL's Count_stop_predicate counts edges (about 1.5 per triangle), which left about two
  // thirds of the requested triangles; this one stops on the faces left.
  const auto stop = [&surface, target_triangles](const auto&, const auto&, std::size_t,
                                                 std::size_t) {
    return surface.number_of_faces() <= target_triangles;
  };
  SMS::GarlandHeckbert_plane_policies<Surface, Kernel> policies(surface);
  SMS::edge_collapse(surface, stop, CGAL::parameters::get_cost(policies.get_cost())
                                        .get_placement(policies.get_placement()));
  surface.collect_garbage();

  // Colours from the nearest original vertex.
  const KdTree tree(mesh.vertices);
  TriangleMesh out;
  std::vector<std::uint32_t> index(surface.number_of_vertices());
  std::uint32_t n = 0;
  for (auto v : surface.vertices()) {
    const auto& p = surface.point(v);
    const Eigen::Vector3f q(static_cast<float>(p.x()), static_cast<float>(p.y()),
                            static_cast<float>(p.z()));
    index[v.idx()] = n++;
    out.vertices.push_back(q);
    if (!mesh.vertex_colors.empty()) {
      Neighbor nn;
      tree.nearest(q, nn);
      out.vertex_colors.push_back(mesh.vertex_colors[nn.index]);
    }
  }
  for (auto f : surface.faces()) {
    std::array<std::uint32_t, 3> tri{};
    int j = 0;
    for (auto v : CGAL::vertices_around_face(surface.halfedge(f), surface))
      if (j < 3) tri[j++] = index[v.idx()];
    if (j == 3) out.triangles.push_back(tri);
  }
  mesh = std::move(out);
  report.triangles_after = mesh.triangles.size();
  return report;
}

}  // namespace locard
