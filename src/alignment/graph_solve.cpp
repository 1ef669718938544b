// Stage 4 of align_sequence: the pose graph (alignment_stages.hpp, sequential_alignment.hpp
// step 4). Pieces joined by a verified loop are first brought into one frame.
#include "alignment/alignment_stages.hpp"
#include "alignment/tripod_fit.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <map>

namespace locard::alignment_detail {
namespace {

void add_odometry_edges(AlignmentState& s, double info_distance) {
  const auto& reg = s.registered;
  PoseGraph& graph = s.result.graph;
  std::vector<Matrix6d> info(reg.size() ? reg.size() - 1 : 0);
  tbb::parallel_for(std::size_t{0}, info.size(), [&](std::size_t k) {
    const std::size_t a = reg[k], b = reg[k + 1];
    if (s.piece_of[a] != s.piece_of[b]) return;
    const Isometry3d T = graph.nodes[k].inverse() * graph.nodes[k + 1];
    info[k] = information_matrix(s.prepared[b].cloud, s.prepared[a].cloud, T, info_distance);
  });
  for (std::size_t k = 0; k + 1 < reg.size(); ++k) {
    if (s.piece_of[reg[k]] != s.piece_of[reg[k + 1]]) continue;
    PoseGraphEdge e;
    e.source = k + 1;
    e.target = k;
    e.T_target_source = graph.nodes[k].inverse() * graph.nodes[k + 1];
    e.information = info[k];
    if (e.information.trace() <= 0.0) e.information = Matrix6d::Identity();
    graph.edges.push_back(e);
  }
}

// Moves pieces into the frame of the earliest piece they connect to (breadth first).
void place_pieces(AlignmentState& s) {
  std::vector<char> placed(s.piece_count, 0);
  std::vector<Isometry3d> T_world_piece(s.piece_count, Isometry3d::Identity());
  for (std::size_t p = 0; p < s.piece_count; ++p) {
    if (placed[p]) continue;
    placed[p] = 1;
    bool grew = true;
    while (grew) {
      grew = false;
      for (const LoopCandidate& c : s.candidates) {
        if (!c.accepted) continue;
        const std::size_t pa = s.piece_of[c.target], pb = s.piece_of[c.source];
        if (pa == pb || placed[pa] == placed[pb]) continue;
        const bool target_placed = placed[pa];
        const std::size_t fixed = target_placed ? c.target : c.source;
        const std::size_t moving = target_placed ? c.source : c.target;
        const Isometry3d T_fixed = T_world_piece[s.piece_of[fixed]] * s.tracked_pose(fixed);
        const Isometry3d T_rel = target_placed ? c.T_target_source : c.T_target_source.inverse();
        const std::size_t q = s.piece_of[moving];
        T_world_piece[q] = T_fixed * T_rel * s.tracked_pose(moving).inverse();
        placed[q] = 1;
        grew = true;
      }
    }
  }
  for (std::size_t k = 0; k < s.registered.size(); ++k)
    s.result.graph.nodes[k] = T_world_piece[s.piece_of[s.registered[k]]] * s.result.graph.nodes[k];
}

LoopCandidate* candidate_of(AlignmentState& s, const std::vector<std::size_t>& node_of,
                            std::size_t source_node, std::size_t target_node) {
  for (LoopCandidate& c : s.candidates)
    if (c.accepted && node_of[c.source] == source_node && node_of[c.target] == target_node)
      return &c;
  return nullptr;
}

void accumulate(PoseGraphResult& total, const PoseGraphResult& pr) {
  total.success = (total.solves == 0 || total.success) && pr.success;
  if (!pr.success) total.reason = pr.reason;
  total.initial_cost += pr.initial_cost;
  total.final_cost += pr.final_cost;
  total.solves += pr.solves;
  total.iterations += pr.iterations;
  total.mu = std::max(total.mu, pr.mu);
  total.max_odometry_bend_deg = std::max(total.max_odometry_bend_deg, pr.max_odometry_bend_deg);
  total.max_odometry_bend_m = std::max(total.max_odometry_bend_m, pr.max_odometry_bend_m);
}

// Tripod post-check: loop edges registered without the tripod may slide along walls, and a
// solve that follows them moves views off the tripod the hold stage put them on. Such a
// solution is worse than the tracked poses: the hold stage's bounds (tripod_fit.hpp).

bool bends_tripod(const std::vector<Isometry3d>& before, const std::vector<Isometry3d>& after) {
  const auto was = views_off_tripod(before, kOnRingDeg, kOnTripodM);
  if (!was) return false;
  const auto now = views_off_tripod(after, kOnRingDeg, kOnTripodM);
  return !now || *now > *was;
}

}  // namespace

void solve_graph(AlignmentState& s) {
  const AlignmentOptions& o = s.options;
  AlignmentResult& result = s.result;
  const auto& reg = s.registered;
  std::vector<std::size_t> node_of(s.n, SIZE_MAX);
  for (std::size_t k = 0; k < reg.size(); ++k) {
    node_of[reg[k]] = k;
    result.node_frames.push_back(reg[k]);
    result.graph.nodes.push_back(s.tracked_pose(reg[k]));
  }
  const double info_distance = 1.5 * o.voxel_size;
  add_odometry_edges(s, info_distance);
  place_pieces(s);
  for (LoopCandidate& c : s.candidates) {
    if (!c.accepted) continue;
    PoseGraphEdge e;
    e.source = node_of[c.source];
    e.target = node_of[c.target];
    e.T_target_source = c.T_target_source;
    e.information = information_matrix(s.prepared[c.source].cloud, s.prepared[c.target].cloud,
                                       c.T_target_source, info_distance);
    e.uncertain = true;
    c.chi2_before = edge_chi2(e, result.graph.nodes);
    result.graph.edges.push_back(e);
  }
  // Solve each connected component with its first node fixed.
  Components components(reg.size());
  for (const PoseGraphEdge& e : result.graph.edges) components.unite(e.source, e.target);
  std::map<std::size_t, std::vector<std::size_t>> members;
  for (std::size_t k = 0; k < reg.size(); ++k) members[components.find(k)].push_back(k);
  PoseGraph solved;
  solved.nodes = result.graph.nodes;
  for (const auto& [root, nodes] : members) {
    PoseGraph sub;
    std::vector<std::size_t> local(reg.size(), SIZE_MAX);
    for (std::size_t k : nodes) {
      local[k] = sub.nodes.size();
      sub.nodes.push_back(result.graph.nodes[k]);
    }
    for (const PoseGraphEdge& e : result.graph.edges) {
      if (local[e.source] == SIZE_MAX) continue;
      PoseGraphEdge le = e;
      le.source = local[e.source];
      le.target = local[e.target];
      sub.edges.push_back(le);
    }
    const std::vector<Isometry3d> tracked = sub.nodes;
    std::vector<PoseGraphEdge> edges = sub.edges;
    PoseGraphResult pr = optimize_pose_graph(sub, o.pose_graph);
    const bool one_piece = std::all_of(nodes.begin(), nodes.end(), [&](std::size_t k) {
      return s.piece_of[reg[k]] == s.piece_of[reg[nodes.front()]];
    });
    if (o.mode == AlignmentMode::Cumulative && one_piece && bends_tripod(tracked, sub.nodes)) {
      // Back to the tracked turn: every loop edge of the component is reported rejected.
      sub.nodes = tracked;
      sub.edges.clear();
      for (PoseGraphEdge& e : edges) {
        if (!e.uncertain) {
          e.confidence = 1.0;
          sub.edges.push_back(e);
          continue;
        }
        pr.rejected.push_back({e, "the solution moved views off the tripod the tracked turn "
                                  "keeps them on"});
      }
    }
    for (std::size_t k = 0; k < nodes.size(); ++k) solved.nodes[nodes[k]] = sub.nodes[k];
    for (const PoseGraphEdge& e : sub.edges) {
      PoseGraphEdge g = e;
      g.source = nodes[e.source];
      g.target = nodes[e.target];
      if (e.uncertain)
        if (LoopCandidate* c = candidate_of(s, node_of, g.source, g.target)) {
          c->chi2_after = e.chi2;
          c->confidence = e.confidence;
        }
      solved.edges.push_back(g);
    }
    for (RejectedEdge r : pr.rejected) {
      r.edge.source = nodes[r.edge.source];
      r.edge.target = nodes[r.edge.target];
      if (LoopCandidate* c = candidate_of(s, node_of, r.edge.source, r.edge.target)) {
        c->accepted = false;
        c->reason = "pose graph: " + r.reason;
        c->confidence = r.edge.confidence;
        c->chi2_after = r.edge.chi2;
      }
      result.pose_graph.rejected.push_back(std::move(r));
    }
    accumulate(result.pose_graph, pr);
  }
  if (reg.empty()) result.pose_graph.success = true;
  for (PoseGraphEdge& e : solved.edges)
    if (!e.uncertain) e.confidence = 1.0;
  result.graph = std::move(solved);
  for (LoopCandidate& c : s.candidates)
    if (c.accepted && c.confidence <= 0.0) c.confidence = 1.0;

  // Pieces after loop closure: connected components of the kept graph, numbered by first frame.
  Components kept(reg.size());
  for (const PoseGraphEdge& e : result.graph.edges) kept.unite(e.source, e.target);
  std::map<std::size_t, std::size_t> piece_id;
  for (std::size_t k = 0; k < reg.size(); ++k) {
    auto [it, inserted] = piece_id.emplace(kept.find(k), piece_id.size());
    FrameAlignment& f = result.frames[reg[k]];
    f.piece = it->second;
    f.T_world_camera_final = result.graph.nodes[k];
  }
  result.pieces = piece_id.size();
}

}  // namespace locard::alignment_detail
