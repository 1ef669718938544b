// Multiway registration of range scans (see scan_alignment.hpp; the numbered comments follow
// its numbered steps).
#include <locard/alignment/scan_alignment.hpp>

#include <locard/core/error.hpp>
#include <locard/preprocess/normals.hpp>
#include <locard/preprocess/voxel_grid.hpp>
#include <locard/registration/global_registration.hpp>
#include <locard/registration/icp.hpp>

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>

namespace locard {
namespace {

// Point-to-plane ICP over the given gates (each level starts from the previous estimate).
IcpResult icp_gates(const PointCloud& source, const PointCloud& target, const Isometry3d& init,
                    const std::vector<double>& gates) {
  IcpOptions o;
  o.method = IcpMethod::PointToPlane;
  o.min_fitness = 0.0;  // acceptance is decided by the caller
  o.convergence.max_iterations = 40;
  Isometry3d T = init;
  IcpResult r;
  int iterations = 0;
  for (double gate : gates) {
    o.max_correspondence_distance = gate;
    r = icp(source, target, T, o);
    iterations += r.iterations;
    if (!r.success) {
      r.reason = fmt::format("gate {} m: {}", gate, r.reason);
      break;
    }
    T = r.T_target_source;
  }
  r.iterations = iterations;
  return r;
}

// Union-find over scan indices.
std::size_t find_root(std::vector<std::size_t>& parent, std::size_t x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

}  // namespace

ScanAlignmentResult align_scans(const std::vector<PointCloud>& scans,
                                const ScanAlignmentOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  const std::size_t n = scans.size();
  if (n < 2) throw InputError(fmt::format("scan alignment needs at least two scans, got {}", n));
  if (!(o.voxel_size > 0.0) || !(o.feature_voxel_size > 0.0))
    throw InputError(fmt::format("scan alignment: voxel sizes must be positive (voxel_size {}, "
                                 "feature_voxel_size {})",
                                 o.voxel_size, o.feature_voxel_size));
  if (o.icp_gates.empty() ||
      std::any_of(o.icp_gates.begin(), o.icp_gates.end(), [](double g) { return !(g > 0.0); }))
    throw InputError("scan alignment: icp_gates must be a non-empty list of positive distances");
  for (std::size_t i = 0; i < n; ++i)
    if (scans[i].size() < 6)
      throw InputError(fmt::format("scan alignment: scan {} has {} points (at least 6 needed)", i,
                                   scans[i].size()));

  // 1. Thinned scans with normals towards their sensor (the origin of each scan's frame).
  std::vector<PointCloud> clouds(n);
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
    clouds[i] = voxel_down_sample(scans[i], static_cast<float>(o.voxel_size)).cloud;
    NormalOptions nopt;
    nopt.radius = static_cast<float>(2.5 * o.voxel_size);
    nopt.max_neighbors = 30;
    estimate_normals(clouds[i], nopt);
  });

  // 2. Every pair: features, then ICP with the smaller scan as the source.
  ScanAlignmentResult result;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      ScanPair p;
      p.target = i;
      p.source = j;
      result.pairs.push_back(p);
    }
  tbb::parallel_for(std::size_t{0}, result.pairs.size(), [&](std::size_t k) {
    ScanPair& p = result.pairs[k];
    const bool swap = clouds[p.source].size() > clouds[p.target].size();
    const PointCloud& src = swap ? clouds[p.target] : clouds[p.source];
    const PointCloud& tgt = swap ? clouds[p.source] : clouds[p.target];
    GlobalRegistrationOptions g;
    g.voxel_size = o.feature_voxel_size;
    g.ransac.seed = o.seed + 1000003 * p.source + p.target;
    const GlobalRegistrationResult gr = global_registration(src, tgt, g);
    if (!gr.ransac.success) {
      p.reason = "feature registration failed: " + gr.ransac.reason;
      return;
    }
    const IcpResult r = icp_gates(src, tgt, gr.ransac.T_target_source, o.icp_gates);
    p.fitness = r.fitness;
    p.inlier_rmse = r.inlier_rmse;
    p.T_target_source = swap ? r.T_target_source.inverse() : r.T_target_source;
    if (!r.success) {
      p.reason = "ICP failed: " + r.reason;
      return;
    }
    if (r.fitness < o.min_fitness || r.inlier_rmse > o.max_inlier_rmse) {
      p.reason = fmt::format("ICP fitness {:.3f} (need >= {:.2f}), inlier RMSE {:.5f} m (need "
                             "<= {:.5f})",
                             r.fitness, o.min_fitness, r.inlier_rmse, o.max_inlier_rmse);
      return;
    }
    p.verified = true;
  });

  // 3. Maximum spanning tree (Kruskal, highest fitness first; ties by pair order).
  std::vector<std::size_t> order;
  for (std::size_t k = 0; k < result.pairs.size(); ++k)
    if (result.pairs[k].verified) order.push_back(k);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return result.pairs[a].fitness > result.pairs[b].fitness;
  });
  std::vector<std::size_t> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  std::vector<std::vector<std::size_t>> tree_pairs(n);
  for (std::size_t k : order) {
    ScanPair& p = result.pairs[k];
    const std::size_t a = find_root(parent, p.source), b = find_root(parent, p.target);
    if (a == b) continue;
    parent[std::max(a, b)] = std::min(a, b);
    p.in_tree = true;
    tree_pairs[p.source].push_back(k);
    tree_pairs[p.target].push_back(k);
  }
  result.T_world_scan.assign(n, Isometry3d::Identity());
  result.placed.assign(n, 0);
  result.placed[0] = 1;
  std::vector<std::size_t> queue = {0};
  for (std::size_t q = 0; q < queue.size(); ++q) {
    const std::size_t s = queue[q];
    for (std::size_t k : tree_pairs[s]) {
      const ScanPair& p = result.pairs[k];
      const std::size_t other = p.source == s ? p.target : p.source;
      if (result.placed[other]) continue;
      // T_w_target = T_w_source * T_t_s^-1 and T_w_source = T_w_target * T_t_s.
      result.T_world_scan[other] = p.source == s
                                       ? result.T_world_scan[s] * p.T_target_source.inverse()
                                       : result.T_world_scan[s] * p.T_target_source;
      result.placed[other] = 1;
      queue.push_back(other);
    }
  }

  // 4. Pose graph over the placed scans.
  std::vector<std::size_t> node_of(n, SIZE_MAX), scan_of;
  PoseGraph graph;
  for (std::size_t i = 0; i < n; ++i)
    if (result.placed[i]) {
      node_of[i] = graph.nodes.size();
      scan_of.push_back(i);
      graph.nodes.push_back(result.T_world_scan[i]);
    }
  std::vector<std::size_t> edge_pair;
  for (std::size_t k = 0; k < result.pairs.size(); ++k) {
    const ScanPair& p = result.pairs[k];
    if (!p.verified || !result.placed[p.source] || !result.placed[p.target]) continue;
    PoseGraphEdge e;
    e.source = node_of[p.source];
    e.target = node_of[p.target];
    e.T_target_source = p.T_target_source;
    e.uncertain = !p.in_tree;
    graph.edges.push_back(e);
    edge_pair.push_back(k);
  }
  tbb::parallel_for(std::size_t{0}, graph.edges.size(), [&](std::size_t k) {
    PoseGraphEdge& e = graph.edges[k];
    e.information = information_matrix(clouds[scan_of[e.source]], clouds[scan_of[e.target]],
                                       e.T_target_source, o.icp_gates.back());
    if (e.information.trace() <= 0.0) e.information = Matrix6d::Identity();
  });
  PoseGraphOptions pg = o.pose_graph;
  pg.fixed_node = 0;
  result.pose_graph = optimize_pose_graph(graph, pg);
  for (std::size_t k = 0; k < edge_pair.size(); ++k) result.pairs[edge_pair[k]].kept = true;
  for (const RejectedEdge& r : result.pose_graph.rejected)
    for (std::size_t k : edge_pair) {
      ScanPair& p = result.pairs[k];
      if (node_of[p.source] == r.edge.source && node_of[p.target] == r.edge.target) {
        p.kept = false;
        p.reason = "pose graph: " + r.reason;
      }
    }
  for (std::size_t k = 0; k < scan_of.size(); ++k) result.T_world_scan[scan_of[k]] = graph.nodes[k];

  // 5. Multi-view refinement: each scan against all the others.
  const std::vector<double> fine_gates(
      o.icp_gates.end() - static_cast<std::ptrdiff_t>(std::min<std::size_t>(2, o.icp_gates.size())),
      o.icp_gates.end());
  for (int round = 0; round < o.refine_rounds; ++round)
    for (std::size_t i = 1; i < n; ++i) {
      if (!result.placed[i]) continue;
      PointCloud others;
      for (std::size_t j = 0; j < n; ++j)
        if (j != i && result.placed[j]) others.append(transformed(clouds[j], result.T_world_scan[j]));
      const IcpResult r = icp_gates(clouds[i], others, result.T_world_scan[i], fine_gates);
      if (r.success && r.fitness >= o.min_fitness && r.inlier_rmse <= o.max_inlier_rmse)
        result.T_world_scan[i] = r.T_target_source;
    }
  result.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace locard
