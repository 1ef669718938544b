#include <locard/core/error.hpp>
#include <locard/core/point_cloud.hpp>

namespace locard {

void PointCloud::reserve(std::size_t n, bool with_normals, bool with_colors) {
  positions.reserve(n);
  if (with_normals) normals.reserve(n);
  if (with_colors) colors.reserve(n);
}

void PointCloud::clear() {
  positions.clear();
  normals.clear();
  colors.clear();
  scalars.clear();
}

void PointCloud::append(const PointCloud& other) {
  const bool was_empty = empty();
  const bool keep_normals = (was_empty || has_normals()) && other.has_normals();
  const bool keep_colors = (was_empty || has_colors()) && other.has_colors();
  positions.insert(positions.end(), other.positions.begin(), other.positions.end());
  if (keep_normals)
    normals.insert(normals.end(), other.normals.begin(), other.normals.end());
  else
    normals.clear();
  if (keep_colors)
    colors.insert(colors.end(), other.colors.begin(), other.colors.end());
  else
    colors.clear();
  // Scalars survive only where both sides carry the same field.
  std::vector<ScalarField> merged;
  const auto& source = was_empty ? other.scalars : scalars;
  for (const auto& field : source) {
    const ScalarField* theirs = other.find_scalar(field.name);
    if (!theirs) continue;
    ScalarField f = was_empty ? *theirs : field;
    if (!was_empty) f.values.insert(f.values.end(), theirs->values.begin(), theirs->values.end());
    merged.push_back(std::move(f));
  }
  scalars = std::move(merged);
}

void PointCloud::check_consistent() const {
  const auto n = positions.size();
  if (!normals.empty() && normals.size() != n)
    throw Error("point cloud has " + std::to_string(n) + " positions but " +
                std::to_string(normals.size()) + " normals");
  if (!colors.empty() && colors.size() != n)
    throw Error("point cloud has " + std::to_string(n) + " positions but " +
                std::to_string(colors.size()) + " colours");
  for (const auto& s : scalars)
    if (s.values.size() != n)
      throw Error("point cloud has " + std::to_string(n) + " positions but scalar field '" +
                  s.name + "' has " + std::to_string(s.values.size()) + " values");
}

const ScalarField* PointCloud::find_scalar(const std::string& name) const {
  for (const auto& s : scalars)
    if (s.name == name) return &s;
  return nullptr;
}

PointCloud transformed(const PointCloud& cloud, const Isometry3d& T) {
  PointCloud out = cloud;
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  for (auto& p : out.positions) p = R * p + t;
  for (auto& n : out.normals) n = R * n;
  return out;
}

}  // namespace locard
