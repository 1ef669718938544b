#include <locard/forensics/floor_coverage.hpp>

#include <locard/forensics/floor_level.hpp>

#include "core/convex_polygon.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace locard::forensics {
namespace {

constexpr double kDeg = M_PI / 180.0;
// A levelled case's floor lies within a few degrees of the xy plane; more is no floor of it.
constexpr double kMaxFloorTiltDeg = 5.0;

// What one view says of one cell's centre.
enum class Look : std::uint8_t { Nothing, Measured, InFront, Through };

Look look(const DepthImage& depth, const CameraIntrinsics& K, double depth_scale,
          const Isometry3d& T_camera_world, const Eigen::Vector3d& p, const FloorCoverageOptions& o) {
  const Eigen::Vector3d c = T_camera_world * p;
  const double z = c.z();
  if (z < o.min_depth_m || z > o.max_depth_m) return Look::Nothing;
  const long u = std::lround(K.fx * c.x() / z + K.cx);
  const long v = std::lround(K.fy * c.y() / z + K.cy);
  if (u < 0 || v < 0 || u >= depth.width() || v >= depth.height()) return Look::Nothing;
  const std::uint16_t raw = depth.at(static_cast<int>(u), static_cast<int>(v));
  if (raw == 0) return Look::Nothing;
  const double d = raw / depth_scale;
  const double margin = o.margin_m + 0.01 * z * z;
  if (std::abs(d - z) <= margin) return Look::Measured;
  return d < z ? Look::InFront : Look::Through;
}

std::vector<std::size_t> chosen_views(const std::vector<std::optional<Isometry3d>>& poses,
                                      std::size_t max_views) {
  std::vector<std::size_t> placed;
  for (std::size_t i = 0; i < poses.size(); ++i)
    if (poses[i]) placed.push_back(i);
  if (placed.size() <= max_views) return placed;
  std::vector<std::size_t> chosen;
  for (std::size_t k = 0; k < max_views; ++k) chosen.push_back(placed[k * placed.size() / max_views]);
  return chosen;
}

// The placed views' depth images, read once, and their poses.
struct PlacedViews {
  std::vector<std::size_t> index;  // frames of the sequence
  std::vector<DepthImage> depth;
  std::vector<Isometry3d> T;
};

PlacedViews load_views(const RgbdSequence& sequence,
                       const std::vector<std::optional<Isometry3d>>& poses, std::size_t max_views) {
  PlacedViews v;
  v.index = chosen_views(poses, max_views);
  v.depth.resize(v.index.size());
  for (std::size_t i : v.index) v.T.push_back(*poses[i]);
  tbb::parallel_for(std::size_t{0}, v.index.size(),
                    [&](std::size_t k) { v.depth[k] = sequence.load_depth(v.index[k]); });
  return v;
}

// Every view's measured points in range (every 16th pixel): what the room's footprint is found
// from.
std::vector<Eigen::Vector3d> sample_points(const PlacedViews& views, const CameraIntrinsics& K,
                                           double depth_scale, const FloorCoverageOptions& o) {
  std::vector<Eigen::Vector3d> points;
  for (std::size_t k = 0; k < views.depth.size(); ++k) {
    const DepthImage& depth = views.depth[k];
    for (int v = 0; v < depth.height(); v += 16)
      for (int u = 0; u < depth.width(); u += 16) {
        const std::uint16_t raw = depth.at(u, v);
        if (raw == 0) continue;
        const double z = raw / depth_scale;
        if (z < o.min_depth_m || z > o.max_depth_m) continue;
        points.push_back(views.T[k] * Eigen::Vector3d((u - K.cx) * z / K.fx, (v - K.cy) * z / K.fy, z));
      }
  }
  return points;
}

// The room's footprint from above: the hull of the sampled points (the floor and what stands on
// it, the walls).
detail::ConvexPolygon footprint(const std::vector<Eigen::Vector3d>& points) {
  std::vector<Eigen::Vector2d> xy;
  xy.reserve(points.size());
  for (const Eigen::Vector3d& p : points) xy.emplace_back(p.x(), p.y());
  return detail::convex_hull(std::move(xy));
}

void classify(FloorCoverage& c, const std::vector<DepthImage>& depths,
              const std::vector<Isometry3d>& T, const CameraIntrinsics& K, double depth_scale,
              const detail::ConvexPolygon& hull, const FloorCoverageOptions& o) {
  std::vector<Isometry3d> T_camera_world;
  for (const Isometry3d& t : T) T_camera_world.push_back(t.inverse());
  tbb::parallel_for(0, c.ny, [&](int y) {
    for (int x = 0; x < c.nx; ++x) {
      const Eigen::Vector2d xy = c.cell_centre(x, y);
      FloorCell& cell = c.cells[static_cast<std::size_t>(y) * c.nx + x];
      if (!detail::convex_contains(hull, xy)) {
        cell = FloorCell::NotFloor;
        continue;
      }
      const Eigen::Vector3d p(xy.x(), xy.y(), c.floor_z_m);
      bool measured = false, in_front = false, through = false;
      for (std::size_t k = 0; k < depths.size() && !measured; ++k) {
        const Look l = look(depths[k], K, depth_scale, T_camera_world[k], p, o);
        measured = l == Look::Measured;
        in_front = in_front || l == Look::InFront;
        through = through || l == Look::Through;
      }
      cell = measured ? FloorCell::Seen
             : in_front ? FloorCell::Hidden
             : through  ? FloorCell::NotFloor
                        : FloorCell::Unseen;
    }
  });
}

void add_areas(FloorCoverage& c) {
  const double a = c.cell_m * c.cell_m;
  for (FloorCell cell : c.cells) {
    c.seen_m2 += cell == FloorCell::Seen ? a : 0.0;
    c.hidden_m2 += cell == FloorCell::Hidden ? a : 0.0;
    c.unseen_m2 += cell == FloorCell::Unseen ? a : 0.0;
  }
}

// The radius about the tripod out to which most of the floor is unseen: rings of one cell
// width, outwards, while each ring is at least disc_unseen_share unseen.
double unseen_disc_radius(const FloorCoverage& c, const FloorCoverageOptions& o) {
  const double step = c.cell_m;
  // Each floor cell counted once into its ring (ring k: distances [k, k + 1) steps), then the
  // rings read outwards, out to 10 m.
  const std::size_t rings = static_cast<std::size_t>(10.0 / step);
  std::vector<std::size_t> floor(rings, 0), unseen(rings, 0);
  for (int y = 0; y < c.ny; ++y)
    for (int x = 0; x < c.nx; ++x) {
      if (c.at(x, y) == FloorCell::NotFloor) continue;
      const auto k = static_cast<std::size_t>((c.cell_centre(x, y) - c.tripod_centre).norm() / step);
      if (k >= rings) continue;
      ++floor[k];
      unseen[k] += c.at(x, y) == FloorCell::Unseen;
    }
  double radius = 0.0;
  for (std::size_t k = 0; k < rings; ++k) {
    if (floor[k] == 0) continue;
    if (static_cast<double>(unseen[k]) < o.disc_unseen_share * static_cast<double>(floor[k])) break;
    radius = static_cast<double>(k + 1) * step;
  }
  return radius;
}

// 4-connected patches of unseen floor outside the tripod's disc.
std::vector<UnseenPatch> unseen_patches(const FloorCoverage& c, const std::vector<Isometry3d>& T,
                                        const FloorCoverageOptions& o) {
  std::vector<int> label(c.cells.size(), -1);
  std::vector<UnseenPatch> patches;
  const double a = c.cell_m * c.cell_m;
  const auto in_disc = [&](int x, int y) {
    return c.tripod && (c.cell_centre(x, y) - c.tripod_centre).norm() < c.unseen_radius_m;
  };
  for (int y0 = 0; y0 < c.ny; ++y0)
    for (int x0 = 0; x0 < c.nx; ++x0) {
      const std::size_t start = static_cast<std::size_t>(y0) * c.nx + x0;
      if (c.cells[start] != FloorCell::Unseen || label[start] >= 0) continue;
      if (in_disc(x0, y0)) continue;
      UnseenPatch patch;
      std::vector<std::size_t> stack{start};
      label[start] = static_cast<int>(patches.size());
      std::size_t count = 0;
      while (!stack.empty()) {
        const std::size_t i = stack.back();
        stack.pop_back();
        const int x = static_cast<int>(i % c.nx), y = static_cast<int>(i / c.nx);
        patch.centre += c.cell_centre(x, y);
        ++count;
        const int nbr[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
        for (const auto& d : nbr) {
          const int u = x + d[0], v = y + d[1];
          if (u < 0 || v < 0 || u >= c.nx || v >= c.ny) continue;
          const std::size_t j = static_cast<std::size_t>(v) * c.nx + u;
          if (c.cells[j] != FloorCell::Unseen || label[j] >= 0) continue;
          if (in_disc(u, v)) continue;
          label[j] = label[start];
          stack.push_back(j);
        }
      }
      patch.centre /= static_cast<double>(count);
      patch.area_m2 = static_cast<double>(count) * a;
      patch.distance_m = INFINITY;
      for (const Isometry3d& t : T)
        patch.distance_m = std::min(patch.distance_m, (t.translation().head<2>() - patch.centre).norm());
      patches.push_back(patch);
    }
  std::erase_if(patches, [&](const UnseenPatch& p) { return p.area_m2 < o.min_patch_m2; });
  std::sort(patches.begin(), patches.end(),
            [](const UnseenPatch& p, const UnseenPatch& q) { return p.area_m2 > q.area_m2; });
  return patches;
}

// The pitch (degrees, negative down, rounded down to 5) whose lowest rays reach the floor
// `foot` metres from the tripod, for a camera `height` over it with vertical field `vfov`.
double downward_pitch_deg(double height, double foot, double vfov_deg) {
  const double needed = std::atan2(height, foot) / kDeg - 0.5 * vfov_deg;
  return -5.0 * std::ceil(std::max(needed, 0.0) / 5.0);
}

void write_advice(FloorCoverage& c, const CameraIntrinsics& K, double max_depth_m,
                  const FloorCoverageOptions& o) {
  if (c.tripod && c.unseen_radius_m > o.tripod_foot_m + c.cell_m) {  // more than its legs cover
    const double vfov = 2.0 * std::atan2(0.5 * K.height, K.fy) / kDeg;
    c.advised_pitch_deg = downward_pitch_deg(c.camera_height_m, o.tripod_foot_m, vfov);
    c.advice.push_back(fmt::format(
        "floor within {:.1f} m of the tripod unseen: add a ring at pitch {:.0f} degrees (the "
        "camera {:.2f} m over the floor, a vertical field of {:.0f} degrees reaches the floor "
        "{:.1f} m from the tripod)",
        c.unseen_radius_m, *c.advised_pitch_deg, c.camera_height_m, vfov, o.tripod_foot_m));
  }
  for (const UnseenPatch& p : c.patches)
    c.advice.push_back(fmt::format(
        "floor unseen: {:.2f} m² about ({:.2f}, {:.2f}) m, {:.1f} m from the nearest camera{}: "
        "scan it from another position",
        p.area_m2, p.centre.x(), p.centre.y(), p.distance_m,
        p.distance_m > 0.8 * max_depth_m ? " (beyond the sensor's range)" : ""));
  if (c.hidden_m2 >= o.min_patch_m2)
    c.advice.push_back(fmt::format("{:.2f} m² of floor hidden under or behind objects: look there "
                                   "by hand",
                                   c.hidden_m2));
  if (c.advice.empty()) c.advice.push_back("the floor was observed throughout");
}

FloorCoverage cover(const RgbdSequence& sequence, const PlacedViews& views, double floor_z_m,
                    const FloorCoverageOptions& o) {
  FloorCoverage c;
  c.floor_z_m = floor_z_m;
  c.cell_m = o.cell_m;
  c.views_used = views.index.size();
  if (views.index.empty()) return c;
  const std::vector<DepthImage>& depths = views.depth;
  const std::vector<Isometry3d>& T = views.T;
  const CameraIntrinsics& K = sequence.intrinsics;
  const detail::ConvexPolygon hull = footprint(sample_points(views, K, sequence.depth_scale, o));
  if (hull.size() < 3) return c;
  Eigen::Vector2d lo = hull.front(), hi = hull.front();
  for (const Eigen::Vector2d& p : hull) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  c.origin = (lo / o.cell_m).array().floor().matrix() * o.cell_m;
  c.nx = static_cast<int>(std::ceil((hi.x() - c.origin.x()) / o.cell_m));
  c.ny = static_cast<int>(std::ceil((hi.y() - c.origin.y()) / o.cell_m));
  c.cells.assign(static_cast<std::size_t>(c.nx) * c.ny, FloorCell::NotFloor);
  classify(c, depths, T, K, sequence.depth_scale, hull, o);
  add_areas(c);
  c.tripod = sequence.traits.capture == CaptureKind::TripodTurn;
  if (c.tripod) {
    for (const Isometry3d& t : T) {
      c.tripod_centre += t.translation().head<2>();
      c.camera_height_m += t.translation().z() - floor_z_m;
    }
    c.tripod_centre /= static_cast<double>(T.size());
    c.camera_height_m /= static_cast<double>(T.size());
    c.unseen_radius_m = unseen_disc_radius(c, o);
  }
  c.patches = unseen_patches(c, T, o);
  write_advice(c, K, o.max_depth_m, o);
  return c;
}

}  // namespace

std::optional<double> floor_height(const std::vector<Eigen::Vector3d>& points) {
  const std::optional<FloorLevel> floor = find_floor_level(points, Eigen::Vector3d::UnitZ());
  if (!floor || floor->tilt_deg > kMaxFloorTiltDeg) return std::nullopt;
  return floor->height_m / floor->normal.z();
}

FloorCoverage compute_floor_coverage(const RgbdSequence& sequence,
                                     const std::vector<std::optional<Isometry3d>>& poses,
                                     double floor_z_m, const FloorCoverageOptions& o) {
  return cover(sequence, load_views(sequence, poses, o.max_views), floor_z_m, o);
}

std::string floor_coverage_json(const FloorCoverage& c) {
  using nlohmann::json;
  json rows = json::array();
  for (int y = 0; y < c.ny; ++y) {
    std::string row(static_cast<std::size_t>(c.nx), '.');
    for (int x = 0; x < c.nx; ++x) {
      const FloorCell cell = c.at(x, y);
      row[static_cast<std::size_t>(x)] = cell == FloorCell::Seen     ? 's'
                                         : cell == FloorCell::Hidden ? 'h'
                                         : cell == FloorCell::Unseen ? 'u'
                                                                     : '.';
    }
    rows.push_back(row);
  }
  json patches = json::array();
  for (const UnseenPatch& p : c.patches)
    patches.push_back({{"area_m2", p.area_m2},
                       {"centre", {p.centre.x(), p.centre.y()}},
                       {"distance_m", p.distance_m}});
  json j = {{"floor_z_m", c.floor_z_m},
            {"cell_m", c.cell_m},
            {"origin", {c.origin.x(), c.origin.y()}},
            {"size", {c.nx, c.ny}},
            {"legend", {{"s", "seen"}, {"h", "hidden under or behind objects"},
                        {"u", "unseen: in no view's field and range"}, {".", "not floor"}}},
            {"rows", rows},
            {"views_used", c.views_used},
            {"area_m2", {{"seen", c.seen_m2}, {"hidden", c.hidden_m2}, {"unseen", c.unseen_m2}}},
            {"seen_share", c.seen_share()},
            {"patches", patches},
            {"advice", c.advice}};
  if (c.tripod) {
    j["tripod"] = {{"centre", {c.tripod_centre.x(), c.tripod_centre.y()}},
                   {"camera_height_m", c.camera_height_m},
                   {"unseen_radius_m", c.unseen_radius_m}};
    if (c.advised_pitch_deg) j["tripod"]["advised_pitch_deg"] = *c.advised_pitch_deg;
  }
  return j.dump(1);
}

}  // namespace locard::forensics
