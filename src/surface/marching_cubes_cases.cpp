#include "surface/marching_cubes_cases.hpp"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <algorithm>
#include <vector>

namespace locard::detail {
namespace {

// The corners whose bit `axis` is clear, in increasing order: the low ends of that axis' edges.
int low_corner_of(int axis, int k) {
  int found = 0;
  for (int c = 0; c < 8; ++c) {
    if (c & (1 << axis)) continue;
    if (found++ == k) return c;
  }
  return -1;
}

int edge_between(int a, int b) {
  const int diff = a ^ b;
  const int axis = diff == 1 ? 0 : diff == 2 ? 1 : 2;
  const int low = a & ~diff;
  for (int k = 0; k < 4; ++k)
    if (low_corner_of(axis, k) == low) return axis * 4 + k;
  return -1;
}

Eigen::Vector3f corner_position(int c) {
  return Eigen::Vector3f(static_cast<float>(c & 1), static_cast<float>((c >> 1) & 1),
                         static_cast<float>((c >> 2) & 1));
}

MarchingCubesCase derive_case(int index) {
  auto negative = [index](int c) { return (index >> c) & 1; };
  // Adjacency between crossed edges: each has at most two partners (one per face).
  std::array<std::array<int, 2>, 12> partner;
  for (auto& p : partner) p = {-1, -1};
  auto link = [&partner](int a, int b) {
    partner[a][partner[a][0] < 0 ? 0 : 1] = b;
    partner[b][partner[b][0] < 0 ? 0 : 1] = a;
  };
  for (int axis = 0; axis < 3; ++axis) {
    const int b = (axis + 1) % 3;
    const int c = (axis + 2) % 3;
    for (int side = 0; side < 2; ++side) {
      const int base = side << axis;
      const std::array<int, 4> q = {base, base | (1 << b), base | (1 << b) | (1 << c),
                                    base | (1 << c)};
      std::array<int, 4> f;  // f[i] joins q[i] and q[i + 1]
      std::vector<int> crossed;
      for (int i = 0; i < 4; ++i) {
        f[i] = edge_between(q[i], q[(i + 1) % 4]);
        if (negative(q[i]) != negative(q[(i + 1) % 4])) crossed.push_back(i);
      }
      if (crossed.size() == 2) {
        link(f[crossed[0]], f[crossed[1]]);
      } else if (crossed.size() == 4) {
        // Corner q[i] touches edges f[i - 1] and f[i]; pair around the negative corners.
        for (int i = 0; i < 4; ++i)
          if (negative(q[i])) link(f[(i + 3) % 4], f[i]);
      }
    }
  }

  MarchingCubesCase out;
  std::array<bool, 12> used{};
  for (int start = 0; start < 12; ++start) {
    if (used[start] || partner[start][0] < 0) continue;
    std::vector<int> cycle;
    int previous = -1;
    int current = start;
    while (!used[current]) {
      used[current] = true;
      cycle.push_back(current);
      const int next = partner[current][0] != previous ? partner[current][0] : partner[current][1];
      previous = current;
      current = next;
    }
    // Orientation: Newell normal of the polygon through the edge midpoints against the
    // direction from negative to positive corners.
    Eigen::Vector3f normal = Eigen::Vector3f::Zero();
    Eigen::Vector3f gradient = Eigen::Vector3f::Zero();
    for (std::size_t i = 0; i < cycle.size(); ++i) {
      auto mid = [](int e) -> Eigen::Vector3f {
        const int lo = edge_low_corner(e);
        return 0.5f * (corner_position(lo) + corner_position(lo | (1 << edge_axis(e))));
      };
      normal += mid(cycle[i]).cross(mid(cycle[(i + 1) % cycle.size()]));
      const int lo = edge_low_corner(cycle[i]);
      const int hi = lo | (1 << edge_axis(cycle[i]));
      const Eigen::Vector3f d = corner_position(hi) - corner_position(lo);
      gradient += negative(lo) ? d : Eigen::Vector3f(-d);
    }
    if (normal.dot(gradient) < 0.f) std::reverse(cycle.begin(), cycle.end());
    for (std::size_t i = 1; i + 1 < cycle.size(); ++i)
      out.triangles[out.triangle_count++] = {static_cast<std::uint8_t>(cycle[0]),
                                             static_cast<std::uint8_t>(cycle[i]),
                                             static_cast<std::uint8_t>(cycle[i + 1])};
  }
  return out;
}

}  // namespace

int edge_low_corner(int edge) { return low_corner_of(edge_axis(edge), edge % 4); }

const std::array<MarchingCubesCase, 256>& marching_cubes_cases() {
  static const std::array<MarchingCubesCase, 256> cases = [] {
    std::array<MarchingCubesCase, 256> all;
    for (int i = 0; i < 256; ++i) all[i] = derive_case(i);
    return all;
  }();
  return cases;
}

}  // namespace locard::detail
