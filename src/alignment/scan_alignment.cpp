// Multiway registration of range scans (see scan_alignment.hpp; the numbered comments follow
// its numbered steps). Each step is a function over ScanAlignmentState.
#include <locard/alignment/scan_alignment.hpp>

#include <locard/core/disjoint_sets.hpp>
#include <locard/core/error.hpp>
#include <locard/core/kdtree.hpp>
#include <locard/preprocess/normals.hpp>
#include <locard/preprocess/voxel_grid.hpp>
#include <locard/registration/global_registration.hpp>
#include <locard/registration/icp.hpp>

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>

namespace locard {
namespace {

struct ScanAlignmentState {
  const ScanAlignmentOptions& o;
  const std::vector<std::optional<Isometry3d>>& initial;
  std::vector<PointCloud> clouds;  // thinned, with normals
  ScanAlignmentResult result;
  std::vector<std::size_t> node_of;  // scan -> graph node (SIZE_MAX: none)
};

// Point-to-plane ICP over the given gates (each level starts from the previous estimate), the
// target prepared once for all of them.
IcpResult icp_gates(const PointCloud& source, const PointCloud& target, const Isometry3d& init,
                    const std::vector<double>& gates) {
  IcpOptions o;
  o.method = IcpMethod::PointToPlane;
  o.min_fitness = 0.0;  // acceptance is decided by the caller
  const IcpTarget prepared(target, o);
  std::vector<IcpLevel> levels;
  for (double gate : gates)
    levels.push_back({fmt::format("gate {} m", gate), &source, &target, &prepared,
                      IcpMethod::PointToPlane, gate, 40, false});
  return icp_levels(levels, init, o);
}

void check_inputs(const std::vector<PointCloud>& scans, const ScanAlignmentOptions& o,
                  const std::vector<std::optional<Isometry3d>>& initial) {
  const std::size_t n = scans.size();
  if (n < 2) throw InputError(fmt::format("scan alignment needs at least two scans, got {}", n));
  if (!initial.empty() && initial.size() != n)
    throw InputError(fmt::format("scan alignment: {} initial poses for {} scans", initial.size(), n));
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
}

// 1. Thinned scans with normals towards their sensor (the origin of each scan's frame).
void thin_scans(ScanAlignmentState& s, const std::vector<PointCloud>& scans) {
  s.clouds.resize(scans.size());
  tbb::parallel_for(std::size_t{0}, scans.size(), [&](std::size_t i) {
    s.clouds[i] = voxel_down_sample(scans[i], static_cast<float>(s.o.voxel_size)).cloud;
    NormalOptions nopt;
    nopt.radius = static_cast<float>(2.5 * s.o.voxel_size);
    nopt.max_neighbors = 30;
    estimate_normals(s.clouds[i], nopt);
  });
}

bool posed(const ScanAlignmentState& s, std::size_t i) {
  return !s.initial.empty() && s.initial[i].has_value();
}

// Whether two posed scans' boxes in the input's frame, grown by `margin`, meet.
bool boxes_meet(const ScanAlignmentState& s, std::size_t i, std::size_t j, double margin) {
  Eigen::AlignedBox3d a, b;
  for (const Eigen::Vector3f& p : s.clouds[i].positions) a.extend(*s.initial[i] * p.cast<double>());
  for (const Eigen::Vector3f& p : s.clouds[j].positions) b.extend(*s.initial[j] * p.cast<double>());
  a.min().array() -= margin;
  a.max().array() += margin;
  return a.intersects(b);
}

// 2. One pair: the initial T_target_source (input poses or features), then ICP with the
// smaller scan as the source.
void register_pair(const ScanAlignmentState& s, ScanPair& p) {
  const ScanAlignmentOptions& o = s.o;
  const bool swap = s.clouds[p.source].size() > s.clouds[p.target].size();
  const PointCloud& src = swap ? s.clouds[p.target] : s.clouds[p.source];
  const PointCloud& tgt = swap ? s.clouds[p.source] : s.clouds[p.target];
  Isometry3d init;
  if (posed(s, p.source) && posed(s, p.target)) {
    if (!boxes_meet(s, p.source, p.target, o.icp_gates.front())) {
      p.reason = "no overlap at the input's poses";
      return;
    }
    const Isometry3d T_t_s = s.initial[p.target]->inverse() * *s.initial[p.source];
    init = swap ? T_t_s.inverse() : T_t_s;
  } else {
    GlobalRegistrationOptions g;
    g.voxel_size = o.feature_voxel_size;
    g.ransac.seed = o.seed + 1000003 * p.source + p.target;
    const GlobalRegistrationResult gr = global_registration(src, tgt, g);
    if (!gr.ransac.success) {
      p.reason = "feature registration failed: " + gr.ransac.reason;
      return;
    }
    init = gr.ransac.T_target_source;
  }
  const IcpResult r = icp_gates(src, tgt, init, o.icp_gates);
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
}

void register_pairs(ScanAlignmentState& s) {
  const std::size_t n = s.clouds.size();
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      ScanPair p;
      p.target = i;
      p.source = j;
      s.result.pairs.push_back(p);
    }
  tbb::parallel_for(std::size_t{0}, s.result.pairs.size(),
                    [&](std::size_t k) { register_pair(s, s.result.pairs[k]); });
}

// The root: the lowest index of the largest set the verified pairs connect.
std::size_t choose_root(const ScanAlignmentState& s) {
  const std::size_t n = s.clouds.size();
  DisjointSets sets(n);
  for (const ScanPair& p : s.result.pairs)
    if (p.verified) sets.unite(p.source, p.target);
  std::vector<std::size_t> size(n, 0);
  for (std::size_t i = 0; i < n; ++i) ++size[sets.find(i)];
  std::size_t best = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (size[i] > size[best]) best = i;  // roots are their set's lowest index
  return best;
}

// 3. Maximum spanning tree (Kruskal, highest fitness first; ties by pair order), walked from
// the root.
void place_by_tree(ScanAlignmentState& s) {
  ScanAlignmentResult& result = s.result;
  const std::size_t n = s.clouds.size();
  std::vector<std::size_t> order;
  for (std::size_t k = 0; k < result.pairs.size(); ++k)
    if (result.pairs[k].verified) order.push_back(k);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return result.pairs[a].fitness > result.pairs[b].fitness;
  });
  DisjointSets sets(n);
  std::vector<std::vector<std::size_t>> tree_pairs(n);
  for (std::size_t k : order) {
    ScanPair& p = result.pairs[k];
    if (sets.find(p.source) == sets.find(p.target)) continue;
    sets.unite(p.source, p.target);
    p.in_tree = true;
    tree_pairs[p.source].push_back(k);
    tree_pairs[p.target].push_back(k);
  }
  result.root = choose_root(s);
  const bool input_frame = !s.initial.empty() &&
                           std::all_of(s.initial.begin(), s.initial.end(),
                                       [](const auto& T) { return T.has_value(); });
  result.T_world_scan.assign(n, Isometry3d::Identity());
  if (input_frame) result.T_world_scan[result.root] = *s.initial[result.root];
  result.placed.assign(n, 0);
  result.placed[result.root] = 1;
  std::vector<std::size_t> queue = {result.root};
  for (std::size_t q = 0; q < queue.size(); ++q) {
    const std::size_t at = queue[q];
    for (std::size_t k : tree_pairs[at]) {
      const ScanPair& p = result.pairs[k];
      const std::size_t other = p.source == at ? p.target : p.source;
      if (result.placed[other]) continue;
      // T_w_target = T_w_source * T_t_s^-1 and T_w_source = T_w_target * T_t_s.
      result.T_world_scan[other] = p.source == at
                                       ? result.T_world_scan[at] * p.T_target_source.inverse()
                                       : result.T_world_scan[at] * p.T_target_source;
      result.placed[other] = 1;
      queue.push_back(other);
    }
  }
}

// 4. Pose graph over the placed scans.
void solve_pose_graph(ScanAlignmentState& s) {
  ScanAlignmentResult& result = s.result;
  const std::size_t n = s.clouds.size();
  s.node_of.assign(n, SIZE_MAX);
  PoseGraph& graph = result.graph;
  for (std::size_t i = 0; i < n; ++i)
    if (result.placed[i]) {
      s.node_of[i] = graph.nodes.size();
      result.graph_scans.push_back(i);
      graph.nodes.push_back(result.T_world_scan[i]);
    }
  std::vector<std::size_t> edge_pair;
  for (std::size_t k = 0; k < result.pairs.size(); ++k) {
    const ScanPair& p = result.pairs[k];
    if (!p.verified || !result.placed[p.source] || !result.placed[p.target]) continue;
    PoseGraphEdge e;
    e.source = s.node_of[p.source];
    e.target = s.node_of[p.target];
    e.T_target_source = p.T_target_source;
    e.uncertain = !p.in_tree;
    graph.edges.push_back(e);
    edge_pair.push_back(k);
  }
  tbb::parallel_for(std::size_t{0}, graph.edges.size(), [&](std::size_t k) {
    PoseGraphEdge& e = graph.edges[k];
    e.information = information_matrix(s.clouds[result.graph_scans[e.source]],
                                       s.clouds[result.graph_scans[e.target]], e.T_target_source,
                                       s.o.icp_gates.back());
    if (e.information.trace() <= 0.0) e.information = Matrix6d::Identity();
  });
  PoseGraphOptions pg = s.o.pose_graph;
  pg.fixed_node = s.node_of[result.root];
  result.pose_graph = optimize_pose_graph(graph, pg);
  for (std::size_t k : edge_pair) result.pairs[k].kept = true;
  for (const RejectedEdge& r : result.pose_graph.rejected)
    for (std::size_t k : edge_pair) {
      ScanPair& p = result.pairs[k];
      if (s.node_of[p.source] == r.edge.source && s.node_of[p.target] == r.edge.target) {
        p.kept = false;
        p.reason = "pose graph: " + r.reason;
      }
    }
  for (std::size_t k = 0; k < result.graph_scans.size(); ++k)
    result.T_world_scan[result.graph_scans[k]] = graph.nodes[k];
}

// The other placed scans at their current poses, as one cloud.
PointCloud others_of(const ScanAlignmentState& s, std::size_t i) {
  PointCloud others;
  for (std::size_t j = 0; j < s.clouds.size(); ++j)
    if (j != i && s.result.placed[j]) others.append(transformed(s.clouds[j], s.result.T_world_scan[j]));
  return others;
}

// 5. Multi-view refinement: each scan against all the others.
void refine(ScanAlignmentState& s) {
  const std::vector<double>& gates = s.o.icp_gates;
  const std::vector<double> fine_gates(
      gates.end() - static_cast<std::ptrdiff_t>(std::min<std::size_t>(2, gates.size())), gates.end());
  for (int round = 0; round < s.o.refine_rounds; ++round)
    for (std::size_t i = 0; i < s.clouds.size(); ++i) {
      if (!s.result.placed[i] || i == s.result.root) continue;
      const IcpResult r = icp_gates(s.clouds[i], others_of(s, i), s.result.T_world_scan[i], fine_gates);
      if (r.success && r.fitness >= s.o.min_fitness && r.inlier_rmse <= s.o.max_inlier_rmse)
        s.result.T_world_scan[i] = r.T_target_source;
    }
}

// 6. Per-scan fit at the final poses (no iteration: the residuals as they are).
void measure_fit(ScanAlignmentState& s) {
  s.result.fit.assign(s.clouds.size(), ScanFit{});
  tbb::parallel_for(std::size_t{0}, s.clouds.size(), [&](std::size_t i) {
    if (!s.result.placed[i]) return;
    const PointCloud others = others_of(s, i);
    if (others.empty()) return;
    const KdTree tree(others.positions);
    const float gate = static_cast<float>(s.o.icp_gates.back());
    std::size_t inliers = 0;
    double sum2 = 0.0;
    for (const Eigen::Vector3f& p : s.clouds[i].positions) {
      Neighbor nb;
      if (!tree.nearest((s.result.T_world_scan[i] * p.cast<double>()).cast<float>(), nb, gate)) continue;
      ++inliers;
      sum2 += nb.squared_distance;
    }
    ScanFit& f = s.result.fit[i];
    f.fitness = static_cast<double>(inliers) / static_cast<double>(s.clouds[i].size());
    f.inlier_rmse = inliers ? std::sqrt(sum2 / static_cast<double>(inliers)) : 0.0;
  });
}

}  // namespace

ScanAlignmentOptions scan_alignment_options_for_spacing(double spacing) {
  const double k = spacing / 0.0006;  // the defaults hold at 0.6 mm
  ScanAlignmentOptions o;
  o.voxel_size *= k;
  o.feature_voxel_size *= k;
  for (double& g : o.icp_gates) g *= k;
  o.max_inlier_rmse *= k;
  o.pose_graph.max_correspondence_distance *= k;
  return o;
}

double median_point_spacing(const std::vector<PointCloud>& scans, std::size_t samples) {
  std::vector<double> d;
  for (const PointCloud& scan : scans) {
    if (scan.size() < 2) continue;
    const KdTree tree(scan.positions);
    const std::size_t step = std::max<std::size_t>(1, scan.size() / samples);
    std::vector<Neighbor> nb;
    for (std::size_t i = 0; i < scan.size(); i += step)
      if (tree.knn(scan.positions[i], 2, nb) == 2) d.push_back(std::sqrt(nb[1].squared_distance));
  }
  if (d.empty()) return 0.0;
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

ScanAlignmentResult align_scans(const std::vector<PointCloud>& scans, const ScanAlignmentOptions& o,
                                const std::vector<std::optional<Isometry3d>>& initial) {
  const auto start = std::chrono::steady_clock::now();
  check_inputs(scans, o, initial);
  ScanAlignmentState s{o, initial, {}, {}, {}};
  thin_scans(s, scans);
  register_pairs(s);
  place_by_tree(s);
  solve_pose_graph(s);
  refine(s);
  measure_fit(s);
  s.result.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return std::move(s.result);
}

}  // namespace locard
