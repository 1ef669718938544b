#include <locard/core/error.hpp>
#include <locard/surface/mesh_evaluation.hpp>

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

#include <tbb/parallel_for.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

namespace locard {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Triangle = Kernel::Triangle_3;
using TriangleIterator = std::vector<Triangle>::const_iterator;
using Primitive = CGAL::AABB_triangle_primitive<Kernel, TriangleIterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;

const double kMaxTanIncidence = std::tan(80.0 * 3.14159265358979323846 / 180.0);

// Exact point-to-surface distances; degenerate triangles (no area) are left out.
class SurfaceDistance {
 public:
  explicit SurfaceDistance(const TriangleMesh& mesh) {
    triangles_.reserve(mesh.triangles.size());
    for (const auto& t : mesh.triangles) {
      auto p = [&](std::uint32_t i) {
        const Eigen::Vector3f& v = mesh.vertices[i];
        return Kernel::Point_3(v.x(), v.y(), v.z());
      };
      Triangle tri(p(t[0]), p(t[1]), p(t[2]));
      if (!tri.is_degenerate()) triangles_.push_back(tri);
    }
    tree_.insert(triangles_.begin(), triangles_.end());
    tree_.build();
    tree_.accelerate_distance_queries();
    if (!triangles_.empty()) (void)tree_.squared_distance(Kernel::Point_3(0, 0, 0));  // lazy parts
  }
  bool empty() const { return triangles_.empty(); }
  std::vector<double> distances(const std::vector<Eigen::Vector3f>& points) const {
    std::vector<double> out(points.size());
    tbb::parallel_for(std::size_t{0}, points.size(), [&](std::size_t i) {
      const Eigen::Vector3f& p = points[i];
      out[i] = std::sqrt(tree_.squared_distance(Kernel::Point_3(p.x(), p.y(), p.z())));
    });
    return out;
  }

 private:
  std::vector<Triangle> triangles_;
  Tree tree_;
};

// Seen: in front of a view, facing it (the ground truth's winding gives the outside), and
// where that view measured the sample's depth. The depth read is the nearest pixel's, whose ray
// passes up to 0.71 pixel from the sample; on a surface inclined by theta to the ray that moves
// the depth by up to 0.71 * z / f * tan(theta) (tan capped at 80 degrees), so that is added to
// the fixed tolerance. The fixed part stays below the thickness of things flush with a wall (a
// 2-3 cm door or window): the wall behind them is occluded, not seen.
int seen_by(const Eigen::Vector3f& p, const Eigen::Vector3f& normal,
            const std::vector<EvaluationView>& views, double tolerance, bool count_all) {
  int seen = 0;
  for (const EvaluationView& view : views) {
    const Eigen::Vector3d to_camera = view.T_world_camera.translation() - p.cast<double>();
    const double facing = normal.cast<double>().dot(to_camera);
    if (facing <= 0.0) continue;
    const Eigen::Vector3d c = view.T_world_camera.inverse() * p.cast<double>();
    if (c.z() <= 0.0) continue;
    const CameraIntrinsics& k = view.intrinsics;
    const long u = std::lround(k.fx * c.x() / c.z() + k.cx);
    const long v = std::lround(k.fy * c.y() / c.z() + k.cy);
    if (u < 0 || v < 0 || u >= view.depth.width() || v >= view.depth.height()) continue;
    const std::uint16_t raw = view.depth.at(static_cast<int>(u), static_cast<int>(v));
    if (raw == 0) continue;
    const double cos_incidence = facing / to_camera.norm();
    const double tan_incidence =
        std::min(std::sqrt(std::max(0.0, 1.0 - cos_incidence * cos_incidence)) / cos_incidence,
                 kMaxTanIncidence);
    const double slope = 0.71 * c.z() / std::min(k.fx, k.fy) * tan_incidence;
    if (std::abs(raw / view.depth_scale - c.z()) <= tolerance + slope) {
      ++seen;
      if (!count_all) break;
    }
  }
  return seen;
}

}  // namespace

namespace {
std::vector<Eigen::Vector3f> sample_surface_with_normals(const TriangleMesh& mesh, double spacing,
                                                         std::uint64_t seed,
                                                         std::vector<Eigen::Vector3f>* normals) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double per_area = 1.0 / (spacing * spacing);
  // The budget before any allocation: one far or non-finite vertex makes a triangle whose
  // area asks for billions of samples (a vertex at 1e10 m once took 16 GB).
  constexpr double kMaxSamples = 5e7;
  double area = 0.0;
  for (const auto& t : mesh.triangles)
    area += 0.5 * (mesh.vertices[t[1]] - mesh.vertices[t[0]])
                      .cast<double>()
                      .cross((mesh.vertices[t[2]] - mesh.vertices[t[0]]).cast<double>())
                      .norm();
  if (!std::isfinite(area))
    throw InputError("evaluate_mesh: the ground truth has a vertex that is not a finite number");
  if (area * per_area > kMaxSamples)
    throw InputError(fmt::format("evaluate_mesh: the ground truth's {:.4g} m2 at {} m spacing "
                                 "needs {:.3g} samples (at most {:.0g}): a vertex far off the "
                                 "scene, or a larger spacing",
                                 area, spacing, area * per_area, kMaxSamples));
  std::vector<Eigen::Vector3f> out;
  out.reserve(static_cast<std::size_t>(area * per_area) + mesh.triangles.size());
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[t[0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[t[1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[t[2]].cast<double>();
    const double expected = 0.5 * (b - a).cross(c - a).norm() * per_area;
    // Whole samples plus one more with the probability of the fraction: unbiased by area.
    std::size_t n = static_cast<std::size_t>(expected);
    if (unit(rng) < expected - static_cast<double>(n)) ++n;
    for (std::size_t i = 0; i < n; ++i) {
      double r1 = unit(rng), r2 = unit(rng);
      if (r1 + r2 > 1.0) {
        r1 = 1.0 - r1;
        r2 = 1.0 - r2;
      }
      out.push_back((a + r1 * (b - a) + r2 * (c - a)).cast<float>());
      if (normals) normals->push_back((b - a).cross(c - a).normalized().cast<float>());
    }
  }
  return out;
}
}  // namespace

std::vector<Eigen::Vector3f> sample_surface(const TriangleMesh& mesh, double spacing,
                                            std::uint64_t seed) {
  return sample_surface_with_normals(mesh, spacing, seed, nullptr);
}

MeshEvaluation evaluate_mesh(const TriangleMesh& ground_truth, const TriangleMesh& reconstruction,
                             const MeshEvaluationOptions& options) {
  if (ground_truth.triangles.empty())
    throw InputError("evaluate_mesh: the ground-truth mesh has no triangles");
  if (reconstruction.triangles.empty())
    throw InputError("evaluate_mesh: the reconstructed mesh has no triangles");
  if (!(options.sample_spacing > 0.0) || !(options.completeness_threshold > 0.0))
    throw InputError("evaluate_mesh: sample spacing and threshold must be positive");

  MeshEvaluation result;
  // Accuracy: reconstruction vertices against the ground-truth surface.
  {
    const SurfaceDistance gt(ground_truth);
    if (gt.empty()) throw InputError("evaluate_mesh: every ground-truth triangle is degenerate");
    std::vector<double> d = gt.distances(reconstruction.vertices);
    result.mesh_vertices = d.size();
    if (!d.empty()) {
      result.accuracy_mean = std::accumulate(d.begin(), d.end(), 0.0) / static_cast<double>(d.size());
      std::sort(d.begin(), d.end());
      result.accuracy_median = d[d.size() / 2];
      result.accuracy_p90 = d[std::min(d.size() - 1, d.size() * 9 / 10)];
      result.accuracy_max = d.back();
    }
  }
  // Completeness: ground-truth samples (seen by a view) against the reconstruction.
  std::vector<Eigen::Vector3f> normals;
  std::vector<Eigen::Vector3f> samples =
      sample_surface_with_normals(ground_truth, options.sample_spacing, options.seed, &normals);
  result.gt_samples = samples.size();
  std::vector<int> view_counts;
  if (!options.views.empty()) {
    std::vector<int> seen(samples.size());
    tbb::parallel_for(std::size_t{0}, samples.size(), [&](std::size_t i) {
      seen[i] = seen_by(samples[i], normals[i], options.views, options.visibility_tolerance,
                        options.keep_samples);
    });
    std::size_t kept = 0;
    for (std::size_t i = 0; i < samples.size(); ++i)
      if (seen[i] > 0) {
        seen[kept] = seen[i];
        samples[kept++] = samples[i];
      }
    samples.resize(kept);
    seen.resize(kept);
    view_counts = std::move(seen);
  }
  result.counted_samples = samples.size();
  if (!samples.empty()) {
    const SurfaceDistance rec(reconstruction);
    if (rec.empty()) throw InputError("evaluate_mesh: every reconstructed triangle is degenerate");
    const std::vector<double> d = rec.distances(samples);
    std::size_t within = 0;
    double sum = 0.0;
    for (double x : d) {
      within += x <= options.completeness_threshold;
      sum += x;
    }
    result.completeness = static_cast<double>(within) / static_cast<double>(d.size());
    result.completeness_mean_distance = sum / static_cast<double>(d.size());
    if (options.keep_samples) {
      result.samples.positions = samples;
      ScalarField distance{"distance", std::vector<float>(d.begin(), d.end())};
      ScalarField views{"views", std::vector<float>(samples.size(), 0.f)};
      for (std::size_t i = 0; i < view_counts.size(); ++i)
        views.values[i] = static_cast<float>(view_counts[i]);
      result.samples.scalars = {std::move(distance), std::move(views)};
    }
  }
  return result;
}

}  // namespace locard
