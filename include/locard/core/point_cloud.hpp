#pragma once
// Point cloud in structure-of-arrays layout: one contiguous array per attribute, so kernels
// stream only what they touch (positions for a kd-tree, colours for colour ICP).
// Positions are float metres: ample for room-scale scenes (0.25 um resolution at 4 m); the
// registration kernels re-centre and work in double where residuals accumulate.

#include <locard/core/pose.hpp>

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace locard {

struct Rgb8 {
  std::uint8_t r = 0;
  std::uint8_t g = 0;
  std::uint8_t b = 0;
  bool operator==(const Rgb8&) const = default;
};

// An extra per-point scalar kept through read/write (curvature, intensity, confidence, label).
struct ScalarField {
  std::string name;
  std::vector<float> values;
  bool operator==(const ScalarField&) const = default;
};

class PointCloud {
 public:
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3f> normals;  // empty, or one per position (unit length)
  std::vector<Rgb8> colors;              // empty, or one per position
  std::vector<ScalarField> scalars;      // each empty-free: one value per position

  std::size_t size() const { return positions.size(); }
  bool empty() const { return positions.empty(); }
  bool has_normals() const { return !normals.empty(); }
  bool has_colors() const { return !colors.empty(); }

  void reserve(std::size_t n, bool with_normals, bool with_colors);
  void clear();
  // Appends the points of `other` (attributes present in both are kept; an attribute missing
  // from either side is dropped for the result, so the arrays never go out of step).
  void append(const PointCloud& other);
  // Throws locard::Error if an attribute array does not match positions in size.
  void check_consistent() const;
  const ScalarField* find_scalar(const std::string& name) const;
};

// The cloud moved rigidly by T: positions p -> R p + t and normals n -> R n, in float;
// colours and scalar fields unchanged.
PointCloud transformed(const PointCloud& cloud, const Isometry3d& T);

}  // namespace locard
