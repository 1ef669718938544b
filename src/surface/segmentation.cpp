#include <locard/core/error.hpp>
#include <locard/core/kdtree.hpp>
#include <locard/surface/segmentation.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace locard {

Segmentation region_growing(const PointCloud& cloud, const RegionGrowingOptions& options) {
  const std::size_t n = cloud.size();
  if (cloud.normals.size() != n)
    throw InputError("region_growing: the cloud needs one normal per point");
  const ScalarField* curvature = cloud.find_scalar("curvature");
  if (!curvature || curvature->values.size() != n)
    throw InputError("region_growing: the cloud needs a \"curvature\" scalar field (estimate "
                     "normals with compute_curvature)");
  const KdTree tree(cloud.positions);
  const NeighborLists neighbours =
      tree.hybrid_batch(cloud.positions, options.radius, options.max_neighbors);
  const float min_cos = static_cast<float>(std::cos(options.max_angle_deg * M_PI / 180.0));

  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return curvature->values[a] < curvature->values[b];
  });

  std::vector<std::int32_t> region(n, -1);
  std::vector<std::vector<std::uint32_t>> members;
  std::vector<std::uint32_t> front;
  for (std::uint32_t seed : order) {
    if (region[seed] >= 0) continue;
    const auto id = static_cast<std::int32_t>(members.size());
    members.emplace_back();
    region[seed] = id;
    members.back().push_back(seed);
    front.assign(1, seed);
    while (!front.empty()) {
      const std::uint32_t p = front.back();
      front.pop_back();
      for (const Neighbor& nb : neighbours[p]) {
        const std::uint32_t q = nb.index;
        if (region[q] >= 0) continue;
        if (std::abs(cloud.normals[p].dot(cloud.normals[q])) < min_cos) continue;
        region[q] = id;
        members.back().push_back(q);
        if (curvature->values[q] < options.max_curvature) front.push_back(q);
      }
    }
  }

  // Keep regions of at least min_points; order by size, then by smallest member.
  std::vector<std::size_t> kept;
  for (std::size_t r = 0; r < members.size(); ++r)
    if (members[r].size() >= options.min_points) kept.push_back(r);
  auto smallest = [&](std::size_t r) {
    return *std::min_element(members[r].begin(), members[r].end());
  };
  std::stable_sort(kept.begin(), kept.end(), [&](std::size_t a, std::size_t b) {
    if (members[a].size() != members[b].size()) return members[a].size() > members[b].size();
    return smallest(a) < smallest(b);
  });
  Segmentation out;
  out.labels.assign(n, -1);
  for (std::size_t label = 0; label < kept.size(); ++label) {
    for (std::uint32_t p : members[kept[label]]) out.labels[p] = static_cast<std::int32_t>(label);
    out.sizes.push_back(members[kept[label]].size());
  }
  return out;
}

void attach_segment_labels(PointCloud& cloud, const Segmentation& segmentation) {
  ScalarField field{"segment", {}};
  field.values.reserve(segmentation.labels.size());
  for (std::int32_t l : segmentation.labels) field.values.push_back(static_cast<float>(l));
  for (ScalarField& s : cloud.scalars)
    if (s.name == "segment") {
      s = std::move(field);
      return;
    }
  cloud.scalars.push_back(std::move(field));
}

}  // namespace locard
