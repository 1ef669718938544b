#pragma once
// Iterative Closest Point refinement of T_target_source: point-to-point (Besl & McKay 1992),
// point-to-plane (Chen & Medioni 1992) and coloured ICP (Park, Zhou, Koltun 2017, "Colored
// Point Cloud Registration Revisited", ICCV), with robust kernels and a multi-scale schedule.
//
// Frames. Every computation runs in a locally centred frame, in double: with c_t the target
// centroid and c_s the source centroid, target points become t - c_t, source points s - c_s,
// and the unknown is T_c = T(-c_t) T_target_source T(c_s). Far-from-origin clouds (survey
// coordinates) then keep full precision; the result is mapped back exactly at the end.
//
// One iteration at the current estimate T_c. For every source point, q = T_c s; its
// correspondence is the target point t nearest to q if |q - t| <= max_correspondence_distance
// (kd-tree search). The update is a small left perturbation
//   T_c <- [exp(omega) | v] T_c,    q(xi) ~ q + omega x q + v,   xi = (omega, v),
// so every residual r(q) has the Jacobian J = dr/dq [-[q]x  I] with respect to xi.
//
//  point-to-point  r = q - t (3-vector). The step is closed form: the weighted Kabsch/Umeyama
//                  solution over the pairs (q, t) (see rigid_transform.hpp), which is the
//                  exact minimiser of sum w |r|^2 for fixed pairs (no linearisation).
//  point-to-plane  r = n_t . (q - t),  J = [ (q x n_t)^T  n_t^T ].
//  coloured        Two residuals per pair, weighted as Park et al. eq. 19 with
//                  lambda = lambda_geometric:
//                    r_G = sqrt(lambda)     n_t . (q - t)                    (as above)
//                    r_C = sqrt(1 - lambda) (C_t(f(q)) - C_s(s))
//                  where C is intensity (r + g + b) / (3 * 255) and C_t is the target's
//                  colour extended over the tangent plane of t (Park et al. eq. 12-13):
//                    f(q) = q - (n_t . (q - t)) n_t,  C_t(f(q)) = C(t) + d_t . (f(q) - t),
//                  d_t being the colour gradient at t, fitted once per target point by least
//                  squares over its neighbours projected onto the tangent plane, with the
//                  constraint d_t . n_t = 0 (eq. 10). dr_C/dq = sqrt(1 - lambda) d_t^T
//                  (I - n_t n_t^T) = sqrt(1 - lambda) g^T, so J_C = [ (q x g)^T  g^T ].
//                  (Sign: we write r_C = C_t - C_s; Park writes C_s - C_t; r^2 is the same.)
// For the last two, Gauss-Newton with IRLS weights w_i = kernel.weight(r_i):
//   H = sum w_i J_i^T J_i,  b = sum w_i J_i^T r_i,  H xi = -b   (solved by LDLT).
// Sums are parallel (oneTBB parallel_deterministic_reduce with a fixed grain), so the result
// is bit-for-bit the same for any thread count.
//
// Pose prior (optional, point-to-plane and coloured). A Gaussian prior on where the source
// frame's origin - the camera centre of a camera-frame cloud - lies in the target frame and on
// the rotation, as a tripod gives: with q0 = T_c (0 - c_s) the origin's current place,
// p = prior centre - c_t, R the current and R_p the prior rotation,
//   centre    r_c = q0 - p,          J_c = [-[q0]x  I],  w_c = (point_sigma / centre_sigma)^2
//   rotation  r_R = log(R R_p^T),    J_R = [I  0],       w_R = (point_sigma / rotation_sigma)^2
// (rotation_sigma in radians; J_R is first order, as the left perturbation itself). Each
// prior counts like one correspondence of residual spread point_sigma - or, with
// per_correspondence, like every correspondence of the pass (w times their count: a prior as
// sure as the data, for a constraint that is physical, such as a tripod). Either way it leaves
// alone what the geometry fixes firmly and decides a direction the geometry leaves free (a bare
// wall's slide and its turn about its normal) or only half fixes (a periodic texture). H += w J^T J and b += w J^T r join the sums before the solve;
// fitness, RMSE and the information matrix stay those of the data alone.
// With a hinge axis a (unit, target frame; a tripod's pan axis) the rotation prior splits:
// W_R = w_R a a^T + w_off (I - a a^T), w_off = (point_sigma / off_axis_sigma)^2 times the
// pass's correspondence count always (a hinge turns about its axis only: that is physical
// whatever per_correspondence says), so the turn about a stays as free as rotation_sigma says
// and tilt and roll are held to the prior.
//
// Stopping. After each update: converged when the step is below rotation_eps_deg AND
// translation_eps_m, or (Open3D's criteria) when fitness and inlier RMSE changed by less than
// relative_fitness and relative_rmse since the previous iteration; otherwise stop after
// max_iterations (converged = false, which is still a result: success depends on fitness).
//
// Result quality, as Open3D's RegistrationResult:
//   fitness     = correspondences / source points (after non-finite points are dropped),
//   inlier_rmse = sqrt(mean |q - t|^2) over the correspondences (point-to-point distance),
// at the final estimate. The 6x6 information matrix is Open3D's
// GetInformationMatrixFromPointClouds: sum over the final correspondences of G^T G with
// G = [-[t]x  I] at target point t in the TARGET frame (rows/cols: rotation x y z, then
// translation x y z), so it drops into a pose graph edge unchanged. `hessian` is the final
// Gauss-Newton H of the method's own objective (small_gicp's H), in the same frame and order.
//
// Bad input. Points with a NaN/Inf coordinate (or NaN/Inf normal, where normals are used) are
// dropped and counted. Fewer than `min_points` finite points in either cloud: InputError.
// Point-to-plane and coloured ICP need target normals: when the target has none they are
// estimated (local PCA, see preprocess/normals.hpp) and target_normals_estimated says so.
// Coloured ICP without colours on both clouds: InputError. No overlap, too few
// correspondences, a singular system or a fitness below min_fitness: success = false with a
// reason, and T_target_source holds the last estimate (never a silent identity).

#include <locard/core/point_cloud.hpp>
#include <locard/core/pose.hpp>
#include <locard/registration/robust_kernel.hpp>

#include <Eigen/Core>

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace locard {

enum class IcpMethod { PointToPoint, PointToPlane, Colored };

// "point-to-point", "point-to-plane", "colored" (also "coloured").
std::string_view to_string(IcpMethod method);
std::optional<IcpMethod> parse_icp_method(std::string_view name);

struct IcpConvergence {
  int max_iterations = 30;
  double rotation_eps_deg = 1e-3;   // update rotation angle below this ...
  double translation_eps_m = 1e-5;  // ... and update translation below this: converged
  double relative_fitness = 1e-6;   // Open3D: |fitness change| below this ...
  double relative_rmse = 1e-6;      // ... and |RMSE change| below this: converged
};

struct IcpPosePrior {
  Isometry3d T_target_source = Isometry3d::Identity();  // the prior pose
  double centre_sigma_m = 0.05;     // spread of the source origin's place; 0: not used
  double rotation_sigma_deg = 5.0;  // spread of the rotation; 0: not used
  double point_sigma_m = 0.01;      // spread of one correspondence's residual
  bool per_correspondence = false;  // weight times the pass's correspondences
  std::optional<Eigen::Vector3d> hinge_axis;  // unit, target frame; see "Pose prior"
  double off_axis_sigma_deg = 0.5;            // spread of tilt and roll about the hinge
};

struct IcpOptions {
  IcpMethod method = IcpMethod::PointToPlane;
  double max_correspondence_distance = 0.05;  // metres (not squared)
  RobustKernel kernel;                        // None by default
  IcpConvergence convergence;
  double lambda_geometric = 0.968;  // coloured ICP: weight of the geometric term (Park eq. 19)
  // Normals, when the target has none (point-to-plane, coloured): hybrid search, the at most
  // normal_max_neighbors nearest within normal_radius (<= 0: plain k-NN), oriented towards
  // the origin of the target's frame (the sensor for a camera-frame cloud).
  double normal_radius = 0.0;
  int normal_max_neighbors = 20;
  // Coloured ICP: neighbourhood for the colour gradient (Open3D uses 2x the correspondence
  // distance and 30 neighbours). <= 0: 2 * max_correspondence_distance.
  double color_gradient_radius = 0.0;
  int color_gradient_max_neighbors = 30;
  // Acceptance: success needs at least min_correspondences pairs and fitness >= min_fitness.
  double min_fitness = 0.1;
  std::size_t min_correspondences = 6;
  std::size_t min_points = 6;  // per cloud, after dropping non-finite points; else InputError
  // Where the source should lie (see "Pose prior"); point-to-point: InputError.
  std::optional<IcpPosePrior> pose_prior;
};

// One level of a coarse-to-fine schedule: both clouds are voxel-down-sampled to voxel_size
// (0: used as they are) and ICP runs with this correspondence distance and iteration limit.
struct IcpScale {
  double voxel_size = 0.0;
  double max_correspondence_distance = 0.05;
  int max_iterations = 30;
};

struct IcpLevelReport {
  double voxel_size = 0.0;
  double max_correspondence_distance = 0.0;
  std::size_t source_points = 0;
  std::size_t target_points = 0;
  int iterations = 0;
  bool converged = false;
  double fitness = 0.0;
  double inlier_rmse = 0.0;
};

struct IcpResult {
  bool success = false;
  std::string reason;  // why it failed; empty on success
  Isometry3d T_target_source = Isometry3d::Identity();
  double fitness = 0.0;
  double inlier_rmse = 0.0;           // metres
  std::size_t correspondences = 0;
  int iterations = 0;                 // updates applied (all levels together)
  bool converged = false;             // a convergence criterion was met (last level)
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 6> hessian = Eigen::Matrix<double, 6, 6>::Zero();
  IcpMethod method = IcpMethod::PointToPlane;
  std::size_t source_points = 0;      // finite points used (last level)
  std::size_t target_points = 0;
  std::size_t source_non_finite = 0;  // dropped from the input clouds
  std::size_t target_non_finite = 0;
  bool target_normals_estimated = false;
  std::vector<IcpLevelReport> levels;  // one per scale (a single entry for plain icp())
};

// Refines init_T_target_source. Throws InputError for unusable input (see above).
IcpResult icp(const PointCloud& source, const PointCloud& target,
              const Isometry3d& init_T_target_source, const IcpOptions& options);

// A target prepared once - finite points, kd-tree, normals, colour gradients - for many ICP
// runs against it (several initial guesses, several sources): the preparation is most of the
// cost of a short run against a large model. It is bound to the method it was prepared for
// and, for coloured ICP, to the gradient radius of those options. Copies share the data.
class IcpTarget {
 public:
  // Throws InputError as icp() does for a target it cannot use.
  IcpTarget(const PointCloud& target, const IcpOptions& options);
  IcpMethod method() const;
  std::size_t size() const;  // finite points kept

 private:
  struct Prepared;
  std::shared_ptr<const Prepared> prepared_;
  friend IcpResult icp(const PointCloud& source, const IcpTarget& target,
                       const Isometry3d& init_T_target_source, const IcpOptions& options);
};

// icp() against a prepared target; options.method must be the target's method (InputError
// otherwise). The result is the same as icp() with the target's cloud.
IcpResult icp(const PointCloud& source, const IcpTarget& target,
              const Isometry3d& init_T_target_source, const IcpOptions& options);

// One level of a coarse-to-fine schedule over clouds the caller has ready: the source, the
// target and, when the caller prepared it for this level's method, the target's IcpTarget (used
// instead of preparing the cloud again: the same result, without the cost).
struct IcpLevel {
  std::string name;  // prefixes a failure's reason: "level 2 of 3", "gate 0.01 m"
  const PointCloud* source = nullptr;
  const PointCloud* target = nullptr;
  const IcpTarget* prepared = nullptr;  // optional
  IcpMethod method = IcpMethod::PointToPlane;
  double max_correspondence_distance = 0.05;
  int max_iterations = 30;
  bool skip_if_small = false;  // fewer than options.min_points on a side: fail, do not run
  // > 0: this level's normal estimation instead of options' (multi-scale: 2 voxels, 30).
  double normal_radius = 0.0;
  int normal_max_neighbors = 0;
};

// The one coarse-to-fine loop (icp_multiscale, the alignment's refinement of a view, the scan
// alignment's gates): each level runs icp() with the level's method, gate and iteration limit
// over `options`, from the previous level's estimate; the first level that fails stops it, its
// reason prefixed with the level's name ("<name>: too few points" for a small level with
// skip_if_small). iterations are summed over the levels run, `levels` has one report each.
// An InputError of a level is re-thrown with the level's name in front.
IcpResult icp_levels(const std::vector<IcpLevel>& levels, const Isometry3d& init_T_target_source,
                     const IcpOptions& options);

// Coarse to fine over `scales` (each level starts from the previous level's estimate). The
// fields of `options` other than the correspondence distance and iteration limit apply to
// every level; normals are re-estimated per level (radius 2 x voxel_size, as Open3D's
// multi-scale examples) unless options.normal_radius is set. Stops at the first level that
// fails. Throws InputError when `scales` is empty or a voxel size is negative.
IcpResult icp_multiscale(const PointCloud& source, const PointCloud& target,
                         const Isometry3d& init_T_target_source, const IcpOptions& options,
                         const std::vector<IcpScale>& scales);

// Open3D's GetInformationMatrixFromPointClouds for T_target_source: the information matrix
// above over all source points whose nearest target point lies within max_distance.
Eigen::Matrix<double, 6, 6> information_matrix(const PointCloud& source,
                                               const PointCloud& target,
                                               const Isometry3d& T_target_source,
                                               double max_distance);

}  // namespace locard
