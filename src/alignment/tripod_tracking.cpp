// Tripod tracking, stage 2 of align_sequence in cumulative mode (sequential_alignment.hpp).
//
// A tripod turn moves the camera on one pan axis through a fixed centre, so the next view is
// the previous one turned about that axis by a step narrower than the field of view, and
// tilted only where a pitch ring starts. The search follows that motion instead of trusting
// feature matches, which in a symmetric room (a rectangle fits itself turned by 180 degrees)
// happily return a pose on the far side of the tripod:
//   1. guesses: the previous pose turned by the last step (the prediction) and by every
//      tripod_sweep_step_deg within +-max_tripod_step_deg; before the pan axis is known (the
//      first step) the axis is searched too, from the camera's up axis tilted forwards and
//      back, as the camera may look up or down;
//   2. each guess is screened by a short coarse ICP; the fittest few that still respect the
//      tripod are refined by the full ICP (refine());
//   3. where a ring starts, or the turn alone finds nothing, tilts about the horizontal axis
//      are added (from the previous view and from the previous ring's first view), and then
//      feature registration; every result is held to the tripod all the same.
#include "alignment/alignment_stages.hpp"
#include "alignment/tripod_fit.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <utility>

namespace locard::alignment_detail {
namespace {

constexpr double kDeg = M_PI / 180.0;
// Once the turn has a direction, a view may lie at most this far back: a pose further back
// lands on what the model already covers, and fits it better than the true pose at the
// model's edge does, so fitness alone would walk the turn backwards.
constexpr double kMaxBackTurnDeg = 10.0;
// Between consecutive views the camera centre moves by tripod play and the nodal offset's
// turn (the prediction follows the offset once its pivot is fitted): a few centimetres.
constexpr double kMaxCentreStepM = 0.10;
constexpr double kMaxDataSlideM = 0.02;
// Below this a light and a firm result differ by the prior's pull, not by a slide.
constexpr double kMinJudgedSlideM = 0.002;
// ICP that turns further than this from its guess has left the guess's basin: the guesses
// are a few degrees apart, so the right pose is always near one of them.
constexpr double kMaxWanderDeg = 10.0;
constexpr double kGuessRotationSigmaDeg = 5.0;
// The pan axis voted from every view (tripod_fit.hpp) holds tilt and roll once the views on
// their rings span this much turn (an axis from a short turn is off by the views' noise over
// the turn's angle), held this firmly per correspondence.
constexpr double kHingeAfterTurnDeg = 45.0;
constexpr double kHeldOffAxisSigmaDeg = 0.2;
// A view whose camera-frame axis lies this near a ring's is held to that ring; further off it
// starts a ring of its own (the first views after a tilt).
constexpr double kSameRingDeg = 3.0;

// What the registered views of the piece so far say about the tripod.
struct TripodMotion {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // median camera centre
  std::optional<Eigen::Vector3d> pan_axis;           // world frame; unknown before a turn
  double last_step_rad = 0.0;                        // signed, about pan_axis
  // The camera centre turns with the camera about the tripod's pivot (a nodal offset):
  // c = pivot + R R_last^T (c_last - pivot). Without a fitted pivot, c = c_last.
  Isometry3d T_last = Isometry3d::Identity();
  std::optional<Eigen::Vector3d> pivot;
  // Once the tripod fit holds: the pan axis (world) and the pan axis as the next view must see
  // it (its ring's, camera frame); tilt and roll are then held to them.
  std::optional<Eigen::Vector3d> hinge_axis;
  Eigen::Vector3d held_camera_axis = Eigen::Vector3d::Zero();
  // The tripod fit of the views so far (their order), where one holds.
  std::optional<TripodFit> fit;
  Eigen::Matrix3d on_hinge(const Eigen::Matrix3d& R) const {
    return hinge_axis ? onto_ring(R, *hinge_axis, held_camera_axis) : R;
  }
  Eigen::Vector3d predicted_centre(const Isometry3d& T) const {
    if (!pivot) return T_last.translation();
    return *pivot + T.linear() * T_last.linear().transpose() * (T_last.translation() - *pivot);
  }
};

struct Guess {
  Isometry3d T;
  const char* label;
};

double median(std::vector<double> v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

Isometry3d turned(const Isometry3d& T, const Eigen::Vector3d& axis, double angle_rad) {
  Isometry3d out = T;
  out.linear() = Eigen::AngleAxisd(angle_rad, axis).toRotationMatrix() * T.linear();
  return out;
}

// Frames of the piece in registration order.
std::vector<std::size_t> piece_views(const AlignmentState& s, std::size_t piece) {
  std::vector<std::size_t> views;
  for (std::size_t f : s.registered)
    if (s.piece_of[f] == piece) views.push_back(f);
  return views;
}

// The first view of each ring (indices into the frames used), from ring_sizes.
std::vector<std::size_t> ring_starts(const AlignmentOptions& o) {
  std::vector<std::size_t> starts;
  std::size_t at = 0;
  for (std::size_t size : o.ring_sizes) {
    if (at >= o.first_frame) starts.push_back(at - o.first_frame);
    at += size;
  }
  return starts;
}

// The pivot P with c_k - P = R_k R_0^T (c_0 - P) for every view k, by least squares:
// (I - R_k R_0^T) P = c_k - R_k R_0^T c_0. Needs turns about two axes or more than a small
// turn about one (the pivot's place along the pan axis is then fixed by the smallest-norm
// part, which the camera centre's height does not depend on); none when the turn is short.
std::optional<Eigen::Vector3d> fitted_pivot(const AlignmentState& s,
                                            const std::vector<std::size_t>& views) {
  const Isometry3d& T0 = s.tracked_pose(views.front());
  Eigen::Matrix3d AtA = Eigen::Matrix3d::Zero();
  Eigen::Vector3d Atb = Eigen::Vector3d::Zero();
  double widest = 0.0;
  for (std::size_t f : views) {
    const Isometry3d& T = s.tracked_pose(f);
    const Eigen::Matrix3d R = T.linear() * T0.linear().transpose();
    widest = std::max(widest, Eigen::AngleAxisd(R).angle());
    const Eigen::Matrix3d A = Eigen::Matrix3d::Identity() - R;
    AtA += A.transpose() * A;
    Atb += A.transpose() * (T.translation() - R * T0.translation());
  }
  if (widest < 20.0 * kDeg) return std::nullopt;
  // Pseudo-inverse: the direction along the pan axis is unobservable from the turn alone.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(AtA);
  Eigen::Vector3d P = Eigen::Vector3d::Zero();
  const double top = eig.eigenvalues()(2);
  for (int k = 0; k < 3; ++k) {
    const double l = eig.eigenvalues()(k);
    if (l > 1e-6 * top) P += eig.eigenvectors().col(k) * (eig.eigenvectors().col(k).dot(Atb) / l);
  }
  // The unobservable part: put it at the camera centre's own height on the axis.
  for (int k = 0; k < 3; ++k) {
    const double l = eig.eigenvalues()(k);
    if (l <= 1e-6 * top) {
      const Eigen::Vector3d u = eig.eigenvectors().col(k);
      P += u * u.dot(T0.translation() - P);
    }
  }
  if (!P.allFinite() || (P - T0.translation()).norm() > s.options.view_check.max_tripod_offset_m)
    return std::nullopt;
  return P;
}

// The hinge from the tripod fit of the views so far, once they span enough turn on their
// rings; the last view's ring is the one held (or its own axis, where it starts a ring).
void hold_to_fit(TripodMotion& m, const AlignmentState& s, const std::vector<std::size_t>& views) {
  std::vector<Eigen::Matrix3d> R;
  for (std::size_t f : views) R.push_back(s.tracked_pose(f).linear());
  m.fit = fit_tripod(R);
  const std::optional<TripodFit>& fit = m.fit;
  if (!fit) return;
  const TripodFitOptions limits;
  std::optional<std::size_t> first_on_ring;
  double widest = 0.0;
  for (std::size_t k = 0; k < R.size(); ++k) {
    if (fit->off_axis_deg[k] >= limits.inlier_deg) continue;
    if (!first_on_ring) first_on_ring = k;
    widest = std::max(widest, Eigen::AngleAxisd(R[k] * R[*first_on_ring].transpose()).angle());
  }
  if (widest < kHingeAfterTurnDeg * kDeg) return;
  const Eigen::Vector3d seen = R.back().transpose() * fit->axis;
  const Eigen::Vector3d held =
      fit->off_axis_deg.back() < kSameRingDeg ? fit->ring_axes[fit->ring.back()] : seen;
  const double sign = m.pan_axis && m.pan_axis->dot(fit->axis) < 0.0 ? -1.0 : 1.0;
  m.pan_axis = sign * fit->axis;
  m.hinge_axis = m.pan_axis;
  m.held_camera_axis = sign * held;
}

// Pan axis: the angle-weighted mean of the step axes that agree with the first clear step
// (a ring change tilts about another axis and is left out), signed so the turn is positive.
TripodMotion tripod_motion(const AlignmentState& s, const std::vector<std::size_t>& views) {
  TripodMotion m;
  std::vector<double> c[3];
  for (std::size_t f : views)
    for (int k = 0; k < 3; ++k) c[k].push_back(s.tracked_pose(f).translation()(k));
  for (int k = 0; k < 3; ++k) m.centre(k) = median(c[k]);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t k = 1; k < views.size(); ++k) {
    const Eigen::Matrix3d R = s.tracked_pose(views[k]).linear() *
                              s.tracked_pose(views[k - 1]).linear().transpose();
    const Eigen::AngleAxisd step(R);
    if (step.angle() < 2.0 * kDeg) continue;
    Eigen::Vector3d axis = step.axis();
    if (sum.squaredNorm() > 0.0) {
      const Eigen::Vector3d mean = sum.normalized();
      if (axis.dot(mean) < 0.0) axis = -axis;
      if (axis.dot(mean) < std::cos(30.0 * kDeg)) continue;
    }
    sum += step.angle() * axis;
  }
  m.T_last = s.tracked_pose(views.back());
  m.pivot = fitted_pivot(s, views);
  if (sum.norm() < 2.0 * kDeg) return m;
  m.pan_axis = sum.normalized();
  hold_to_fit(m, s, views);
  if (views.size() >= 2) {
    const Eigen::AngleAxisd last(s.tracked_pose(views.back()).linear() *
                                 s.tracked_pose(views[views.size() - 2]).linear().transpose());
    const double along = last.axis().dot(*m.pan_axis);
    if (std::abs(along) > std::cos(30.0 * kDeg)) m.last_step_rad = last.angle() * along;
  }
  return m;
}

// Turns of `base` about the pan axis (or, before it is known, about the camera's up axis
// tilted by up to +-40 degrees towards its forward axis).
void add_turns(std::vector<Guess>& guesses, const Isometry3d& base, const TripodMotion& m,
               const AlignmentOptions& o) {
  std::vector<Eigen::Vector3d> axes;
  if (m.pan_axis) {
    axes.push_back(*m.pan_axis);
  } else {
    const Eigen::Vector3d up = -base.linear().col(1), ahead = base.linear().col(2);
    for (double tilt = -40.0; tilt <= 40.0; tilt += 20.0)
      axes.push_back(std::cos(tilt * kDeg) * up + std::sin(tilt * kDeg) * ahead);
  }
  const double step = std::max(o.tripod_sweep_step_deg, 0.5);
  const double from = m.pan_axis ? -kMaxBackTurnDeg : -o.max_tripod_step_deg;
  for (const Eigen::Vector3d& axis : axes)
    for (double a = from; a <= o.max_tripod_step_deg + 1e-9; a += step)
      guesses.push_back({turned(base, axis, a * kDeg), "tripod turn"});
}

// Tilts of `base` about its horizontal axis, each with a few turns about the pan axis.
void add_tilts(std::vector<Guess>& guesses, const Isometry3d& base, const TripodMotion& m,
               const AlignmentOptions& o) {
  const Eigen::Vector3d up = m.pan_axis ? *m.pan_axis : Eigen::Vector3d(-base.linear().col(1));
  Eigen::Vector3d side = up.cross(base.linear().col(2));
  if (side.norm() < 1e-6) side = base.linear().col(0);
  side.normalize();
  const double tilt_step = 2.0 * std::max(o.tripod_sweep_step_deg, 0.5);
  const double turn_step = 3.0 * std::max(o.tripod_sweep_step_deg, 0.5);
  for (double tilt = -o.max_tripod_tilt_deg; tilt <= o.max_tripod_tilt_deg + 1e-9;
       tilt += tilt_step)
    for (double turn = -2.0 * turn_step; turn <= 2.0 * turn_step + 1e-9; turn += turn_step)
      guesses.push_back({turned(turned(base, side, tilt * kDeg), up, turn * kDeg), "tripod tilt"});
}

// Why a pose breaks the tripod, or an empty string.
std::string tripod_violation(const Isometry3d& T, const Isometry3d& T_last, const TripodMotion& m,
                             const AlignmentOptions& o, double max_turn_deg,
                             bool direction_known) {
  const double offset = (T.translation() - m.centre).norm();
  if (offset > o.view_check.max_tripod_offset_m)
    return fmt::format("camera {:.2f} m from the tripod's centre (allowed {:.2f} m)", offset,
                       o.view_check.max_tripod_offset_m);
  const double moved = (T.translation() - m.predicted_centre(T)).norm();
  if (moved > kMaxCentreStepM)
    return fmt::format("camera moved {:.2f} m on the tripod since the previous view (at most "
                       "{:.2f})",
                       moved, kMaxCentreStepM);
  const double turn = rotation_difference_deg(T_last, T);
  if (turn > max_turn_deg)
    return fmt::format("turned {:.1f} deg from the previous view (at most {:.0f})", turn,
                       max_turn_deg);
  if (direction_known && m.pan_axis) {
    const Eigen::AngleAxisd step(T.linear() * T_last.linear().transpose());
    const double signed_turn = step.angle() * step.axis().dot(*m.pan_axis) / kDeg;
    if (signed_turn < -kMaxBackTurnDeg)
      return fmt::format("turned {:.1f} deg back against the turn (at most {:.0f})", -signed_turn,
                         kMaxBackTurnDeg);
  }
  return {};
}

struct Candidate {
  IcpResult result;
  const char* label;
};

// The tripod holds the camera centre (a nodal offset moves it by centimetres) and allows no
// roll. A light prior (one correspondence's worth) only makes an exactly free direction
// solvable and leaves the data's optimum alone, which a firm one would bias towards the
// predicted centre by a share of the camera's real movement (tripod play, nodal offset). The
// firm prior (as sure as the data) is the fall-back for a view the light one lets slide off
// the tripod: a bare wall, a periodic texture.
enum class PriorStrength { Light, Firm };
// Within a ring the head turns about the pan axis only: the hinge holds tilt and roll to the
// ring (the turn a wall seen square on leaves free otherwise walks by degrees a view). Where a
// ring starts the camera tilts, and nothing is held.
enum class Hinge { Free, PanAxis };

IcpPosePrior tripod_prior(const TripodMotion& m, const Isometry3d& guess,
                          const AlignmentOptions& o, PriorStrength strength, Hinge hinge) {
  IcpPosePrior prior;
  prior.T_target_source = guess;
  prior.T_target_source.translation() = m.predicted_centre(guess);
  prior.centre_sigma_m = kTripodCentreSigmaM;
  prior.rotation_sigma_deg = kGuessRotationSigmaDeg;
  prior.point_sigma_m = 0.5 * o.voxel_size;
  prior.per_correspondence = strength == PriorStrength::Firm;
  if (hinge == Hinge::PanAxis && m.hinge_axis) {
    prior.T_target_source.linear() = m.on_hinge(guess.linear());
    prior.hinge_axis = m.hinge_axis;
    prior.off_axis_sigma_deg = kHeldOffAxisSigmaDeg;
  }
  return prior;
}

class TripodSearch {
 public:
  TripodSearch(const AlignmentState& s, const Target& model, std::size_t frame,
               const TripodMotion& m, const Isometry3d& T_last)
      : s_(s), o_(s.options), model_(model), frame_(frame), m_(m), T_last_(T_last) {}

  // Screens the guesses, refines the fittest few that respect the tripod, keeps the best.
  // forward_only: the turn keeps its direction (not where a ring starts).
  void run(const std::vector<Guess>& guesses, double max_turn_deg, bool forward_only) {
    std::vector<Candidate> screened;
    for (const Guess& g : guesses) {
      IcpResult r = screen(s_.prepared[frame_].coarse, model_, g.T, o_,
                           tripod_prior(m_, g.T, o_, PriorStrength::Firm, hinge_));
      if (!r.success && r.correspondences == 0) continue;
      if (rotation_difference_deg(g.T, r.T_target_source) > kMaxWanderDeg) continue;
      if (!tripod_violation(r.T_target_source, T_last_, m_, o_, max_turn_deg, forward_only)
               .empty())
        continue;
      screened.push_back({std::move(r), g.label});
    }
    std::stable_sort(screened.begin(), screened.end(), [](const auto& a, const auto& b) {
      return better(a.result, b.result);
    });
    std::vector<Isometry3d> refined_from;
    for (const Candidate& c : screened) {
      if (refined_from.size() >= o_.tripod_refined_guesses) break;
      const bool repeat = std::any_of(refined_from.begin(), refined_from.end(), [&](const auto& T) {
        return rotation_difference_deg(T, c.result.T_target_source) < 1.0 &&
               translation_difference_m(T, c.result.T_target_source) < 2.0 * o_.voxel_size;
      });
      if (repeat) continue;
      refined_from.push_back(c.result.T_target_source);
      refine_on_tripod(c.result.T_target_source, c.label, max_turn_deg, forward_only);
    }
  }

  // Refines from `init` with the light prior, and with the firm one where the light one lets
  // the camera leave the tripod.
  void refine_on_tripod(const Isometry3d& init, const char* label, double max_turn_deg,
                        bool forward_only) {
    IcpResult light = refine_from(init, PriorStrength::Light, hinge_);
    if (rotation_difference_deg(init, light.T_target_source) > kMaxWanderDeg) {
      // The light prior let the data turn the view off its guess's basin: data that do not fix
      // the turn (one wall seen aslant) or a wrong guess. Within a ring, where the guesses are
      // the tripod's turns, the firm prior's result is kept as a last resort, for when no guess
      // holds with the light one (generated room 33's view 27). Not where a ring starts: its
      // guesses are tilts 10 degrees apart, and the firm prior would hold a wrong one (room 2).
      // Refined only when needed: most views take a light result.
      if (forward_only) last_resorts_.push_back({label, init, max_turn_deg, hinge_});
      return;
    }
    const bool slid =
        !tripod_violation(light.T_target_source, T_last_, m_, o_, max_turn_deg, forward_only)
             .empty();
    if (consider(std::move(light), label, max_turn_deg, forward_only)) {
      best_init_ = init;
      best_limits_ = {max_turn_deg, forward_only};
      best_is_firm_ = false;
      best_hinge_ = hinge_;
    }
    if (!slid) return;
    take_firm(refine_from(init, PriorStrength::Firm, hinge_), label, init, max_turn_deg,
              forward_only, hinge_);
  }

  // The firm prior's results from the turn guesses kept as a last resort, where no guess was
  // accepted so far (only turns within a ring keep one).
  void take_last_resorts() {
    if (accepted_) return;
    for (const LastResort& r : last_resorts_)
      take_firm(refine_from(r.init, PriorStrength::Firm, r.hinge), r.label, r.init,
                r.max_turn_deg, true, r.hinge);
    last_resorts_.clear();
  }

  // The light prior's winner, checked against the firm prior from the same guess: where the
  // data lets the camera drift more than kMaxDataSlideM from where the tripod holds it, the
  // data does not fix the position (a wall seen square on slides freely) and the tripod's
  // place is the better estimate. The self-check trusts the tripod for a view's position, so
  // tracking must not let the data move it unheld.
  void settle() {
    if (!accepted_ || best_is_firm_) return;
    IcpResult firm = refine_from(best_init_, PriorStrength::Firm, best_hinge_);
    const Eigen::Vector3d shift =
        view_.best->T_target_source.translation() - firm.T_target_source.translation();
    const double slide = shift.norm();
    if (slide <= kMaxDataSlideM && !unsupported_slide(shift)) return;
    if (!tripod_violation(firm.T_target_source, T_last_, m_, o_, best_limits_.first,
                          best_limits_.second)
             .empty() ||
        !acceptable(firm, o_, o_.min_fitness))
      return;
    view_.best = std::move(firm);
    best_is_firm_ = true;
  }

  // Whether the light prior's result moved the camera from the firm one's along a direction
  // the view's own points do not fix (translation_constraint below the check's minimum): a
  // bare wall's slide, which the data's noise - or a texture's aliased gradients - decides
  // rather than its surfaces. Such a slide is not evidence, however small; kept, it also moves
  // every later view, whose tripod prior starts from this one (generated room 75: 12-20 mm a
  // view past a near bare wall, 57 mm by the fifth).
  bool unsupported_slide(const Eigen::Vector3d& shift) const {
    if (shift.norm() < kMinJudgedSlideM) return false;
    const Eigen::Vector3d in_camera = view_.best->T_target_source.linear().transpose() * shift;
    return translation_constraint(s_, frame_, in_camera) < o_.view_check.min_constraint;
  }

  // Keeps `r` when it is the best acceptable result so far; true when it was kept.
  bool consider(IcpResult r, const char* label, double max_turn_deg, bool forward_only) {
    const std::string violation =
        tripod_violation(r.T_target_source, T_last_, m_, o_, max_turn_deg, forward_only);
    const bool ok = violation.empty() && acceptable(r, o_, o_.min_fitness);
    if (ok && (!accepted_ || better(r, view_.best.value()))) {
      view_.best = std::move(r);
      view_.initialisation = label;
      accepted_ = true;
      return true;
    }
    if (!accepted_ && (!view_.best || better(r, *view_.best))) {
      view_.failure = violation.empty() ? rejection(r, o_, o_.min_fitness) : violation;
      view_.best = std::move(r);
    }
    return false;
  }

  // The frame refined from `init` with the tripod prior of that strength and hinge.
  IcpResult refine_from(const Isometry3d& init, PriorStrength strength, Hinge hinge) const {
    return refine(s_.prepared[frame_].cloud, s_.prepared[frame_].coarse, model_, init, o_,
                  tracking_method(o_), tripod_prior(m_, init, o_, strength, hinge));
  }

  void take_firm(IcpResult firm, const char* label, const Isometry3d& init, double max_turn_deg,
                 bool forward_only, Hinge hinge) {
    if (rotation_difference_deg(init, firm.T_target_source) > kMaxWanderDeg) return;
    if (consider(std::move(firm), label, max_turn_deg, forward_only)) {
      best_init_ = init;
      best_is_firm_ = true;
      best_hinge_ = hinge;
    }
  }

  void hold(Hinge hinge) { hinge_ = hinge; }
  bool accepted() const { return accepted_; }
  const Isometry3d& best_init() const { return best_init_; }
  TrackedView& view() { return view_; }

 private:
  const AlignmentState& s_;
  const AlignmentOptions& o_;
  const Target& model_;
  std::size_t frame_;
  const TripodMotion& m_;
  Isometry3d T_last_;
  TrackedView view_;
  bool accepted_ = false;
  Isometry3d best_init_ = Isometry3d::Identity();
  std::pair<double, bool> best_limits_{0.0, false};
  bool best_is_firm_ = false;
  Hinge hinge_ = Hinge::Free;
  Hinge best_hinge_ = Hinge::Free;
  struct LastResort {  // a guess within a ring (forward only)
    const char* label;
    Isometry3d init;
    double max_turn_deg;
    Hinge hinge;
  };
  std::vector<LastResort> last_resorts_;
};

}  // namespace

TrackedView register_tripod_view(const AlignmentState& s, const Target& model, std::size_t frame,
                                 std::size_t piece) {
  const AlignmentOptions& o = s.options;
  const std::vector<std::size_t> views = piece_views(s, piece);
  const TripodMotion m = tripod_motion(s, views);
  const Isometry3d& T_last = s.tracked_pose(views.back());
  TripodSearch search(s, model, frame, m, T_last);

  // A ring is entered until one of its views is registered: its first views are searched
  // with tilts, from the last view and from the previous ring's first registered view.
  const std::vector<std::size_t> starts = ring_starts(o);
  const auto ring_of = [&](std::size_t f) {
    return static_cast<std::size_t>(std::upper_bound(starts.begin(), starts.end(), f) -
                                    starts.begin());
  };
  const std::size_t ring = ring_of(frame);
  const bool starts_ring =
      ring > 1 && std::none_of(views.begin(), views.end(),
                               [&](std::size_t f) { return ring_of(f) == ring; });
  if (!starts_ring) {
    // Where the view's geometry does not fix its rotation (a wall seen square on), the hinge
    // does, and its turns start from the last pose put back on its ring; elsewhere the data
    // decides, as an axis voted from a short turn is less sure than a well-fixed view.
    const bool held = pose_constraint(s.prepared[frame].cloud, true) < o.view_check.min_constraint;
    search.hold(held ? Hinge::PanAxis : Hinge::Free);
    Isometry3d base = T_last;
    if (held) base.linear() = m.on_hinge(T_last.linear());
    std::vector<Guess> guesses;
    if (m.pan_axis)
      search.refine_on_tripod(turned(base, *m.pan_axis, m.last_step_rad), "tripod prediction",
                              o.max_tripod_step_deg + 5.0, true);
    add_turns(guesses, base, m, o);
    search.run(guesses, o.max_tripod_step_deg + 5.0, true);
    search.take_last_resorts();
  }
  search.hold(Hinge::Free);
  const double max_tilt_turn = std::hypot(o.max_tripod_step_deg, o.max_tripod_tilt_deg);
  if (!search.accepted()) {
    std::vector<Guess> guesses;
    add_tilts(guesses, T_last, m, o);
    if (starts_ring) {
      // The ring below is entered where it began, from its first view put back on its ring:
      // a first view that one bare wall let roll about its normal would pass its roll to the
      // whole new ring (generated room 33: 8 degrees).
      const auto first = std::find_if(views.begin(), views.end(),
                                      [&](std::size_t f) { return ring_of(f) == ring - 1; });
      if (first != views.end()) {
        const auto k = static_cast<std::size_t>(first - views.begin());
        Isometry3d entry = s.tracked_pose(*first);
        if (m.fit && m.fit->off_axis_deg[k] >= TripodFitOptions{}.inlier_deg)
          entry.linear() = onto_its_ring(*m.fit, k, entry.linear());
        add_tilts(guesses, entry, m, o);
      }
    }
    search.run(guesses, max_tilt_turn, false);
  }
  if (!search.accepted()) {
    const auto g = features(s.prepared[frame].cloud, model.fine,
                            m.centre.cast<float>(), o, frame);
    if (g.ransac.success)
      search.refine_on_tripod(g.ransac.T_target_source, "features", max_tilt_turn, false);
  }
  search.settle();
  if (search.accepted()) search.view().T_world_camera_initial = search.best_init();
  TrackedView view = std::move(search.view());
  if (search.accepted()) view.failure.clear();
  if (!view.best) view.failure = "no guess overlapped the model";
  return view;
}

}  // namespace locard::alignment_detail
