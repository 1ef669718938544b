#pragma once
// What of the floor the scan observed, in a levelled case (z up): where a body, a casing or a
// stain would lie. The floor plane is cut into square cells; each cell's centre is projected
// into every trusted view's depth image (the same test a TSDF makes when it carves free space
// along a ray):
//   seen     a view measured the floor there (depth within the sensor's noise of the cell);
//   hidden   it lay in some view's field and range, but every such view measured something in
//            front of it (under a table, behind a box);
//   unseen   no view had it in its field of view and range with a return (under the tripod, a
//            ring that never looked down, beyond the sensor's range);
//   not floor  outside the room's footprint (the convex hull of everything seen, from above),
//            or a view saw through the plane there (a stairwell, a doorway's far side).
// Advice follows from the shape of what is missing: a disc around a tripod asks for a ring
// pitched down far enough to see it; other unseen patches ask for another scan position.
#include <locard/core/camera_intrinsics.hpp>
#include <locard/core/pose.hpp>
#include <locard/io/rgbd_sequence.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace locard::forensics {

enum class FloorCell : std::uint8_t { NotFloor, Seen, Hidden, Unseen };

struct FloorCoverageOptions {
  double cell_m = 0.05;
  std::size_t max_views = 120;  // views spread evenly over a long video; a tripod set uses all
  // A depth within this of the cell's (plus the sensor's spread, 1 % of z^2) measures it.
  double margin_m = 0.03;
  double min_depth_m = 0.3;
  double max_depth_m = 8.0;
  // A tripod's unseen disc: the radius out to which at least this share of floor is unseen.
  double disc_unseen_share = 0.75;
  // Patches smaller than this are not worth a line of advice.
  double min_patch_m2 = 0.25;
  // The nearest floor a downward ring should reach (a tripod's legs stand about here).
  double tripod_foot_m = 0.3;
};

// A connected patch of unseen floor (not the disc around a tripod).
struct UnseenPatch {
  double area_m2 = 0.0;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double distance_m = 0.0;  // from the nearest camera that was placed
};

struct FloorCoverage {
  double floor_z_m = 0.0;
  double cell_m = 0.05;
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();  // corner of cell (0, 0)
  int nx = 0, ny = 0;
  std::vector<FloorCell> cells;  // row-major, y rows, x columns
  std::size_t views_used = 0;
  double seen_m2 = 0.0, hidden_m2 = 0.0, unseen_m2 = 0.0;
  // Tripod turn: the camera centres' mean (xy), the camera height over the floor, the radius of
  // the unseen disc about the centre (0 when none) and the downward ring that would cover it.
  bool tripod = false;
  Eigen::Vector2d tripod_centre = Eigen::Vector2d::Zero();
  double camera_height_m = 0.0;
  double unseen_radius_m = 0.0;
  std::optional<double> advised_pitch_deg;
  std::vector<UnseenPatch> patches;  // largest first, each >= min_patch_m2
  std::vector<std::string> advice;   // for the investigator, one line each

  FloorCell at(int x, int y) const { return cells[static_cast<std::size_t>(y) * nx + x]; }
  Eigen::Vector2d cell_centre(int x, int y) const {
    return origin + cell_m * Eigen::Vector2d(x + 0.5, y + 0.5);
  }
  double seen_share() const {
    const double all = seen_m2 + hidden_m2 + unseen_m2;
    return all > 0 ? seen_m2 / all : 0.0;
  }
};

// The floor's height in a levelled case from points seen there (the lowest horizontal plane
// with enough points); nullopt without one.
std::optional<double> floor_height(const std::vector<Eigen::Vector3d>& points);

// `poses[i]` is frame i's camera pose in the levelled case frame, or nullopt (flagged, not
// registered, not in the model): only placed views count. `floor_z_m` from floor_height.
FloorCoverage compute_floor_coverage(const RgbdSequence& sequence,
                                     const std::vector<std::optional<Isometry3d>>& poses,
                                     double floor_z_m, const FloorCoverageOptions& options = {});

// As JSON: the grid as one string a row ('.' not floor, 's' seen, 'h' hidden, 'u' unseen),
// row 0 at the smallest y; areas, tripod, patches, advice.
std::string floor_coverage_json(const FloorCoverage& coverage);

}  // namespace locard::forensics
