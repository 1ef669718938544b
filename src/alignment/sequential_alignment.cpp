// Sequential alignment, loop closure and pose graph (see sequential_alignment.hpp for the
// scheme; the numbered comments below follow its numbered steps).
#include <locard/alignment/sequential_alignment.hpp>

#include <locard/core/error.hpp>
#include <locard/preprocess/depth_to_points.hpp>
#include <locard/preprocess/normals.hpp>
#include <locard/preprocess/voxel_grid.hpp>
#include <locard/registration/global_registration.hpp>
#include <locard/registration/icp.hpp>

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <numeric>
#include <set>

namespace locard {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

struct PreparedFrame {
  PointCloud cloud;   // camera frame, voxel grid, normals towards the sensor, colours
  PointCloud coarse;  // the same at twice the voxel size (first ICP level)
  std::string unusable;  // non-empty: why this frame cannot be used
};

PreparedFrame prepare_frame(const RgbdSequence& sequence, std::size_t index,
                            const AlignmentOptions& o) {
  PreparedFrame f;
  const RgbdFrame frame = sequence.load_frame(index);
  DepthToPointsOptions dopt;
  dopt.min_depth_m = o.min_depth_m;
  dopt.max_depth_m = o.max_depth_m;
  dopt.stride = o.stride;
  const PointCloud raw = depth_to_points(frame, dopt);
  if (raw.size() < o.min_frame_points) {
    f.unusable = fmt::format("only {} depth pixels in [{}, {}] m at stride {} (at least {} "
                             "needed): blank, covered or out of range",
                             raw.size(), o.min_depth_m, o.max_depth_m, o.stride,
                             o.min_frame_points);
    return f;
  }
  f.cloud = voxel_down_sample(raw, static_cast<float>(o.voxel_size)).cloud;
  if (f.cloud.size() < o.min_frame_points / 4 + 6) {
    f.unusable = fmt::format("only {} points after the {} m voxel grid", f.cloud.size(),
                             o.voxel_size);
    return f;
  }
  NormalOptions nopt;
  nopt.radius = static_cast<float>(2.5 * o.voxel_size);
  nopt.max_neighbors = 30;
  estimate_normals(f.cloud, nopt);
  f.coarse = voxel_down_sample(f.cloud, static_cast<float>(2.0 * o.voxel_size)).cloud;
  return f;
}

// A registration target at two resolutions (the coarse one is made once per model update).
struct Target {
  PointCloud fine;
  PointCloud coarse;
};

Target make_target(PointCloud fine, double voxel_size) {
  Target t;
  t.coarse = voxel_down_sample(fine, static_cast<float>(2.0 * voxel_size)).cloud;
  t.fine = std::move(fine);
  return t;
}

// ICP of a frame (camera frame) against a target, coarse to fine (header, step 2): point to
// plane at 2v with a 4v gate, then at v with gates 2v and v; the last level uses `method`
// (coloured in odometry mode), so the colour gradients are fitted once per frame.
IcpResult refine(const PointCloud& source_fine, const PointCloud& source_coarse,
                 const Target& target, const Isometry3d& init, const AlignmentOptions& o,
                 IcpMethod method) {
  const double v = o.voxel_size;
  IcpOptions options;
  options.method = IcpMethod::PointToPlane;
  options.min_fitness = 0.0;  // acceptance is decided by the caller
  options.normal_radius = 2.5 * v;
  struct Level {
    const PointCloud* source;
    const PointCloud* target;
    double gate;
    int iterations;
  };
  const Level levels[3] = {{&source_coarse, &target.coarse, 4.0 * v, 30},
                           {&source_fine, &target.fine, 2.0 * v, 20},
                           {&source_fine, &target.fine, v, 15}};
  Isometry3d T = init;
  IcpResult r;
  int iterations = 0;
  for (int level = 0; level < 3; ++level) {
    options.max_correspondence_distance = levels[level].gate;
    options.convergence.max_iterations = levels[level].iterations;
    if (level == 2 && method == IcpMethod::Colored && source_fine.has_colors() &&
        target.fine.has_colors())
      options.method = IcpMethod::Colored;
    if (levels[level].source->size() < options.min_points ||
        levels[level].target->size() < options.min_points) {
      r.success = false;
      r.reason = fmt::format("level {}: too few points", level + 1);
      return r;
    }
    r = icp(*levels[level].source, *levels[level].target, T, options);
    iterations += r.iterations;
    if (!r.success) {
      r.reason = fmt::format("level {} of 3: {}", level + 1, r.reason);
      break;
    }
    T = r.T_target_source;
  }
  r.iterations = iterations;
  return r;
}

bool acceptable(const IcpResult& r, const AlignmentOptions& o, double min_fitness) {
  return r.success && r.fitness >= min_fitness &&
         r.inlier_rmse <= o.max_inlier_rmse_ratio * o.voxel_size;
}

std::string rejection(const IcpResult& r, const AlignmentOptions& o, double min_fitness) {
  if (!r.success) return "ICP failed: " + r.reason;
  return fmt::format("ICP fitness {:.3f} (need >= {:.2f}), inlier RMSE {:.4f} m (need <= {:.4f})",
                     r.fitness, min_fitness, r.inlier_rmse,
                     o.max_inlier_rmse_ratio * o.voxel_size);
}

bool better(const IcpResult& a, const IcpResult& b) {
  if (a.fitness != b.fitness) return a.fitness > b.fitness;
  return a.inlier_rmse < b.inlier_rmse;
}

GlobalRegistrationResult features(const PointCloud& source, const PointCloud& target,
                                  const Eigen::Vector3f& target_viewpoint,
                                  const AlignmentOptions& o, std::uint64_t salt) {
  GlobalRegistrationOptions g;
  g.voxel_size = o.feature_voxel_size;
  g.target_viewpoint = target_viewpoint;
  g.ransac.seed = o.seed + salt;
  g.ransac.max_iterations = 20000;
  g.ransac.confidence = 0.999;
  g.ransac.min_fitness = 0.2;
  return global_registration(source, target, g);
}

void check_options(const AlignmentOptions& o) {
  const auto bad = [](const std::string& what) { throw InputError("alignment options: " + what); };
  if (!(o.voxel_size > 0.0) || !std::isfinite(o.voxel_size))
    bad(fmt::format("voxel_size must be a positive number of metres, got {}", o.voxel_size));
  if (!(o.feature_voxel_size > 0.0))
    bad(fmt::format("feature_voxel_size must be positive, got {}", o.feature_voxel_size));
  if (o.stride < 1) bad(fmt::format("stride must be >= 1, got {}", o.stride));
  if (!(o.max_depth_m > o.min_depth_m))
    bad(fmt::format("max_depth_m ({}) must exceed min_depth_m ({})", o.max_depth_m,
                    o.min_depth_m));
  if (o.keyframe_interval < 1) bad("keyframe_interval must be >= 1");
  if (o.local_model_frames < 1) bad("local_model_frames must be >= 1");
}

Eigen::Vector3d forward(const Isometry3d& T) { return T.linear().col(2); }

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.dot(b), -1.0, 1.0)) * 180.0 / M_PI;
}

// Union-find over node indices.
struct Components {
  std::vector<std::size_t> parent;
  explicit Components(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  std::size_t find(std::size_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void join(std::size_t a, std::size_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

}  // namespace

std::string_view to_string(AlignmentMode mode) {
  return mode == AlignmentMode::Cumulative ? "cumulative" : "odometry";
}

std::optional<AlignmentMode> parse_alignment_mode(std::string_view name) {
  if (name == "cumulative") return AlignmentMode::Cumulative;
  if (name == "odometry") return AlignmentMode::Odometry;
  return std::nullopt;
}

std::string_view to_string(FrameStatus status) {
  switch (status) {
    case FrameStatus::Registered: return "registered";
    case FrameStatus::Unusable: return "unusable";
    case FrameStatus::Failed: return "failed";
  }
  return "unknown";
}

Trajectory AlignmentResult::trajectory(long piece) const {
  Trajectory out;
  for (const FrameAlignment& f : frames) {
    if (f.status != FrameStatus::Registered || !f.T_world_camera_final) continue;
    if (piece >= 0 && f.piece != static_cast<std::size_t>(piece)) continue;
    out.push_back({f.frame_index, f.timestamp, *f.T_world_camera_final});
  }
  return out;
}

std::vector<std::int64_t> AlignmentResult::unregistered_frame_indices() const {
  std::vector<std::int64_t> out;
  for (const FrameAlignment& f : frames)
    if (f.status != FrameStatus::Registered) out.push_back(f.frame_index);
  return out;
}

std::vector<std::int64_t> AlignmentResult::flagged_frame_indices() const {
  std::vector<std::int64_t> out;
  for (const FrameAlignment& f : frames)
    if (f.status == FrameStatus::Registered && f.check.checked && !f.check.verified)
      out.push_back(f.frame_index);
  return out;
}

std::size_t AlignmentResult::usable_frames() const {
  return static_cast<std::size_t>(std::count_if(frames.begin(), frames.end(), [](const auto& f) {
    return f.status != FrameStatus::Unusable;
  }));
}

std::size_t AlignmentResult::trusted_frames() const {
  return static_cast<std::size_t>(
      std::count_if(frames.begin(), frames.end(), [](const auto& f) { return f.trusted(); }));
}

double AlignmentResult::trusted_share() const {
  const std::size_t usable = usable_frames();
  return usable ? static_cast<double>(trusted_frames()) / static_cast<double>(usable) : 0.0;
}

AlignmentResult align_sequence(const RgbdSequence& sequence, const AlignmentOptions& options) {
  check_options(options);
  const AlignmentOptions& o = options;
  if (sequence.frames.empty())
    throw_input_error(sequence.root, "the sequence has no frames to align");
  if (o.first_frame >= sequence.frames.size())
    throw_input_error(sequence.root, fmt::format("first frame {} is past the last frame ({})",
                                                 o.first_frame, sequence.frames.size() - 1));
  const std::size_t end =
      o.max_frames ? std::min(sequence.frames.size(), o.first_frame + o.max_frames)
                   : sequence.frames.size();
  const std::size_t n = end - o.first_frame;
  const auto t_total = Clock::now();
  AlignmentResult result;
  result.options = o;
  result.options.progress = nullptr;

  // 1. Frame clouds, in parallel (each frame is independent; the order is the index order).
  auto t0 = Clock::now();
  std::vector<PreparedFrame> prepared(n);
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
    prepared[i] = prepare_frame(sequence, o.first_frame + i, o);
  });
  result.frames.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    FrameAlignment& f = result.frames[i];
    const FrameEntry& e = sequence.frames[o.first_frame + i];
    f.sequence_index = o.first_frame + i;
    f.frame_index = e.frame_index;
    f.timestamp = e.timestamp;
    f.points = prepared[i].cloud.size();
    f.status = prepared[i].unusable.empty() ? FrameStatus::Failed : FrameStatus::Unusable;
    f.reason = prepared[i].unusable;
  }
  result.timings.prepare_s = seconds_since(t0);

  // 2. Sequential registration.
  t0 = Clock::now();
  const IcpMethod method =
      o.mode == AlignmentMode::Odometry ? o.odometry_method : IcpMethod::PointToPlane;
  Target model;                              // world frame
  std::vector<std::size_t> keyframes_local;  // odometry: frames in the local model
  std::vector<std::size_t> piece_of(n, 0);
  std::vector<std::size_t> registered;       // frame indices (into result.frames), in order
  std::size_t piece = 0;
  bool piece_open = false;
  std::size_t failures = 0;
  std::size_t since_keyframe = 0;
  const auto rebuild_local_model = [&] {
    PointCloud m;
    for (std::size_t k : keyframes_local)
      m.append(transformed(prepared[k].cloud, *result.frames[k].T_world_camera_icp));
    model = make_target(voxel_down_sample(m, static_cast<float>(o.voxel_size)).cloud,
                        o.voxel_size);
  };
  const auto add_to_model = [&](std::size_t i) {
    const PointCloud world = transformed(prepared[i].cloud, *result.frames[i].T_world_camera_icp);
    if (o.mode == AlignmentMode::Cumulative) {
      model.fine.append(world);
      model = make_target(
          voxel_down_sample(model.fine, static_cast<float>(o.voxel_size)).cloud, o.voxel_size);
    } else {
      keyframes_local.push_back(i);
      if (keyframes_local.size() > o.local_model_frames)
        keyframes_local.erase(keyframes_local.begin());
      rebuild_local_model();
    }
  };
  for (std::size_t i = 0; i < n; ++i) {
    FrameAlignment& f = result.frames[i];
    if (o.progress) o.progress(i, n);
    if (f.status == FrameStatus::Unusable) continue;
    if (!piece_open) {
      // First usable frame of a piece: it defines that piece's world frame.
      if (!registered.empty()) ++piece;
      piece_open = true;
      failures = 0;
      since_keyframe = 0;
      f.status = FrameStatus::Registered;
      f.T_world_camera_icp = Isometry3d::Identity();
      f.initialisation = "first frame";
      f.fitness = 1.0;
      piece_of[i] = piece;
      registered.push_back(i);
      model = Target{};
      keyframes_local.clear();
      add_to_model(i);
      continue;
    }
    const PointCloud& cloud = prepared[i].cloud;
    const std::size_t last = registered.back();
    const Isometry3d T_last = *result.frames[last].T_world_camera_icp;
    std::vector<std::pair<Isometry3d, std::string>> inits;
    const auto try_features = [&] {
      const auto g = features(cloud, model.fine, T_last.translation().cast<float>(), o, i);
      if (g.ransac.success) {
        f.T_world_camera_svd = g.ransac.T_target_source;
        inits.emplace_back(g.ransac.T_target_source, "features");
      }
    };
    if (o.mode == AlignmentMode::Cumulative) {
      try_features();
      inits.emplace_back(T_last, "previous pose");
    } else {
      Isometry3d prediction = T_last;
      if (registered.size() >= 2 && piece_of[registered[registered.size() - 2]] == piece) {
        const Isometry3d& T_prev = *result.frames[registered[registered.size() - 2]]
                                        .T_world_camera_icp;
        prediction = T_last * (T_prev.inverse() * T_last);  // constant velocity
      }
      inits.emplace_back(prediction, "prediction");
      inits.emplace_back(T_last, "previous pose");
    }
    std::optional<IcpResult> best;
    std::string best_init;
    const auto evaluate = [&](std::size_t from) {
      for (std::size_t k = from; k < inits.size(); ++k) {
        IcpResult r = refine(cloud, prepared[i].coarse, model, inits[k].first, o, method);
        if (!best || better(r, *best)) {
          best = std::move(r);
          best_init = inits[k].second;
        }
        // Odometry: the prediction is good enough almost always; skip the other guesses.
        if (o.mode == AlignmentMode::Odometry && acceptable(*best, o, o.min_fitness)) break;
      }
    };
    evaluate(0);
    if (o.mode == AlignmentMode::Odometry && !acceptable(*best, o, o.min_fitness)) {
      const std::size_t from = inits.size();
      try_features();  // tracking lost: feature registration against the local model
      evaluate(from);
    }
    if (best && acceptable(*best, o, o.min_fitness)) {
      f.status = FrameStatus::Registered;
      f.T_world_camera_icp = best->T_target_source;
      f.fitness = best->fitness;
      f.inlier_rmse = best->inlier_rmse;
      f.initialisation = best_init;
      piece_of[i] = piece;
      registered.push_back(i);
      failures = 0;
      if (o.mode == AlignmentMode::Cumulative || ++since_keyframe >= o.keyframe_interval) {
        since_keyframe = 0;
        add_to_model(i);
      }
    } else {
      f.status = FrameStatus::Failed;
      f.reason = best ? rejection(*best, o, o.min_fitness) : "no initial pose";
      f.fitness = best ? best->fitness : 0.0;
      f.inlier_rmse = best ? best->inlier_rmse : 0.0;
      if (++failures >= o.max_consecutive_failures) piece_open = false;
    }
  }
  if (o.progress) o.progress(n, n);
  result.timings.register_s = seconds_since(t0);

  // 3. Loop closure between keyframes.
  t0 = Clock::now();
  std::vector<std::size_t> keyframes;
  {
    std::size_t count = 0;
    for (std::size_t k = 0; k < registered.size(); ++k) {
      const bool piece_edge = k == 0 || k + 1 == registered.size() ||
                              piece_of[registered[k]] != piece_of[registered[k - 1]] ||
                              piece_of[registered[k]] != piece_of[registered[k + 1]];
      if (o.mode == AlignmentMode::Cumulative || piece_edge || count % o.keyframe_interval == 0)
        keyframes.push_back(registered[k]);
      ++count;
    }
  }
  std::vector<LoopCandidate> candidates;
  if (o.loop_closure) {
    std::set<std::pair<std::size_t, std::size_t>> seen;
    std::vector<std::pair<double, LoopCandidate>> near;
    const auto by_score = [](const auto& x, const auto& y) { return x.first < y.first; };
    // Pairs closer in the sequence than the local model's span are already tied together by
    // tracking; only pairs beyond it can remove drift.
    const std::size_t separation =
        o.mode == AlignmentMode::Odometry
            ? std::max(o.loop_min_separation, o.local_model_frames * o.keyframe_interval)
            : o.loop_min_separation;
    for (std::size_t b = 0; b < keyframes.size(); ++b) {
      // The nearest few earlier keyframes of each keyframe, so that the candidates spread over
      // the whole sequence instead of crowding where the camera lingered.
      std::vector<std::pair<double, LoopCandidate>> mine;
      for (std::size_t a = 0; a < b; ++a) {
        const std::size_t i = keyframes[a], j = keyframes[b];
        if (piece_of[i] != piece_of[j] || j - i < separation) continue;
        const Isometry3d& Ti = *result.frames[i].T_world_camera_icp;
        const Isometry3d& Tj = *result.frames[j].T_world_camera_icp;
        const double d = (Ti.translation() - Tj.translation()).norm();
        const double ang = angle_deg(forward(Ti), forward(Tj));
        if (d > o.loop_max_distance_m || ang > o.loop_max_angle_deg) continue;
        LoopCandidate c;
        c.source = j;
        c.target = i;
        c.found_by = "proximity";
        c.T_target_source = Ti.inverse() * Tj;
        mine.emplace_back(d / o.loop_max_distance_m + ang / o.loop_max_angle_deg, c);
      }
      std::stable_sort(mine.begin(), mine.end(), by_score);
      if (mine.size() > o.loop_candidates_per_keyframe) mine.resize(o.loop_candidates_per_keyframe);
      near.insert(near.end(), mine.begin(), mine.end());
    }
    std::stable_sort(near.begin(), near.end(), by_score);
    if (near.size() > o.max_loop_candidates) near.resize(o.max_loop_candidates);
    for (auto& [score, c] : near) {
      seen.emplace(c.target, c.source);
      candidates.push_back(std::move(c));
    }
    // Feature candidates: first and last keyframe of each piece, and across pieces.
    std::map<std::size_t, std::pair<std::size_t, std::size_t>> ends;  // piece -> first, last
    for (std::size_t k : registered) {
      auto [it, inserted] = ends.emplace(piece_of[k], std::make_pair(k, k));
      if (!inserted) it->second.second = k;
    }
    std::vector<std::pair<std::size_t, std::size_t>> pairs;
    for (const auto& [p, fl] : ends) {
      if (fl.second - fl.first >= o.loop_min_separation) pairs.emplace_back(fl.first, fl.second);
      for (const auto& [q, gl] : ends)
        if (q > p) {
          pairs.emplace_back(fl.first, gl.first);
          pairs.emplace_back(fl.second, gl.first);
        }
    }
    for (const auto& [i, j] : pairs) {
      if (seen.count({i, j})) continue;
      seen.emplace(i, j);
      LoopCandidate c;
      c.source = j;
      c.target = i;
      c.found_by = "features";
      candidates.push_back(std::move(c));
    }
    // Verification (parallel over candidates; each is independent and seeded by its pair).
    tbb::parallel_for(std::size_t{0}, candidates.size(), [&](std::size_t k) {
      LoopCandidate& c = candidates[k];
      const PointCloud& src = prepared[c.source].cloud;
      const PointCloud& src_coarse = prepared[c.source].coarse;
      const Target tgt{prepared[c.target].cloud, prepared[c.target].coarse};
      std::optional<IcpResult> best;
      if (c.found_by == "proximity")
        best = refine(src, src_coarse, tgt, c.T_target_source, o, method);
      if (c.found_by == "features") {
        const auto g =
            features(src, tgt.fine, Eigen::Vector3f::Zero(), o, 1000003 * c.source + c.target);
        if (g.ransac.success) {
          IcpResult r = refine(src, src_coarse, tgt, g.ransac.T_target_source, o, method);
          if (!best || better(r, *best)) best = std::move(r);
        } else if (!best) {
          c.reason = "feature registration failed: " + g.ransac.reason;
          return;
        }
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
  result.timings.loop_closure_s = seconds_since(t0);

  // 4. Pose graph. Pieces joined by a verified loop are first brought into one frame.
  t0 = Clock::now();
  std::vector<std::size_t> node_of(n, SIZE_MAX);
  for (std::size_t k = 0; k < registered.size(); ++k) {
    node_of[registered[k]] = k;
    result.node_frames.push_back(registered[k]);
    result.graph.nodes.push_back(*result.frames[registered[k]].T_world_camera_icp);
  }
  const double info_distance = 1.5 * o.voxel_size;
  std::vector<Matrix6d> odometry_info(registered.size() ? registered.size() - 1 : 0);
  tbb::parallel_for(std::size_t{0}, odometry_info.size(), [&](std::size_t k) {
    const std::size_t a = registered[k], b = registered[k + 1];
    if (piece_of[a] != piece_of[b]) return;
    const Isometry3d T = result.graph.nodes[k].inverse() * result.graph.nodes[k + 1];
    odometry_info[k] = information_matrix(prepared[b].cloud, prepared[a].cloud, T, info_distance);
  });
  for (std::size_t k = 0; k + 1 < registered.size(); ++k) {
    if (piece_of[registered[k]] != piece_of[registered[k + 1]]) continue;
    PoseGraphEdge e;
    e.source = k + 1;
    e.target = k;
    e.T_target_source = result.graph.nodes[k].inverse() * result.graph.nodes[k + 1];
    e.information = odometry_info[k];
    if (e.information.trace() <= 0.0) e.information = Matrix6d::Identity();
    result.graph.edges.push_back(e);
  }
  // Move pieces into the frame of the earliest piece they connect to (breadth first).
  std::size_t piece_count = registered.empty() ? 0 : piece + 1;
  {
    std::vector<char> placed(piece_count, 0);
    std::vector<Isometry3d> T_world_piece(piece_count, Isometry3d::Identity());
    for (std::size_t p = 0; p < piece_count; ++p) {
      if (placed[p]) continue;
      placed[p] = 1;
      bool grew = true;
      while (grew) {
        grew = false;
        for (const LoopCandidate& c : candidates) {
          if (!c.accepted) continue;
          const std::size_t pa = piece_of[c.target], pb = piece_of[c.source];
          if (pa == pb || placed[pa] == placed[pb]) continue;
          // T_world_piece(source side) from the target side through the loop transform.
          const bool target_placed = placed[pa];
          const std::size_t fixed = target_placed ? c.target : c.source;
          const std::size_t moving = target_placed ? c.source : c.target;
          const Isometry3d T_fixed = T_world_piece[piece_of[fixed]] *
                                     *result.frames[fixed].T_world_camera_icp;
          const Isometry3d T_rel = target_placed ? c.T_target_source : c.T_target_source.inverse();
          const Isometry3d T_moving_world = T_fixed * T_rel;
          const std::size_t q = piece_of[moving];
          T_world_piece[q] = T_moving_world * result.frames[moving].T_world_camera_icp->inverse();
          placed[q] = 1;
          grew = true;
        }
      }
    }
    for (std::size_t k = 0; k < registered.size(); ++k)
      result.graph.nodes[k] = T_world_piece[piece_of[registered[k]]] * result.graph.nodes[k];
  }
  for (LoopCandidate& c : candidates) {
    if (!c.accepted) continue;
    PoseGraphEdge e;
    e.source = node_of[c.source];
    e.target = node_of[c.target];
    e.T_target_source = c.T_target_source;
    e.information = information_matrix(prepared[c.source].cloud, prepared[c.target].cloud,
                                       c.T_target_source, info_distance);
    e.uncertain = true;
    c.chi2_before = edge_chi2(e, result.graph.nodes);
    result.graph.edges.push_back(e);
  }
  // Solve each connected component with its first node fixed.
  Components components(registered.size());
  for (const PoseGraphEdge& e : result.graph.edges) components.join(e.source, e.target);
  std::map<std::size_t, std::vector<std::size_t>> members;
  for (std::size_t k = 0; k < registered.size(); ++k) members[components.find(k)].push_back(k);
  PoseGraph solved;
  solved.nodes = result.graph.nodes;
  for (const auto& [root, nodes] : members) {
    PoseGraph sub;
    std::vector<std::size_t> local(registered.size(), SIZE_MAX);
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
    // Loop edges are matched back to their candidates by (source, target) below.
    PoseGraphResult pr = optimize_pose_graph(sub, o.pose_graph);
    for (std::size_t k = 0; k < nodes.size(); ++k) solved.nodes[nodes[k]] = sub.nodes[k];
    for (const PoseGraphEdge& e : sub.edges) {
      PoseGraphEdge g = e;
      g.source = nodes[e.source];
      g.target = nodes[e.target];
      if (e.uncertain)
        for (LoopCandidate& c : candidates)
          if (c.accepted && node_of[c.source] == g.source && node_of[c.target] == g.target) {
            c.chi2_after = e.chi2;
            c.confidence = e.confidence;
          }
      solved.edges.push_back(g);
    }
    for (const RejectedEdge& r : pr.rejected) {
      const std::size_t s = nodes[r.edge.source], t = nodes[r.edge.target];
      for (LoopCandidate& c : candidates)
        if (c.accepted && node_of[c.source] == s && node_of[c.target] == t) {
          c.accepted = false;
          c.reason = "pose graph: " + r.reason;
          c.confidence = r.edge.confidence;
          c.chi2_after = r.edge.chi2;
        }
    }
    // Aggregate the component reports.
    result.pose_graph.success = (result.pose_graph.solves == 0 || result.pose_graph.success) &&
                                pr.success;
    if (!pr.success) result.pose_graph.reason = pr.reason;
    result.pose_graph.initial_cost += pr.initial_cost;
    result.pose_graph.final_cost += pr.final_cost;
    result.pose_graph.solves += pr.solves;
    result.pose_graph.iterations += pr.iterations;
    result.pose_graph.mu = std::max(result.pose_graph.mu, pr.mu);
    result.pose_graph.max_odometry_bend_deg =
        std::max(result.pose_graph.max_odometry_bend_deg, pr.max_odometry_bend_deg);
    result.pose_graph.max_odometry_bend_m =
        std::max(result.pose_graph.max_odometry_bend_m, pr.max_odometry_bend_m);
    for (RejectedEdge r : pr.rejected) {
      r.edge.source = nodes[r.edge.source];
      r.edge.target = nodes[r.edge.target];
      result.pose_graph.rejected.push_back(std::move(r));
    }
  }
  if (registered.empty()) result.pose_graph.success = true;
  for (PoseGraphEdge& e : solved.edges)
    if (!e.uncertain) e.confidence = 1.0;
  result.graph = std::move(solved);
  for (LoopCandidate& c : candidates)
    if (c.accepted && c.confidence <= 0.0) c.confidence = 1.0;

  // Pieces after loop closure: connected components of the kept graph, numbered by first frame.
  Components kept(registered.size());
  for (const PoseGraphEdge& e : result.graph.edges) kept.join(e.source, e.target);
  std::map<std::size_t, std::size_t> piece_id;
  for (std::size_t k = 0; k < registered.size(); ++k) {
    const std::size_t root = kept.find(k);
    auto [it, inserted] = piece_id.emplace(root, piece_id.size());
    FrameAlignment& f = result.frames[registered[k]];
    f.piece = it->second;
    f.T_world_camera_final = result.graph.nodes[k];
  }
  result.pieces = piece_id.size();
  result.loops = std::move(candidates);
  result.timings.pose_graph_s = seconds_since(t0);
  result.timings.total_s = seconds_since(t_total);
  return result;
}

PointCloud fuse_aligned_frames(const RgbdSequence& sequence, const AlignmentResult& result,
                               double voxel_size, long piece) {
  const AlignmentOptions& o = result.options;
  std::vector<const FrameAlignment*> frames;
  for (const FrameAlignment& f : result.frames)
    if (f.trusted() && (piece < 0 || f.piece == static_cast<std::size_t>(piece)))
      frames.push_back(&f);
  std::vector<PointCloud> clouds(frames.size());
  tbb::parallel_for(std::size_t{0}, frames.size(), [&](std::size_t k) {
    const RgbdFrame frame = sequence.load_frame(frames[k]->sequence_index);
    DepthToPointsOptions dopt;
    dopt.min_depth_m = o.min_depth_m;
    dopt.max_depth_m = o.max_depth_m;
    dopt.stride = o.stride;
    const PointCloud raw = depth_to_points(frame, dopt, *frames[k]->T_world_camera_final);
    clouds[k] = voxel_down_sample(raw, static_cast<float>(voxel_size)).cloud;
  });
  PointCloud all;
  for (const PointCloud& c : clouds) all.append(c);
  if (all.empty()) return all;
  return voxel_down_sample(all, static_cast<float>(voxel_size)).cloud;
}

}  // namespace locard
