#pragma once
// Evidence markers: numbered, labelled points on the model, given in the world frame and
// reported in a case frame the investigator chooses (an origin and axes, e.g. a room corner
// with x along one wall and z up).
//
// Files (docs/case-format.md): evidence/markers.json
//   {"frame": {"origin": [x,y,z], "x_axis": [...], "y_axis": [...], "z_axis": [...],
//              "description": "..."},
//    "markers": [{"number", "label", "note", "world": [x,y,z], "local": [x,y,z],
//                 "snapped": bool, "expanded_uncertainty_m", "created",
//                 "previous_names": [...], "withdrawn": {"reason", "at"}}]}
// and evidence/markers.csv with number,label,x,y,z (local frame),world_x,world_y,world_z,
// uncertainty_m,note,status,previous_labels. A withdrawn marker stays in both files, its
// number and label reserved (see revisions.hpp).

#include <locard/forensics/revisions.hpp>

#include <Eigen/Core>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace locard::forensics {

// Local coordinates of a world point p: R^T (p - origin), R's columns the unit axes.
struct CaseFrame {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();  // columns: x, y, z axes in the world
  std::string description = "world frame of the reconstruction";

  Eigen::Vector3d to_local(const Eigen::Vector3d& world) const;
  Eigen::Vector3d to_world(const Eigen::Vector3d& local) const;
  // Origin, a point along +x, and a point in the xy half-plane of +y (right-handed, Gram-
  // Schmidt). Throws InputError when the points are (nearly) collinear.
  static CaseFrame from_points(const Eigen::Vector3d& origin, const Eigen::Vector3d& on_x_axis,
                               const Eigen::Vector3d& in_xy_plane, std::string description);
};

// `locard level`: the frame `current` turned so its z is the normal of the floor through
// `floor_points` (world, at least 3, spread over at least 10 cm both ways; least-squares plane,
// normal on current's +z side) and its origin dropped onto that floor; x is current's x laid
// into the floor plane. Throws InputError naming what is wrong with the points.
struct LevelledFrame {
  CaseFrame frame;
  double tilt_deg = 0.0;   // between current's z and the floor's normal
  double rms_m = 0.0;      // of the points about the fitted plane
  double max_m = 0.0;      // the farthest point from it
};
LevelledFrame level_frame(const CaseFrame& current, const std::vector<Eigen::Vector3d>& floor_points);

struct EvidenceMarker {
  int number = 0;  // 1, 2, 3 ... never reused
  std::string label;
  std::string note;
  Eigen::Vector3d world = Eigen::Vector3d::Zero();
  bool snapped = false;  // moved onto the surface by snap_point
  double expanded_uncertainty_m = 0.0;
  std::string created;   // ISO 8601 UTC
  Revisions revisions;   // earlier labels, withdrawal
};

struct MarkerSet {
  CaseFrame frame;
  std::vector<EvidenceMarker> markers;

  // Appends a marker numbered one past the highest so far. Throws InputError for an empty or
  // duplicate label.
  const EvidenceMarker& add(EvidenceMarker marker);
  // By number ("3", "marker:3") or by label (current or withdrawn).
  const EvidenceMarker* find(const std::string& name_or_number) const;
  EvidenceMarker* find(const std::string& name_or_number);
  // A marker a command may use as a point: InputError when it was withdrawn (naming the
  // reason); nullptr when there is none.
  const EvidenceMarker* find_usable(const std::string& name_or_number) const;
  // Removes by number; false when there is none.
  bool remove(int number);
};

// An empty set (world frame) when the file does not exist. Throws InputError naming the file
// for anything malformed.
MarkerSet read_markers(const std::filesystem::path& json_path);
// Writes markers.json and markers.csv beside it (atomic).
void write_markers(const std::filesystem::path& json_path, const MarkerSet& markers);
std::string markers_csv(const MarkerSet& markers);

}  // namespace locard::forensics
