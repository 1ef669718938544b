// Stage 5 of align_sequence: every registered view checked against the model of the other
// views (ViewCheckOptions in sequential_alignment.hpp says what is tested and why).
#include "alignment/alignment_stages.hpp"
#include "alignment/tripod_fit.hpp"

#include "core/floor_to_int.hpp"

#include <locard/core/kdtree.hpp>
#include <locard/preprocess/point_selection.hpp>
#include <locard/registration/color_gradient.hpp>

#include <Eigen/Eigenvalues>
#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <unordered_map>

namespace locard::alignment_detail {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

// The RMS distance of a view's points from its camera: the lever that turns a rotation into
// metres, so rotation and translation share one scale in the information matrices below.
double rms_lever(const PointCloud& cloud) {
  double lever2 = 0.0;
  for (const Eigen::Vector3f& p : cloud.positions) lever2 += p.squaredNorm();
  return std::sqrt(std::max(lever2 / static_cast<double>(cloud.size()), 1e-12));
}

// Per-point normal matrix of a view's own points, J = [p x n / lever, n] (camera frame, the
// rotation scaled by the RMS lever arm), averaged; zero without normals.
Matrix6d normal_information(const PointCloud& cloud) {
  Matrix6d A = Matrix6d::Zero();
  if (!cloud.has_normals() || cloud.empty()) return A;
  const double lever = rms_lever(cloud);
  for (std::size_t k = 0; k < cloud.size(); ++k) {
    const Eigen::Vector3d p = cloud.positions[k].cast<double>();
    const Eigen::Vector3d n = cloud.normals[k].cast<double>();
    Eigen::Matrix<double, 6, 1> j;
    j << p.cross(n) / lever, n;
    A += j * j.transpose();
  }
  A /= static_cast<double>(cloud.size());
  return A;
}

// The colour term's share of that matrix (Park et al. 2017; color_gradient.hpp): J =
// sqrt(kColorTermWeight) [p x d / lever, d] per point, d its colour gradient over the surface,
// averaged over all the view's points like the geometric matrix. Only gradients that stand
// kSignificantGradient standard errors above the colour's noise count: a plain wall's noise
// must not pass for a texture that fixes the slide.
constexpr double kSignificantGradient = 3.0;

Matrix6d compute_color_information(const PointCloud& cloud, double voxel_size) {
  Matrix6d A = Matrix6d::Zero();
  if (!cloud.has_normals() || !cloud.has_colors() || cloud.empty()) return A;
  const KdTree tree(cloud.positions);
  std::vector<float> error;
  const std::vector<Eigen::Vector3f> gradient =
      surface_color_gradients(cloud, tree, intensities_of(cloud.colors), voxel_size, &error);
  const double lever = rms_lever(cloud);
  for (std::size_t k = 0; k < cloud.size(); ++k) {
    if (!(gradient[k].norm() > kSignificantGradient * error[k])) continue;
    const Eigen::Vector3d p = cloud.positions[k].cast<double>();
    const Eigen::Vector3d d = gradient[k].cast<double>();
    Eigen::Matrix<double, 6, 1> j;
    j << p.cross(d) / lever, d;
    A += kColorTermWeight * j * j.transpose();
  }
  A /= static_cast<double>(cloud.size());
  return A;
}

// The same, made once per frame (PreparedFrame::color_information).
const Matrix6d& color_information(const AlignmentState& s, std::size_t i) {
  const PreparedFrame& frame = s.prepared[i];
  if (!frame.color_information)
    frame.color_information = compute_color_information(frame.cloud, s.options.voxel_size);
  return *frame.color_information;
}

// Its smallest eigenvalue: over the rotation only (tripod) or all six directions (video).
double weakest_direction(const Matrix6d& A, bool rotation_only) {
  if (rotation_only)
    return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(A.topLeftCorner<3, 3>()).eigenvalues()(0);
  return Eigen::SelfAdjointEigenSolver<Matrix6d>(A).eigenvalues()(0);
}

// How firmly it fixes the turn about `axis` (camera frame, unit): a tripod's pan, with tilt
// and roll held by the ring.
double turn_constraint(const Matrix6d& A, const Eigen::Vector3d& axis) {
  return axis.dot(A.topLeftCorner<3, 3>() * axis);
}


// The constraint a view needs: over the rotation on a tripod turn, all six directions on video.
bool rotation_only(const AlignmentOptions& o) { return o.mode == AlignmentMode::Cumulative; }
double min_constraint(const AlignmentOptions& o) {
  return rotation_only(o) ? o.view_check.min_constraint : o.view_check.min_constraint_6dof;
}

// How firmly a view's own points fix where its camera stands: the eigen-decomposition
// (camera frame, smallest first) of the translation block of its information - geometry, and
// the colour term's significant gradients where the geometry leaves the slide free
// (translation_constraint's rule).
struct SlideConstraint {
  Eigen::Vector3d eigenvalues = Eigen::Vector3d::Zero();
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();  // columns
  int free_axes(double needed) const {
    return static_cast<int>((eigenvalues.array() < needed).count());
  }
  // The length of v's part along the first k (the free) axes.
  double along_free(const Eigen::Vector3d& v, int k) const {
    return (axes.leftCols(k).transpose() * v).norm();
  }
};

SlideConstraint slide_constraint(const AlignmentState& s, std::size_t i, const Matrix6d& geometry) {
  const auto translation = [](const Matrix6d& A) {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(A.bottomRightCorner<3, 3>());
    return SlideConstraint{es.eigenvalues(), es.eigenvectors()};
  };
  const SlideConstraint geometric = translation(geometry);
  if (geometric.eigenvalues(0) >= s.options.view_check.min_constraint || !s.options.refinement_color)
    return geometric;
  return translation(geometry + color_information(s, i));
}

// What a view's own points say of its pose, computed once per check (the rounds reuse it): the
// geometric information and, where colour is registered to depth and the geometry leaves a
// direction free, the colour term's (it costs a gradient fit over the view).
struct ViewInformation {
  Matrix6d geometry = Matrix6d::Zero();
  std::optional<Matrix6d> color;
};

ViewInformation view_information(const AlignmentState& s, std::size_t i) {
  const PointCloud& cloud = s.prepared[i].cloud;
  ViewInformation v;
  v.geometry = normal_information(cloud);
  if (s.options.refinement_color &&
      weakest_direction(v.geometry, rotation_only(s.options)) < min_constraint(s.options))
    v.color = color_information(s, i);
  return v;
}

}  // namespace

double translation_constraint(const AlignmentState& s, std::size_t i,
                              const Eigen::Vector3d& direction) {
  const PointCloud& cloud = s.prepared[i].cloud;
  const Eigen::Vector3d d = direction.normalized();
  const double geometry = d.dot(normal_information(cloud).bottomRightCorner<3, 3>() * d);
  if (geometry >= s.options.view_check.min_constraint || !s.options.refinement_color)
    return geometry;
  return geometry + d.dot(color_information(s, i).bottomRightCorner<3, 3>() * d);
}

namespace {

// One world voxel of the multi-view model: sums for the centroid and normal, and which views
// saw it (a 64-bit Bloom mask of view ids: "contains" may say yes for another view with the
// same id mod 64, which only makes the leave-one-out support smaller, never larger).
struct ModelVoxel {
  Eigen::Vector3f position_sum = Eigen::Vector3f::Zero();
  Eigen::Vector3f normal_sum = Eigen::Vector3f::Zero();
  Eigen::Vector3f color_sum = Eigen::Vector3f::Zero();
  std::uint32_t points = 0;
  std::uint32_t views = 0;
  std::uint64_t view_mask = 0;
  std::size_t last_view = SIZE_MAX;

  std::uint32_t support_without(std::size_t view) const {
    const bool mine = (view_mask >> (view % 64)) & 1u;
    return views - (mine ? 1u : 0u);
  }
};

struct ViewModel {
  std::vector<ModelVoxel> voxels;
};

std::uint64_t voxel_key(const Eigen::Vector3f& p, float inverse_size) {
  const auto axis = [&](float x) {
    return static_cast<std::uint64_t>(locard::detail::floor_to_int<std::int64_t>(x * inverse_size) + (1 << 20)) & 0x1fffff;
  };
  return axis(p.x()) | axis(p.y()) << 21 | axis(p.z()) << 42;
}

ViewModel build_model(const AlignmentState& s, const std::vector<char>& excluded) {
  const float inverse = static_cast<float>(1.0 / s.options.voxel_size);
  std::unordered_map<std::uint64_t, std::uint32_t> slot;
  ViewModel model;
  for (std::size_t i = 0; i < s.n; ++i) {
    const FrameAlignment& f = s.result.frames[i];
    if (f.status != FrameStatus::Registered || !f.T_world_camera_final || excluded[i]) continue;
    const Eigen::Isometry3f T = f.T_world_camera_final->cast<float>();
    const PointCloud& c = s.prepared[i].cloud;
    for (std::size_t k = 0; k < c.size(); ++k) {
      const Eigen::Vector3f p = T * c.positions[k];
      if (!p.allFinite()) continue;
      auto [it, inserted] = slot.emplace(voxel_key(p, inverse),
                                         static_cast<std::uint32_t>(model.voxels.size()));
      if (inserted) model.voxels.emplace_back();
      ModelVoxel& v = model.voxels[it->second];
      v.position_sum += p;
      if (c.has_normals()) v.normal_sum += T.linear() * c.normals[k];
      if (c.has_colors()) v.color_sum += Eigen::Vector3f(c.colors[k].r, c.colors[k].g, c.colors[k].b);
      ++v.points;
      if (v.last_view != i) {
        v.last_view = i;
        ++v.views;
        v.view_mask |= std::uint64_t{1} << (i % 64);
      }
    }
  }
  return model;
}

// The others' model around view i: voxels inside the box spanned by the view's points and its
// camera centre (where its rays run), seen by at least one other view.
struct OthersModel {
  PointCloud surface;          // support >= 1, with normals
  std::vector<char> confirmed;  // support >= 2: used for the free-space test
};

OthersModel others_model(const ViewModel& model, std::size_t view, const Eigen::Vector3f& lo,
                         const Eigen::Vector3f& hi) {
  OthersModel out;
  for (const ModelVoxel& v : model.voxels) {
    const std::uint32_t support = v.support_without(view);
    if (support == 0) continue;
    const Eigen::Vector3f p = v.position_sum / static_cast<float>(v.points);
    if ((p.array() < lo.array()).any() || (p.array() > hi.array()).any()) continue;
    out.surface.positions.push_back(p);
    const float norm = v.normal_sum.norm();
    out.surface.normals.push_back(norm > 0.f ? Eigen::Vector3f(v.normal_sum / norm)
                                             : Eigen::Vector3f::UnitZ());
    out.confirmed.push_back(support >= 2);
    const Eigen::Vector3f rgb = (v.color_sum / static_cast<float>(v.points)).array().round();
    out.surface.colors.push_back({static_cast<std::uint8_t>(rgb.x()), static_cast<std::uint8_t>(rgb.y()),
                                  static_cast<std::uint8_t>(rgb.z())});
  }
  return out;
}

// Share of the others' confirmed surface points in the view's image that the view's depth
// lies behind (it sees through them). The depth behind a point must hold over the point's
// 3x3 pixel neighbourhood, so mixed pixels at depth edges do not count.
double free_space_share(const AlignmentState& s, std::size_t i, const OthersModel& others) {
  const FrameAlignment& f = s.result.frames[i];
  const DepthImage depth = s.sequence.load_depth(f.sequence_index);
  const CameraIntrinsics& K = s.sequence.intrinsics;
  const double scale = s.sequence.depth_scale;
  const Eigen::Isometry3f T_camera_world = f.T_world_camera_final->inverse().cast<float>();
  const double v = s.options.voxel_size;
  std::size_t agree = 0, through = 0;
  for (std::size_t k = 0; k < others.surface.size(); ++k) {
    if (!others.confirmed[k]) continue;
    const Eigen::Vector3f p = T_camera_world * others.surface.positions[k];
    const double z = p.z();
    if (z < s.options.min_depth_m || z > s.options.max_depth_m) continue;
    const int u = static_cast<int>(std::lround(K.fx * p.x() / z + K.cx));
    const int r = static_cast<int>(std::lround(K.fy * p.y() / z + K.cy));
    if (u < 1 || r < 1 || u + 1 >= depth.width() || r + 1 >= depth.height()) continue;
    double nearest = INFINITY;
    bool any = false;
    for (int dr = -1; dr <= 1; ++dr)
      for (int du = -1; du <= 1; ++du) {
        const std::uint16_t raw = depth.at(u + du, r + dr);
        if (raw == 0) continue;
        any = true;
        nearest = std::min(nearest, raw / scale);
      }
    if (!any) continue;
    // Beyond three voxels and three times a structured-light sensor's axial noise.
    const double margin = 3.0 * v + 0.0075 * z * z;
    if (nearest > z + margin) ++through;
    else if (std::abs(nearest - z) <= margin) ++agree;
  }
  const std::size_t seen = agree + through;
  return seen ? static_cast<double>(through) / static_cast<double>(seen) : 0.0;
}

// Tripod turn, over the views of one piece: each view's angle off its ring and its centre's distance
// from the nodal model (tripod_fit.hpp); NaN where the views make no tripod fit.
struct TripodConsistency {
  std::vector<double> off_axis_deg, residual_m;
  // Per view, its camera centre less the nodal model's (c - P - R d), in its camera frame.
  std::vector<Eigen::Vector3d> residual_camera;
  std::optional<Eigen::Vector3d> axis;  // the pan axis, world frame
  // The tripod's play: RMS distance from the nodal model of the views whose own surfaces fix
  // all six degrees of freedom (infinite with fewer than kPlayViews of them).
  double play_m = std::numeric_limits<double>::infinity();
};

constexpr std::size_t kPlayViews = 5;

// `together`: the positions in `views` of those that stand together (densest_centres).
TripodConsistency tripod_consistency(const AlignmentState& s, const std::vector<std::size_t>& views,
                                     const std::vector<std::size_t>& together,
                                     const std::vector<ViewInformation>& information) {
  TripodConsistency out;
  out.off_axis_deg.assign(s.n, std::numeric_limits<double>::quiet_NaN());
  out.residual_m = out.off_axis_deg;
  out.residual_camera.assign(s.n, Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
  if (s.options.mode != AlignmentMode::Cumulative) return out;
  std::vector<Eigen::Matrix3d> R;
  std::vector<Isometry3d> T;
  for (std::size_t i : views) {
    T.push_back(*s.result.frames[i].T_world_camera_final);
    R.push_back(T.back().linear());
  }
  const std::optional<TripodFit> fit = turn_fit(s.options, R);
  if (!fit) return out;
  // The nodal model of the views that stand together (densest_centres) on their ring: where
  // tracking left arcs of the turn tens of centimetres apart, or whole rings tilted off the
  // pan axis, a fit to all of them fits none, and every view is then flagged as off the
  // tripod - the good arc or ring with the wrong ones (generated rooms 30 and 45).
  std::vector<Isometry3d> standing, on_ring;
  for (std::size_t k : together) {
    standing.push_back(T[k]);
    if (fit->off_axis_deg[k] <= s.options.view_check.max_off_axis_deg) on_ring.push_back(T[k]);
  }
  NodalFit nodal = fit_nodal(on_ring.size() >= kPlayViews ? on_ring : standing);
  nodal.residual_m.clear();
  for (const Isometry3d& t : T) nodal.residual_m.push_back(nodal.residual(t));
  out.axis = fit->axis;
  double sum2 = 0.0;
  std::size_t fixed = 0;
  for (std::size_t k = 0; k < views.size(); ++k) {
    if (weakest_direction(information[k].geometry, false) < s.options.view_check.min_constraint_6dof ||
        nodal.residual_m[k] > s.options.view_check.max_tripod_residual_m)
      continue;
    sum2 += nodal.residual_m[k] * nodal.residual_m[k];
    ++fixed;
  }
  if (fixed >= kPlayViews) out.play_m = std::sqrt(sum2 / static_cast<double>(fixed));
  for (std::size_t k = 0; k < views.size(); ++k) {
    out.off_axis_deg[views[k]] = fit->off_axis_deg[k];
    out.residual_m[views[k]] = nodal.residual_m[k];
    out.residual_camera[views[k]] =
        R[k].transpose() * (T[k].translation() - nodal.pivot) - nodal.offset;
  }
  return out;
}

// The check's ICP runs on an even sample of the view: its correction and overlap are averages
// over thousands of points, as good from 4000 as from a whole frame (10-20 thousand), and the
// check of a long video is dominated by these searches.
constexpr std::size_t kCheckPoints = 4000;

PointCloud check_sample(const PointCloud& cloud) {
  if (cloud.size() <= kCheckPoints) return cloud;
  std::vector<std::uint32_t> keep;
  const double step = static_cast<double>(cloud.size()) / static_cast<double>(kCheckPoints);
  for (std::size_t k = 0; k < kCheckPoints; ++k)
    keep.push_back(static_cast<std::uint32_t>(static_cast<double>(k) * step));
  return select_points(cloud, keep);
}

// Where a view's check looks: the box spanned by its points and its camera centre, widened by
// the model's margin (others_model).
struct CheckBox {
  Eigen::Vector3f lo, hi;
};

CheckBox check_box(const AlignmentState& s, std::size_t i) {
  const Isometry3d& T = *s.result.frames[i].T_world_camera_final;
  Eigen::Vector3f lo = T.translation().cast<float>(), hi = lo;
  const Eigen::Isometry3f Tf = T.cast<float>();
  for (const Eigen::Vector3f& p : s.prepared[i].cloud.positions) {
    const Eigen::Vector3f q = Tf * p;
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  const float margin = static_cast<float>(4.0 * s.options.voxel_size);
  return {lo.array() - margin, hi.array() + margin};
}

// Where the camera stands, on a tripod turn: the view's own points fix it along the
// directions where they face a surface; along the others (a bare wall: the slide along it)
// nothing the check's ICP sees does. There the true centre is the nodal model's, give or take
// the tripod's measured play (the turn's scatter about the model, split evenly over three
// axes), and the estimate may stand off the model as well (weak data pulled it). Its error
// there is at most that offset plus 2.5 sigma of the play; the view is vouched for where this
// stays within the bar a verified view meets (as a view held by the tripod is).
struct SlideJudgement {
  double constraint = 0.0;    // smallest eigenvalue (ViewCheck::slide_constraint)
  int free_axes = 0;          // below min_constraint (0 on video: its check sees all six)
  double play_m = 0.0;        // the tripod's measured play (inf: unmeasured)
  double sigma_m = 0.0;       // the play along the free axes
  double off_model_m = 0.0;   // the estimate's offset from the nodal model along them
  double bound_m = 0.0;       // offset + 2.5 sigma (inf: no tripod model)
  bool held = true;
};

SlideJudgement judge_slide(const AlignmentState& s, std::size_t i, const Matrix6d& information,
                           double tripod_play_m, const Eigen::Vector3d& tripod_residual_camera) {
  const ViewCheckOptions& limits = s.options.view_check;
  const SlideConstraint slide = slide_constraint(s, i, information);
  SlideJudgement j;
  j.constraint = slide.eigenvalues(0);
  j.play_m = tripod_play_m;
  j.free_axes = rotation_only(s.options) ? slide.free_axes(limits.min_constraint) : 0;
  if (j.free_axes == 0) return j;
  j.sigma_m = tripod_play_m * std::sqrt(static_cast<double>(j.free_axes) / 3.0);
  j.off_model_m = slide.along_free(tripod_residual_camera, j.free_axes);
  j.bound_m = std::isfinite(j.off_model_m) ? j.off_model_m + 2.5 * j.sigma_m
                                           : std::numeric_limits<double>::infinity();
  j.held = j.bound_m <= limits.max_error_m;
  return j;
}

std::string slide_reason(const SlideJudgement& j, const ViewCheckOptions& limits) {
  const std::string what = fmt::format(
      "its points do not fix where its camera stands along {} {} (constraint {:.4f}, need >= "
      "{:.3f}: a bare wall)",
      j.free_axes, j.free_axes > 1 ? "axes" : "axis", j.constraint, limits.min_constraint);
  if (!std::isfinite(j.bound_m))
    return what + ", and the tripod cannot place it (too few views fix themselves to measure "
                  "its play, or the views make no tripod fit)";
  return what + fmt::format(", and there it stands {:.1f} mm off the tripod's nodal model, whose "
                            "play ({:.1f} mm) adds {:.1f} mm at 2.5 sigma (allowed {:.0f} mm in all)",
                            1000 * j.off_model_m, 1000 * j.play_m, 2500 * j.sigma_m,
                            1000 * limits.max_error_m);
}

// Confidence: the smallest margin to any limit, 1 far inside all of them, 0 at or past one.
double view_confidence(const ViewCheck& c, const ViewCheckOptions& limits, double max_correction_m,
                       double max_correction_deg, double needed, const SlideJudgement& slide) {
  const auto below = [](double value, double limit) {
    return std::clamp(1.0 - value / limit, 0.0, 1.0);
  };
  const auto above = [](double value, double limit, double good) {
    return std::clamp((value - limit) / (good - limit), 0.0, 1.0);
  };
  const double off_axis = std::isfinite(c.off_axis_deg) ? c.off_axis_deg : 0.0;
  const double off_tripod = std::isfinite(c.tripod_residual_m) ? c.tripod_residual_m : 0.0;
  return std::min({below(c.correction_m, max_correction_m),
                   below(off_axis, limits.max_off_axis_deg),
                   below(off_tripod, limits.max_tripod_residual_m),
                   below(c.correction_deg, max_correction_deg),
                   below(c.free_space, limits.max_free_space),
                   above(c.overlap, limits.min_overlap, 1.0),
                   above(c.constraint, needed, 5.0 * needed),
                   slide.free_axes == 0 ? 1.0 : below(slide.bound_m, limits.max_error_m)});
}

constexpr std::string_view kAlone = "no other view overlaps it";
constexpr std::string_view kAllFlagged = "; and every view that overlaps it is flagged too";

ViewCheck check_view(const AlignmentState& s, const ViewModel& model, std::size_t i,
                     const Eigen::Vector3d& tripod_centre, double off_axis_deg,
                     double tripod_residual_m, const Eigen::Vector3d& tripod_residual_camera,
                     const std::optional<Eigen::Vector3d>& pan_axis,
                     double tripod_play_m, const ViewInformation& own, const CheckBox& box) {
  const AlignmentOptions& o = s.options;
  const ViewCheckOptions& limits = o.view_check;
  const FrameAlignment& f = s.result.frames[i];
  const PointCloud& cloud = s.prepared[i].cloud;
  const Isometry3d& T = *f.T_world_camera_final;
  ViewCheck c;
  c.checked = true;
  const Matrix6d& information = own.geometry;
  const double needed = min_constraint(o);
  c.constraint = weakest_direction(information, rotation_only(o));
  // A view whose geometry leaves a direction free that its colour's texture fixes: checked by
  // coloured ICP, judged by both terms' constraint (color_information).
  if (own.color && c.constraint < needed) {
    const double both = weakest_direction(information + *own.color, rotation_only(o));
    if (both >= needed) {
      c.constraint = both;
      c.fixed_by_color = true;
    }
  }
  c.off_axis_deg = off_axis_deg;
  c.tripod_residual_m = tripod_residual_m;
  // A tripod turn's view whose surfaces leave a tilt or roll free (a bare wall: the turn about
  // its normal) but fix the pan: the tripod holds the rest - the ring its tilt and roll, the
  // head its centre. It is checked as the tripod moves it (pan free, the rest held), judged by
  // the pan's constraint, and held to the ring more tightly than a view that fixes itself.
  // Only as good as the tripod's play, then: allowed when a slide of 2.5 sigma along two free
  // axes stays within the bar a verified view meets (max_error_m).
  const bool play_small = 2.5 * std::sqrt(2.0 / 3.0) * tripod_play_m <= limits.max_error_m;
  const double pan = pan_axis ? turn_constraint(information, T.linear().transpose() * *pan_axis)
                             : 0.0;
  const bool held_by_tripod =
      !c.fixed_by_color && rotation_only(o) && play_small &&
      std::isfinite(off_axis_deg) &&
      std::isfinite(tripod_residual_m) && c.constraint < limits.min_constraint &&
      pan >= limits.min_constraint;
  if (held_by_tripod) c.constraint = pan;
  const SlideJudgement slide = judge_slide(s, i, information, tripod_play_m, tripod_residual_camera);
  c.slide_constraint = slide.constraint;
  c.tripod_play_m = tripod_play_m;

  const OthersModel others = others_model(model, i, box.lo, box.hi);

  std::vector<std::string> reasons;
  if (others.surface.size() < 50) {
    c.reason = std::string(kAlone);
    return c;
  }
  const PointCloud source = check_sample(cloud);
  IcpOptions icp_options;
  icp_options.method = c.fixed_by_color ? IcpMethod::Colored : IcpMethod::PointToPlane;
  icp_options.min_fitness = 0.0;
  icp_options.max_correspondence_distance = 2.0 * o.voxel_size;
  icp_options.convergence.max_iterations = 20;
  if (held_by_tripod) {
    IcpPosePrior tripod;
    tripod.T_target_source = T;
    tripod.centre_sigma_m = kOnTripodM;
    tripod.rotation_sigma_deg = 30.0;  // the pan: as good as free
    tripod.per_correspondence = true;
    tripod.hinge_axis = *pan_axis;
    tripod.off_axis_sigma_deg = 0.1;
    icp_options.pose_prior = tripod;
  }
  // The others' model is prepared once for both passes (its kd-tree is most of a short run),
  // except that coloured ICP's gradients are taken over twice the gate, which the fine pass
  // halves.
  const IcpTarget target(others.surface, icp_options);
  IcpResult r = icp(source, target, T, icp_options);
  c.overlap = r.fitness;
  if (r.success) {
    icp_options.max_correspondence_distance = o.voxel_size;
    icp_options.convergence.max_iterations = 15;
    const IcpResult fine =
        c.fixed_by_color
            ? icp(source, others.surface, r.T_target_source, icp_options)
            : icp(source, target, r.T_target_source, icp_options);
    if (fine.success) r = fine;
  }
  if (!r.success) {
    reasons.push_back("does not register against the other views: " + r.reason);
  } else {
    c.correction_m = translation_difference_m(T, r.T_target_source);
    c.correction_deg = rotation_difference_deg(T, r.T_target_source);
    c.residual_m = r.inlier_rmse;
  }
  c.free_space = free_space_share(s, i, others);

  if (c.overlap < limits.min_overlap)
    reasons.push_back(fmt::format("overlap with the other views {:.0f} % (need >= {:.0f} %)",
                                  100 * c.overlap, 100 * limits.min_overlap));
  const double max_correction_m =
      rotation_only(o) ? limits.max_error_m : limits.max_video_correction_m;
  const double max_correction_deg =
      rotation_only(o) ? limits.max_error_deg : limits.max_video_correction_deg;
  if (r.success && (c.correction_m > max_correction_m || c.correction_deg > max_correction_deg))
    reasons.push_back(fmt::format("the other views place it {:.1f} mm / {:.2f} deg away "
                                  "(allowed {:.0f} mm / {:.1f} deg)",
                                  1000 * c.correction_m, c.correction_deg,
                                  1000 * max_correction_m, max_correction_deg));
  if (c.free_space > limits.max_free_space)
    reasons.push_back(fmt::format("sees through {:.0f} % of the surfaces other views saw "
                                  "(allowed {:.0f} %)",
                                  100 * c.free_space, 100 * limits.max_free_space));
  const double offset = (T.translation() - tripod_centre).norm();
  if (o.mode == AlignmentMode::Cumulative && offset > limits.max_tripod_offset_m)
    reasons.push_back(fmt::format("its camera stands {:.2f} m from the tripod's centre (allowed "
                                  "{:.2f} m)",
                                  offset, limits.max_tripod_offset_m));
  if (held_by_tripod && c.off_axis_deg > kOnRingDeg)
    reasons.push_back(fmt::format("its surfaces leave its tilt or roll to the tripod, and it stands "
                                  "{:.2f} deg off its ring (allowed {:.1f} deg for such a view)",
                                  c.off_axis_deg, kOnRingDeg));
  if (c.off_axis_deg > limits.max_off_axis_deg)
    reasons.push_back(fmt::format("tilted or rolled {:.2f} deg off the tripod's pan axis as its "
                                  "ring sees it (allowed {:.1f} deg)",
                                  c.off_axis_deg, limits.max_off_axis_deg));
  if (c.tripod_residual_m > limits.max_tripod_residual_m)
    reasons.push_back(fmt::format("its camera stands {:.0f} mm from where the tripod's head puts "
                                  "it (allowed {:.0f} mm)",
                                  1000 * c.tripod_residual_m, 1000 * limits.max_tripod_residual_m));
  if (!slide.held && !held_by_tripod) reasons.push_back(slide_reason(slide, limits));
  if (c.constraint < needed)
    reasons.push_back(fmt::format("geometry does not fix its pose{} (constraint {:.4f}, need >= "
                                  "{:.3f}: a bare wall or plane)",
                                  own.color ? ", nor does its colour's texture" : "", c.constraint,
                                  needed));
  c.verified = reasons.empty();
  for (const std::string& reason : reasons) c.reason += (c.reason.empty() ? "" : "; ") + reason;
  const double confidence = view_confidence(c, limits, max_correction_m, max_correction_deg, needed,
                                            slide);
  c.confidence = c.verified ? std::clamp(confidence, 0.0, 1.0) : 0.0;
  return c;
}

}  // namespace

std::vector<std::uint64_t> world_cells(const PointCloud& cloud, const Isometry3d& T,
                                       double cell_size) {
  const float inverse = static_cast<float>(1.0 / cell_size);
  const Eigen::Isometry3f Tf = T.cast<float>();
  std::vector<std::uint64_t> cells;
  for (const Eigen::Vector3f& p : cloud.positions) {
    const Eigen::Vector3f q = Tf * p;
    if (q.allFinite()) cells.push_back(voxel_key(q, inverse));
  }
  std::sort(cells.begin(), cells.end());
  cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
  return cells;
}

// Smallest eigenvalue of the per-point normal matrix of the view's own points: rotation about
// the camera centre only (tripod), or all six degrees of freedom with the rotation scaled by
// the RMS lever arm (video).
double pose_constraint(const PointCloud& cloud, bool rotation_only) {
  return weakest_direction(normal_information(cloud), rotation_only);
}

namespace {

// Whether any point of view j lies where a check with this box looks, the box widened by a
// voxel (a voxel j shares with the box counts): only then can j leaving or re-entering the
// model change that check.
bool reaches(const AlignmentState& s, std::size_t j, const CheckBox& box) {
  const Eigen::Isometry3f T = s.result.frames[j].T_world_camera_final->cast<float>();
  const float v = static_cast<float>(s.options.voxel_size);
  const Eigen::Array3f lo = box.lo.array() - v, hi = box.hi.array() + v;
  for (const Eigen::Vector3f& p : s.prepared[j].cloud.positions) {
    const Eigen::Array3f q = (T * p).array();
    if ((q >= lo).all() && (q <= hi).all()) return true;
  }
  return false;
}

// Every registered view of one piece checked against the others of that piece, rounds until
// the flagged set settles. A later round checks again only the views whose model changed: those
// a newly flagged (or cleared) view reaches, and that view itself.
void check_piece(AlignmentState& s, const std::vector<std::size_t>& views) {
  std::vector<char> excluded(s.n, 1);  // views of other pieces never enter the model
  for (std::size_t i : views) excluded[i] = 0;
  std::vector<Isometry3d> final_poses;
  for (std::size_t i : views) final_poses.push_back(*s.result.frames[i].T_world_camera_final);
  const std::vector<std::size_t> together =
      densest_centres(final_poses, s.options.view_check.max_tripod_offset_m);
  std::vector<Isometry3d> standing;
  for (std::size_t k : together) standing.push_back(final_poses[k]);
  const Eigen::Vector3d tripod_centre = median_centre(standing);
  std::vector<ViewInformation> information(views.size());
  std::vector<CheckBox> boxes(views.size());
  tbb::parallel_for(std::size_t{0}, views.size(), [&](std::size_t k) {
    information[k] = view_information(s, views[k]);
    boxes[k] = check_box(s, views[k]);
  });
  const TripodConsistency tripod = tripod_consistency(s, views, together, information);
  std::vector<char> due(views.size(), 1);
  for (int round = 0; round < std::max(1, s.options.view_check.rounds); ++round) {
    const ViewModel model = build_model(s, excluded);
    tbb::parallel_for(std::size_t{0}, views.size(), [&](std::size_t k) {
      if (!due[k]) return;
      ViewCheck& check = s.result.frames[views[k]].check;
      const ViewCheck before = check;
      check = check_view(s, model, views[k], tripod_centre, tripod.off_axis_deg[views[k]],
                         tripod.residual_m[views[k]], tripod.residual_camera[views[k]],
                         tripod.axis, tripod.play_m, information[k], boxes[k]);
      // A view flagged in an earlier round whose overlapping views are all flagged now keeps
      // what it was flagged for: "alone" would hide the reason.
      if (round > 0 && check.reason == kAlone && before.checked && !before.verified &&
          before.reason != kAlone) {
        check = before;
        if (!check.reason.ends_with(kAllFlagged)) check.reason += kAllFlagged;
      }
    });
    std::vector<std::size_t> changed;
    for (std::size_t k = 0; k < views.size(); ++k) {
      const ViewCheck& c = s.result.frames[views[k]].check;
      const char flagged = c.checked && !c.verified;
      if (flagged != excluded[views[k]]) changed.push_back(k);
      excluded[views[k]] = flagged;
    }
    if (changed.empty()) break;
    tbb::parallel_for(std::size_t{0}, views.size(), [&](std::size_t k) {
      due[k] = std::any_of(changed.begin(), changed.end(), [&](std::size_t j) {
        return j == k || reaches(s, views[j], boxes[k]);
      });
    });
  }
}

// The cells (twice the voxel size) a view's points fall in, sorted, each once. On a tripod turn
// only the points of surfaces that a turn about the pan axis moves (normals more than 45
// degrees from it: walls, the sides of things): a floor or a ceiling lies in the same cells
// however far a block of views is turned about the axis, so it would link a wrong arc to the
// model (generated room 41: an arc of the ceiling ring 30 degrees off, linked by the ceiling).
std::vector<std::uint64_t> view_cells(const AlignmentState& s, std::size_t i,
                                      const std::optional<Eigen::Vector3d>& pan_axis) {
  const Isometry3d& T = *s.result.frames[i].T_world_camera_final;
  const PointCloud& cloud = s.prepared[i].cloud;
  if (!pan_axis || !cloud.has_normals())
    return world_cells(cloud, T, 2.0 * s.options.voxel_size);
  const Eigen::Vector3f axis = (T.linear().transpose() * *pan_axis).cast<float>();
  std::vector<std::uint32_t> turning;
  for (std::size_t k = 0; k < cloud.size(); ++k)
    if (std::abs(cloud.normals[k].dot(axis)) < 0.7f) turning.push_back(static_cast<std::uint32_t>(k));
  return world_cells(select_points(cloud, turning), T, 2.0 * s.options.voxel_size);
}

// The pan axis of a tripod turn's verified views (tripod_fit.hpp); none on video or without
// a fit.
std::optional<Eigen::Vector3d> pan_axis_of(const AlignmentState& s,
                                           const std::vector<std::size_t>& views) {
  if (s.options.mode != AlignmentMode::Cumulative) return std::nullopt;
  std::vector<Eigen::Matrix3d> R;
  for (std::size_t i : views) R.push_back(s.result.frames[i].T_world_camera_final->linear());
  const std::optional<TripodFit> fit = turn_fit(s.options, R);
  if (!fit) return std::nullopt;
  return fit->axis;
}

// Links between verified views (ViewCheckOptions::min_link_overlap): the share of a sample of
// one view's cells that the other saw too. A sample keeps a long video cheap (a desk seen by
// hundreds of frames); 400 cells estimate a share of 0.2 within about 0.04.
constexpr std::size_t kLinkSample = 400;

Components linked_blocks(const AlignmentState& s, const std::vector<std::size_t>& verified) {
  const std::size_t m = verified.size();
  std::vector<std::vector<std::uint64_t>> cells(m);
  const std::optional<Eigen::Vector3d> axis = pan_axis_of(s, verified);
  tbb::parallel_for(std::size_t{0}, m, [&](std::size_t k) { cells[k] = view_cells(s, verified[k], axis); });
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> seen_by;
  for (std::size_t k = 0; k < m; ++k)
    for (std::uint64_t c : cells[k]) seen_by[c].push_back(static_cast<std::uint32_t>(k));
  std::vector<std::vector<std::size_t>> links(m);
  tbb::parallel_for(std::size_t{0}, m, [&](std::size_t k) {
    const std::vector<std::uint64_t>& own = cells[k];
    if (own.empty()) return;
    const std::size_t step = std::max<std::size_t>(1, own.size() / kLinkSample);
    std::vector<std::uint32_t> shared(m, 0);
    std::size_t sampled = 0;
    for (std::size_t c = 0; c < own.size(); c += step, ++sampled)
      for (std::uint32_t other : seen_by.at(own[c])) ++shared[other];
    const std::size_t piece = s.result.frames[verified[k]].piece;
    for (std::size_t j = 0; j < m; ++j)
      if (j != k && s.result.frames[verified[j]].piece == piece &&
          static_cast<double>(shared[j]) >= s.options.view_check.min_link_overlap * static_cast<double>(sampled))
        links[k].push_back(j);
  });
  Components blocks(m);
  for (std::size_t k = 0; k < m; ++k)
    for (std::size_t j : links[k]) blocks.unite(k, j);
  return blocks;
}

// The piece holding the model becomes piece 0 (what is meshed and measured).
void make_piece_zero(AlignmentState& s, std::size_t piece) {
  if (piece == 0) return;
  for (FrameAlignment& f : s.result.frames)
    if (f.piece == piece) f.piece = 0;
    else if (f.piece == 0) f.piece = piece;
}

// Keeps the largest block of linked verified views; the views of the other blocks are flagged
// (ViewCheckOptions, "linked").
void keep_linked_block(AlignmentState& s) {
  std::vector<std::size_t> verified;
  for (std::size_t i = 0; i < s.n; ++i)
    if (s.result.frames[i].trusted() && s.result.frames[i].check.checked) verified.push_back(i);
  if (verified.empty()) return;
  Components blocks = linked_blocks(s, verified);
  std::unordered_map<std::size_t, std::size_t> size;
  std::size_t main = blocks.find(0);
  for (std::size_t k = 0; k < verified.size(); ++k) {
    const std::size_t b = blocks.find(k);
    if (++size[b] > size[main]) main = b;
  }
  for (std::size_t k = 0; k < verified.size(); ++k) {
    if (blocks.find(k) != main) continue;
    make_piece_zero(s, s.result.frames[verified[k]].piece);
    break;
  }
  for (std::size_t k = 0; k < verified.size(); ++k) {
    const std::size_t b = blocks.find(k);
    if (b == main) continue;
    ViewCheck& c = s.result.frames[verified[k]].check;
    c.verified = false;
    c.confidence = 0.0;
    c.reason = fmt::format("agrees with its neighbours, but its block of {} verified views shares "
                           "no surface with the model's {} verified views except through flagged "
                           "views: where the block sits in the model is unchecked",
                           size[b], size[main]);
  }
}

}  // namespace

std::optional<TripodFit> turn_fit(const AlignmentOptions& o,
                                  const std::vector<Eigen::Matrix3d>& R_world_camera) {
  if (o.mode != AlignmentMode::Cumulative) return std::nullopt;
  TripodFitOptions fit_options;
  if (!o.ring_sizes.empty()) fit_options.min_inlier_share = 0.0;  // a known turn
  return fit_tripod(R_world_camera, fit_options);
}

void check_views(AlignmentState& s) {
  std::map<std::size_t, std::vector<std::size_t>> pieces;
  for (std::size_t i = 0; i < s.n; ++i)
    if (s.result.frames[i].status == FrameStatus::Registered &&
        s.result.frames[i].T_world_camera_final)
      pieces[s.result.frames[i].piece].push_back(i);
  std::size_t registered = 0;
  for (const auto& [piece, views] : pieces) registered += views.size();
  if (registered < 2) return;
  for (const auto& [piece, views] : pieces) {
    if (views.size() >= 2) {
      check_piece(s, views);
      continue;
    }
    ViewCheck& c = s.result.frames[views.front()].check;
    c = ViewCheck{};
    c.checked = true;
    c.reason = "no other view is joined to it (a piece of its own)";
  }
  keep_linked_block(s);
}

}  // namespace locard::alignment_detail
