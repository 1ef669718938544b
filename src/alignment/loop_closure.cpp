// Stage 3 of align_sequence: loop candidates and their verification (alignment_stages.hpp,
// sequential_alignment.hpp step 3).
#include "alignment/alignment_stages.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <map>
#include <optional>
#include <set>
#include <utility>

namespace locard::alignment_detail {
namespace {

std::vector<std::size_t> loop_keyframes(const AlignmentState& s) {
  const AlignmentOptions& o = s.options;
  std::vector<std::size_t> keyframes;
  const auto& reg = s.registered;
  for (std::size_t k = 0; k < reg.size(); ++k) {
    const bool piece_edge = k == 0 || k + 1 == reg.size() ||
                            s.piece_of[reg[k]] != s.piece_of[reg[k - 1]] ||
                            s.piece_of[reg[k]] != s.piece_of[reg[k + 1]];
    if (o.mode == AlignmentMode::Cumulative || piece_edge || k % o.keyframe_interval == 0)
      keyframes.push_back(reg[k]);
  }
  return keyframes;
}

// The nearest few earlier keyframes of each keyframe, so that the candidates spread over the
// whole sequence instead of crowding where the camera lingered.
std::vector<LoopCandidate> proximity_candidates(const AlignmentState& s,
                                                const std::vector<std::size_t>& keyframes) {
  const AlignmentOptions& o = s.options;
  // Pairs closer in the sequence than the local model's span are already tied together by
  // tracking; only pairs beyond it can remove drift.
  const std::size_t separation =
      o.mode == AlignmentMode::Odometry
          ? std::max(o.loop_min_separation, o.local_model_frames * o.keyframe_interval)
          : o.loop_min_separation;
  std::vector<std::pair<double, LoopCandidate>> near;
  const auto by_score = [](const auto& x, const auto& y) { return x.first < y.first; };
  for (std::size_t b = 0; b < keyframes.size(); ++b) {
    std::vector<std::pair<double, LoopCandidate>> mine;
    for (std::size_t a = 0; a < b; ++a) {
      const std::size_t i = keyframes[a], j = keyframes[b];
      if (s.piece_of[i] != s.piece_of[j] || j - i < separation) continue;
      const Isometry3d& Ti = s.tracked_pose(i);
      const Isometry3d& Tj = s.tracked_pose(j);
      const double d = (Ti.translation() - Tj.translation()).norm();
      const double ang = angle_deg(forward(Ti), forward(Tj));
      if (d > o.loop_max_distance_m || ang > o.loop_max_angle_deg) continue;
      LoopCandidate c;
      c.source = j;
      c.target = i;
      c.found_by = LoopSource::Proximity;
      c.T_target_source = Ti.inverse() * Tj;
      mine.emplace_back(d / o.loop_max_distance_m + ang / o.loop_max_angle_deg, c);
    }
    std::stable_sort(mine.begin(), mine.end(), by_score);
    if (mine.size() > o.loop_candidates_per_keyframe) mine.resize(o.loop_candidates_per_keyframe);
    near.insert(near.end(), mine.begin(), mine.end());
  }
  std::stable_sort(near.begin(), near.end(), by_score);
  if (near.size() > o.max_loop_candidates) near.resize(o.max_loop_candidates);
  std::vector<LoopCandidate> out;
  for (auto& [score, c] : near) out.push_back(std::move(c));
  return out;
}

// First and last keyframe of each piece (a turn's first/last overlap, found even after large
// drift), and the ends of different pieces.
std::vector<std::pair<std::size_t, std::size_t>> piece_end_pairs(const AlignmentState& s) {
  std::map<std::size_t, std::pair<std::size_t, std::size_t>> ends;  // piece -> first, last
  for (std::size_t k : s.registered) {
    auto [it, inserted] = ends.emplace(s.piece_of[k], std::make_pair(k, k));
    if (!inserted) it->second.second = k;
  }
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (const auto& [p, fl] : ends) {
    if (fl.second - fl.first >= s.options.loop_min_separation)
      pairs.emplace_back(fl.first, fl.second);
    for (const auto& [q, gl] : ends)
      if (q > p) {
        pairs.emplace_back(fl.first, gl.first);
        pairs.emplace_back(fl.second, gl.first);
      }
  }
  return pairs;
}

}  // namespace

void propose_loops(AlignmentState& s) {
  s.candidates.clear();
  if (!s.options.loop_closure) return;
  const std::vector<std::size_t> keyframes = loop_keyframes(s);
  std::set<std::pair<std::size_t, std::size_t>> seen;  // (target, source)
  for (LoopCandidate& c : proximity_candidates(s, keyframes)) {
    seen.emplace(c.target, c.source);
    s.candidates.push_back(std::move(c));
  }
  for (const auto& [i, j] : piece_end_pairs(s)) {
    if (!seen.emplace(i, j).second) continue;
    LoopCandidate c;
    c.source = j;
    c.target = i;
    c.found_by = LoopSource::Features;
    s.candidates.push_back(std::move(c));
  }
}

// Parallel over candidates; each is independent and seeded by its pair.
void verify_loops(AlignmentState& s) {
  const AlignmentOptions& o = s.options;
  const IcpMethod method = tracking_method(o);
  tbb::parallel_for(std::size_t{0}, s.candidates.size(), [&](std::size_t k) {
    LoopCandidate& c = s.candidates[k];
    const PointCloud& src = s.prepared[c.source].cloud;
    const PointCloud& src_coarse = s.prepared[c.source].coarse;
    Target tgt;
    tgt.fine = s.prepared[c.target].cloud;
    tgt.coarse = s.prepared[c.target].coarse;
    std::optional<IcpResult> best;
    if (c.found_by == LoopSource::Proximity) best = refine(src, src_coarse, tgt, c.T_target_source, o, method);
    if (c.found_by == LoopSource::Features) {
      const auto g =
          features(src, tgt.fine, Eigen::Vector3f::Zero(), o, 1000003 * c.source + c.target);
      if (!g.ransac.success) {
        c.reason = "feature registration failed: " + g.ransac.reason;
        return;
      }
      best = refine(src, src_coarse, tgt, g.ransac.T_target_source, o, method);
    }
    c.fitness = best->fitness;
    c.inlier_rmse = best->inlier_rmse;
    if (!acceptable(*best, o, o.loop_min_fitness)) {
      c.reason = "verification: " + rejection(*best, o, o.loop_min_fitness);
      return;
    }
    c.T_target_source = best->T_target_source;
    c.accepted = true;  // provisionally: the pose graph may still reject it
  });
}

}  // namespace locard::alignment_detail
