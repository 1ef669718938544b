// Stage 2 of align_sequence: sequential registration (alignment_stages.hpp,
// sequential_alignment.hpp step 2).
#include "alignment/alignment_stages.hpp"

#include <locard/preprocess/voxel_grid.hpp>

#include <optional>
#include <utility>

namespace locard::alignment_detail {
namespace {

// The model each frame is registered against, in the world frame of the current piece.
class TrackingModel {
 public:
  explicit TrackingModel(AlignmentState& s) : s_(s) {}
  const Target& target() const { return model_; }
  void reset() {
    model_ = Target{};
    keyframes_.clear();
  }
  void add(std::size_t i) {
    const AlignmentOptions& o = s_.options;
    if (o.mode == AlignmentMode::Cumulative) {
      model_.fine.append(transformed(s_.prepared[i].cloud, s_.tracked_pose(i)));
      model_ = make_target(voxel_down_sample(model_.fine, static_cast<float>(o.voxel_size)).cloud,
                           o.voxel_size);
      prepare_for_icp(model_, o.voxel_size, tracking_method(o));
      return;
    }
    keyframes_.push_back(i);
    if (keyframes_.size() > o.local_model_frames) keyframes_.erase(keyframes_.begin());
    PointCloud m;
    for (std::size_t k : keyframes_) m.append(transformed(s_.prepared[k].cloud, s_.tracked_pose(k)));
    model_ = make_target(voxel_down_sample(m, static_cast<float>(o.voxel_size)).cloud,
                         o.voxel_size);
    prepare_for_icp(model_, o.voxel_size, tracking_method(o));
  }

 private:
  AlignmentState& s_;
  Target model_;                    // world frame
  std::vector<std::size_t> keyframes_;  // odometry: frames in the local model
};

using Guesses = std::vector<std::pair<Isometry3d, std::string>>;

}  // namespace

void track_frames(AlignmentState& s) {
  const AlignmentOptions& o = s.options;
  const IcpMethod method = tracking_method(o);
  TrackingModel model(s);
  s.piece_of.assign(s.n, 0);
  s.registered.clear();
  std::size_t piece = 0;
  bool piece_open = false;
  std::size_t failures = 0;
  std::size_t since_keyframe = 0;
  const auto accept = [&](std::size_t i, const IcpResult& r, const std::string& init) {
    FrameAlignment& f = s.result.frames[i];
    f.status = FrameStatus::Registered;
    f.T_world_camera_icp = r.T_target_source;
    f.fitness = r.fitness;
    f.inlier_rmse = r.inlier_rmse;
    f.initialisation = init;
    s.piece_of[i] = piece;
    s.registered.push_back(i);
    failures = 0;
  };
  const auto reject = [&](std::size_t i, const std::optional<IcpResult>& r,
                          const std::string& why) {
    FrameAlignment& f = s.result.frames[i];
    f.status = FrameStatus::Failed;
    f.reason = why;
    f.fitness = r ? r->fitness : 0.0;
    f.inlier_rmse = r ? r->inlier_rmse : 0.0;
    if (++failures >= o.max_consecutive_failures) piece_open = false;
  };
  for (std::size_t i = 0; i < s.n; ++i) {
    FrameAlignment& f = s.result.frames[i];
    if (o.progress) o.progress(i, s.n);
    if (f.status == FrameStatus::Unusable) continue;
    if (!piece_open) {
      // First usable frame of a piece: it defines that piece's world frame.
      if (!s.registered.empty()) ++piece;
      piece_open = true;
      failures = 0;
      since_keyframe = 0;
      f.status = FrameStatus::Registered;
      f.T_world_camera_icp = Isometry3d::Identity();
      f.initialisation = "first frame";
      f.fitness = 1.0;
      s.piece_of[i] = piece;
      s.registered.push_back(i);
      model.reset();
      model.add(i);
      continue;
    }
    if (o.mode == AlignmentMode::Cumulative) {
      TrackedView view = register_tripod_view(s, model.target(), i, piece);
      f.T_world_camera_svd = view.T_world_camera_initial;  // the stage report's first stage
      if (view.failure.empty()) {
        accept(i, *view.best, view.initialisation);
        model.add(i);
      } else {
        reject(i, view.best, view.failure);
      }
      continue;
    }
    const PointCloud& cloud = s.prepared[i].cloud;
    const std::size_t last = s.registered.back();
    const Isometry3d T_last = s.tracked_pose(last);
    Guesses inits;
    const auto try_features = [&] {
      const auto g = features(cloud, model.target().fine, T_last.translation().cast<float>(), o, i);
      if (g.ransac.success) {
        f.T_world_camera_svd = g.ransac.T_target_source;
        inits.emplace_back(g.ransac.T_target_source, "features");
      }
    };
    Isometry3d prediction = T_last;
    if (s.registered.size() >= 2 && s.piece_of[s.registered[s.registered.size() - 2]] == piece) {
      const Isometry3d& T_prev = s.tracked_pose(s.registered[s.registered.size() - 2]);
      prediction = T_last * (T_prev.inverse() * T_last);  // constant velocity
    }
    inits.emplace_back(prediction, "prediction");
    inits.emplace_back(T_last, "previous pose");
    std::optional<IcpResult> best;
    std::string best_init;
    const auto evaluate = [&](std::size_t from) {
      for (std::size_t k = from; k < inits.size(); ++k) {
        IcpResult r = refine(cloud, s.prepared[i].coarse, model.target(), inits[k].first, o, method);
        if (!best || better(r, *best)) {
          best = std::move(r);
          best_init = inits[k].second;
        }
        // The prediction is good enough almost always; skip the other guesses.
        if (acceptable(*best, o, o.min_fitness)) break;
      }
    };
    evaluate(0);
    if (!acceptable(*best, o, o.min_fitness)) {
      const std::size_t from = inits.size();
      try_features();  // tracking lost: feature registration against the local model
      evaluate(from);
    }
    if (best && acceptable(*best, o, o.min_fitness)) {
      accept(i, *best, best_init);
      if (++since_keyframe >= o.keyframe_interval) {
        since_keyframe = 0;
        model.add(i);
      }
    } else {
      reject(i, best, best ? rejection(*best, o, o.min_fitness) : "no initial pose");
    }
  }
  if (o.progress) o.progress(s.n, s.n);
  s.piece_count = s.registered.empty() ? 0 : piece + 1;
}

}  // namespace locard::alignment_detail
