// Random rooms: a room, its objects, a tripod scan and a sensor drawn from one seed, in a fixed
// order of draws, then written as scene JSON and read back so that the scene returned is
// exactly what its scene.json reproduces.
#include <locard/sim/random_scene.hpp>

#include <locard/alignment/alignment_defaults.hpp>
#include <locard/sim/counter_rng.hpp>
#include <locard/sim/kinect_model.hpp>
#include <locard/sim/measurements.hpp>
#include <locard/sim/scene_mesh.hpp>

#include "core/convex_polygon.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <vector>

namespace locard::sim {
namespace {

// Sequential draws from the seed. Only uniforms are used, mapped by plain arithmetic, so the
// numbers are the same with every compiler and standard library.
class Draws {
 public:
  explicit Draws(std::uint64_t seed) : rng_(seed, RngStream::SceneLayout, 0, 0) {}

  double uniform(double lo, double hi) { return lo + (hi - lo) * rng_.uniform(); }
  // Integer in [lo, hi], each with the same odds.
  int integer(int lo, int hi) {
    const int n = hi - lo + 1;
    return lo + std::min(static_cast<int>(rng_.uniform() * n), n - 1);
  }
  bool chance(double p) { return rng_.uniform() < p; }
  // Rounded to the millimetre (or another step): readable scene files, exact round trips.
  double metres(double lo, double hi, double step = 0.001) {
    return std::clamp(std::round(uniform(lo, hi) / step) * step, lo, hi);
  }
  Rgb8 color(int lo, int hi) {
    const int r = integer(lo, hi), g = integer(lo, hi), b = integer(lo, hi);
    return {static_cast<std::uint8_t>(r), static_cast<std::uint8_t>(g),
            static_cast<std::uint8_t>(b)};
  }

 private:
  CounterRng rng_;
};

// Ranges (docs/simulator.md, "Random rooms").
constexpr double kRoomMin = 2.0, kRoomMax = 8.0;
constexpr double kHeightMin = 2.3, kHeightMax = 3.2;
constexpr int kMaxObjects = 12;
constexpr double kScannerClearance = 0.6;  // from walls and objects, horizontally
constexpr double kWallGap = 0.02;          // objects keep off the walls (no coplanar faces)
constexpr double kObjectGap = 0.10;        // between objects
constexpr int kPlacementTries = 40;

// --- 2-D footprints: convex hulls of an object's vertices seen from above ---------------------

using locard::detail::convex_hull;
using Point2 = locard::detail::Point2;
using Polygon = locard::detail::ConvexPolygon;

Polygon footprint(const SceneObject& o) {
  const TriangleMesh mesh = object_mesh(o);
  std::vector<Point2> points;
  for (const auto& v : mesh.vertices) points.emplace_back(v.x(), v.y());
  return convex_hull(std::move(points));
}

double segment_distance(const Point2& p, const Point2& a, const Point2& b) {
  const Point2 ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / std::max(ab.squaredNorm(), 1e-300), 0.0, 1.0);
  return (p - (a + t * ab)).norm();
}

double point_distance(const Polygon& poly, const Point2& p) {
  if (locard::detail::convex_contains(poly, p)) return 0.0;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < poly.size(); ++i)
    best = std::min(best, segment_distance(p, poly[i], poly[(i + 1) % poly.size()]));
  return best;
}

// Separating axis test for two convex polygons.
bool overlap(const Polygon& a, const Polygon& b) {
  for (const Polygon* poly : {&a, &b}) {
    for (std::size_t i = 0; i < poly->size(); ++i) {
      const Point2 e = (*poly)[(i + 1) % poly->size()] - (*poly)[i];
      const Point2 axis(-e.y(), e.x());
      double a_lo = std::numeric_limits<double>::infinity(), a_hi = -a_lo;
      double b_lo = a_lo, b_hi = a_hi;
      for (const Point2& p : a) a_lo = std::min(a_lo, axis.dot(p)), a_hi = std::max(a_hi, axis.dot(p));
      for (const Point2& p : b) b_lo = std::min(b_lo, axis.dot(p)), b_hi = std::max(b_hi, axis.dot(p));
      if (a_hi < b_lo || b_hi < a_lo) return false;
    }
  }
  return true;
}

double polygon_distance(const Polygon& a, const Polygon& b) {
  if (overlap(a, b)) return 0.0;
  double best = std::numeric_limits<double>::infinity();
  for (const Point2& p : a) best = std::min(best, point_distance(b, p));
  for (const Point2& p : b) best = std::min(best, point_distance(a, p));
  return best;
}

// --- procedural meshes (object frame, no colours: the object's colour is used) ---------------

void append(TriangleMesh& mesh, const TriangleMesh& piece) {
  const auto base = static_cast<std::uint32_t>(mesh.vertices.size());
  mesh.vertices.insert(mesh.vertices.end(), piece.vertices.begin(), piece.vertices.end());
  for (const auto& t : piece.triangles) mesh.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
}

// A table: a top of `size` (x, y; z its full height) `top` thick on four square legs.
TriangleMesh table_mesh(const Eigen::Vector3d& size, double top, double leg) {
  TriangleMesh mesh;
  const Rgb8 unused{0, 0, 0};
  append(mesh, box_mesh({0.0, 0.0, size.z() - 0.5 * top}, {size.x(), size.y(), top}, 0.0, unused));
  const double inset = 0.03;
  const double lx = 0.5 * size.x() - inset - 0.5 * leg, ly = 0.5 * size.y() - inset - 0.5 * leg;
  const double leg_height = size.z() - top;
  for (const double sx : {-1.0, 1.0})
    for (const double sy : {-1.0, 1.0})
      append(mesh, box_mesh({sx * lx, sy * ly, 0.5 * leg_height}, {leg, leg, leg_height}, 0.0, unused));
  return mesh;
}

// An icosahedron subdivided once (42 vertices, 80 faces) on a sphere of `radius`.
TriangleMesh icosphere_mesh(double radius) {
  const double g = 0.5 * (1.0 + std::sqrt(5.0));
  std::vector<Eigen::Vector3d> v = {{-1, g, 0}, {1, g, 0}, {-1, -g, 0}, {1, -g, 0},
                                    {0, -1, g}, {0, 1, g}, {0, -1, -g}, {0, 1, -g},
                                    {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
  std::vector<std::array<std::uint32_t, 3>> faces = {
      {0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
      {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
      {3, 8, 9},  {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (auto& p : v) p.normalize();
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> midpoints;
  auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
    const auto key = std::minmax(a, b);
    if (const auto it = midpoints.find(key); it != midpoints.end()) return it->second;
    v.push_back((v[a] + v[b]).normalized());
    const auto index = static_cast<std::uint32_t>(v.size() - 1);
    midpoints.emplace(key, index);
    return index;
  };
  TriangleMesh mesh;
  for (const auto& f : faces) {
    const std::uint32_t ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]),
                        ca = midpoint(f[2], f[0]);
    const std::array<std::array<std::uint32_t, 3>, 4> quarters{
        {{f[0], ab, ca}, {f[1], bc, ab}, {f[2], ca, bc}, {ab, bc, ca}}};
    for (const std::array<std::uint32_t, 3>& t : quarters) {
      // Counter-clockwise seen from outside: the normal points away from the centre.
      const Eigen::Vector3d n = (v[t[1]] - v[t[0]]).cross(v[t[2]] - v[t[0]]);
      mesh.triangles.push_back(n.dot(v[t[0]]) > 0 ? t : std::array<std::uint32_t, 3>{t[0], t[2], t[1]});
    }
  }
  for (const auto& p : v) mesh.vertices.push_back((radius * p).cast<float>());
  return mesh;
}

// Height of a mesh's bounding box, so that `center.z` (the box's centre) stands it on the floor.
double mesh_height(const TriangleMesh& mesh) {
  float lo = std::numeric_limits<float>::max(), hi = -lo;
  for (const auto& v : mesh.vertices) lo = std::min(lo, v.z()), hi = std::max(hi, v.z());
  return static_cast<double>(hi - lo);
}

// --- the draws ----------------------------------------------------------------------------

// The texture is drawn in plain rooms too, so that forcing the kind of surface changes nothing
// else about the room.
Texture draw_texture(Draws& d, SurfaceKind surfaces, bool room) {
  const Texture drawn = room ? (d.chance(0.5) ? Texture::Checker : Texture::Noise)
                             : std::array{Texture::Plain, Texture::Checker, Texture::Noise}[
                                   static_cast<std::size_t>(d.integer(0, 2))];
  return surfaces == SurfaceKind::Plain ? Texture::Plain : drawn;
}

// An object of a drawn kind and size, centred at the origin on the floor (x, y to be drawn).
SceneObject draw_object(Draws& d, int index, SurfaceKind surfaces) {
  SceneObject o;
  const int kind = d.integer(0, 3);
  o.color = d.color(50, 230);
  o.has_color = true;
  o.texture = draw_texture(d, surfaces, false);
  o.texture_scale = d.metres(0.02, 0.12);
  o.yaw_deg = std::round(d.uniform(0.0, 360.0) * 10.0) / 10.0;
  switch (kind) {
    case 0:
      o.name = fmt::format("box_{}", index);
      o.shape = ShapeKind::Box;
      o.size = {d.metres(0.2, 1.6), d.metres(0.2, 1.6), d.metres(0.1, 2.0)};
      o.center.z() = 0.5 * o.size.z();
      break;
    case 1:
      o.name = fmt::format("cylinder_{}", index);
      o.shape = ShapeKind::Cylinder;
      o.radius = d.metres(0.05, 0.4);
      o.height = d.metres(0.2, 1.5);
      o.segments = d.chance(0.5) ? 32 : 48;
      o.yaw_deg = 0.0;  // a cylinder's facets do not turn
      o.center.z() = 0.5 * o.height;
      break;
    case 2: {
      o.name = fmt::format("table_{}", index);
      o.shape = ShapeKind::Mesh;
      const Eigen::Vector3d size(d.metres(0.6, 1.6), d.metres(0.5, 1.0), d.metres(0.6, 0.9));
      const double top = d.metres(0.03, 0.05), leg = d.metres(0.04, 0.07);
      o.mesh = table_mesh(size, top, leg);
      o.center.z() = 0.5 * size.z();
      break;
    }
    default:
      o.name = fmt::format("ball_{}", index);
      o.shape = ShapeKind::Mesh;
      o.mesh = icosphere_mesh(d.metres(0.15, 0.45));
      o.center.z() = 0.5 * mesh_height(o.mesh);
      break;
  }
  return o;
}

bool inside_room(const Polygon& poly, const Eigen::Vector3d& room) {
  for (const Point2& p : poly)
    if (std::abs(p.x()) > 0.5 * room.x() - kWallGap || std::abs(p.y()) > 0.5 * room.y() - kWallGap)
      return false;
  return true;
}

// Tries to put `o` somewhere free; false when every try collides.
bool place(Draws& d, SceneObject& o, const Scene& scene, const std::vector<Polygon>& placed) {
  o.center.x() = o.center.y() = 0.0;
  const Polygon at_origin = footprint(o);
  double lo_x = 0, hi_x = 0, lo_y = 0, hi_y = 0;
  for (const Point2& p : at_origin) {
    lo_x = std::min(lo_x, p.x()), hi_x = std::max(hi_x, p.x());
    lo_y = std::min(lo_y, p.y()), hi_y = std::max(hi_y, p.y());
  }
  const Eigen::Vector3d& room = scene.room.size;
  const double x0 = -0.5 * room.x() + kWallGap + 0.001 - lo_x, x1 = 0.5 * room.x() - kWallGap - 0.001 - hi_x;
  const double y0 = -0.5 * room.y() + kWallGap + 0.001 - lo_y, y1 = 0.5 * room.y() - kWallGap - 0.001 - hi_y;
  if (x0 > x1 || y0 > y1) return false;
  const Point2 scanner = scene.scanner.position.head<2>();
  for (int attempt = 0; attempt < kPlacementTries; ++attempt) {
    o.center.x() = d.metres(x0, x1);
    o.center.y() = d.metres(y0, y1);
    const Polygon poly = footprint(o);
    if (!inside_room(poly, room)) continue;
    if (point_distance(poly, scanner) < kScannerClearance) continue;
    bool free = true;
    for (const Polygon& other : placed) free = free && polygon_distance(poly, other) >= kObjectGap;
    if (free) return true;
  }
  return false;
}

// The tripod's rings overlap as a scan protocol makes them: the next ring is pitched up by 30-60 %
// of the depth camera's vertical field of view, so neighbouring rings share 40-70 % of it (a gap
// wider than the field leaves rings that no method can join). One ring: level or looking down.
std::vector<double> draw_pitches(Draws& d, const KinectModel& sensor) {
  const int rings = d.integer(1, 3);
  const double down = d.integer(-25, -10);
  const double spacing_share = d.uniform(0.3, 0.6);
  const bool level_alone = d.chance(0.25);
  if (rings == 1) return {level_alone ? 0.0 : down};
  const double spacing = std::round(spacing_share * sensor.intrinsics.vertical_fov_deg());
  std::vector<double> pitches{down};
  for (int r = 1; r < rings; ++r) pitches.push_back(pitches.back() + spacing);
  return pitches;
}

// Where the sensor sees walls: 85 % of the range alignment uses for it (alignment_defaults.hpp),
// so a view at any ring's pitch holds wall as well as floor. An investigator's single tripod
// station stands where every wall is in reach; a room wider than twice the reach needs a second
// station, which is not drawn.
double wall_reach_m(ScannerModel sensor) {
  return 0.85 * default_max_depth_m(depth_sensor_kind(sensor));
}

// A uniform draw u in [lo, hi] mapped onto [lo, top]: the same draw whatever the cap.
double capped(double u, double lo, double hi, double top) {
  if (top >= hi) return u;
  return std::round((lo + (u - lo) * (top - lo) / (hi - lo)) * 1000.0) / 1000.0;
}

}  // namespace

std::string_view to_string(SurfaceKind kind) {
  switch (kind) {
    case SurfaceKind::Plain: return "plain";
    case SurfaceKind::Textured: return "textured";
  }
  return "plain";
}

std::optional<SurfaceKind> parse_surface_kind(std::string_view name) {
  for (SurfaceKind k : {SurfaceKind::Plain, SurfaceKind::Textured})
    if (name == to_string(k)) return k;
  return std::nullopt;
}

SurfaceKind surface_kind(const Scene& scene) {
  bool plain = scene.room.texture == Texture::Plain;
  for (const SceneObject& o : scene.objects) plain = plain && o.texture == Texture::Plain;
  return plain ? SurfaceKind::Plain : SurfaceKind::Textured;
}

Scene random_scene(std::uint64_t seed, const RandomSceneOptions& options) {
  Draws d(seed);
  Scene scene;
  scene.name = fmt::format("random_{}", seed);
  // Both coin flips are always made, so forcing one leaves every other draw as it was.
  const ScannerModel drawn_sensor = d.chance(0.5) ? ScannerModel::KinectV2 : ScannerModel::KinectV1;
  const SurfaceKind drawn_surfaces = d.chance(0.5) ? SurfaceKind::Plain : SurfaceKind::Textured;
  const ScannerModel sensor = options.sensor.value_or(drawn_sensor);
  const SurfaceKind surfaces = options.surfaces.value_or(drawn_surfaces);

  RoomSpec& room = scene.room;
  const double reach = wall_reach_m(sensor);
  const double widest = std::min(kRoomMax, 2.0 * reach);
  room.size = {capped(d.metres(kRoomMin, kRoomMax), kRoomMin, kRoomMax, widest),
               capped(d.metres(kRoomMin, kRoomMax), kRoomMin, kRoomMax, widest),
               d.metres(kHeightMin, kHeightMax)};
  room.wall_color = d.color(150, 235);
  room.floor_color = d.color(60, 200);
  room.ceiling_color = d.color(200, 245);
  room.texture = draw_texture(d, surfaces, true);
  room.texture_scale = d.metres(0.03, 0.30);

  ScannerSpec& scanner = scene.scanner;
  scanner.model = sensor;
  // Off centre by up to what keeps the walls in reach and the tripod clear of them.
  const auto off_centre = [&](double side) {
    const double half = 0.5 * side;
    const double most = std::max(0.0, std::min(half - kScannerClearance, reach - half));
    return std::round(d.uniform(-1.0, 1.0) * most * 1000.0) / 1000.0;
  };
  const double sx = off_centre(room.size.x());
  const double sy = off_centre(room.size.y());
  scanner.position = {sx, sy, d.metres(1.0, 1.6)};
  scanner.views = d.integer(24, 72);
  scanner.pitch_deg = draw_pitches(d, KinectModel::of(sensor));
  scanner.yaw_jitter_deg = d.metres(0.5, 2.0, 0.01);
  scanner.position_jitter_m = d.metres(0.0, 0.008, 0.0001);
  scanner.seed = seed;
  scanner.noise = true;

  const int wanted = d.integer(0, kMaxObjects);
  std::vector<Polygon> placed;
  for (int i = 0; i < wanted; ++i) {
    SceneObject o = draw_object(d, i + 1, surfaces);
    if (!place(d, o, scene, placed)) continue;
    placed.push_back(footprint(o));
    scene.objects.push_back(std::move(o));
  }

  scene.measurements = derive_seen_measurements(scene, KinectModel::of(sensor));

  // The scene returned is the one its JSON reads back to (floats and all).
  std::string source = fmt::format("random:{}", seed);
  if (options.sensor) source += fmt::format(" --sensor {}", to_string(*options.sensor));
  if (options.surfaces) source += fmt::format(" --surfaces {}", to_string(*options.surfaces));
  const std::string text = scene_json(scene);
  Scene parsed = parse_scene(text, source);
  parsed.source = source;
  return parsed;
}

std::string random_scene_summary(const Scene& scene) {
  const Eigen::Vector3d& r = scene.room.size;
  const Eigen::Vector3d& p = scene.scanner.position;
  int boxes = 0, cylinders = 0, meshes = 0;
  for (const SceneObject& o : scene.objects)
    (o.shape == ShapeKind::Box ? boxes : o.shape == ShapeKind::Cylinder ? cylinders : meshes)++;
  std::string pitches;
  for (const double pitch : scene.scanner.pitch_deg)
    pitches += fmt::format("{}{:g}", pitches.empty() ? "" : "/", pitch);
  return fmt::format(
      "{}: room {:.3f} x {:.3f} x {:.3f} m, {} surfaces, {} objects ({} boxes, {} cylinders, {} "
      "meshes), {} rings x {} views (pitch {} deg), {}, scanner at ({:.3f}, {:.3f}, {:.3f}) m",
      scene.name, r.x(), r.y(), r.z(), to_string(surface_kind(scene)), scene.objects.size(),
      boxes, cylinders, meshes, scene.scanner.pitch_deg.size(), scene.scanner.views, pitches,
      to_string(scene.scanner.model), p.x(), p.y(), p.z());
}

}  // namespace locard::sim
