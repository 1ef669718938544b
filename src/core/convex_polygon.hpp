#pragma once
// Convex polygons in the plane, counter-clockwise: the hull of a point set (Andrew's monotone
// chain) and whether a point lies inside. Shared by the random room generator (objects'
// footprints from above) and the floor coverage (the room's footprint from above).
#include <Eigen/Core>

#include <algorithm>
#include <cstddef>
#include <vector>

namespace locard::detail {

using Point2 = Eigen::Vector2d;
using ConvexPolygon = std::vector<Point2>;  // counter-clockwise

// Twice the signed area of the triangle o, a, b: > 0 when b lies left of o -> a.
inline double cross2(const Point2& o, const Point2& a, const Point2& b) {
  return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
}

// Fewer than 3 points come back as given (sorted).
inline ConvexPolygon convex_hull(std::vector<Point2> points) {
  std::sort(points.begin(), points.end(), [](const Point2& a, const Point2& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  if (points.size() < 3) return points;
  ConvexPolygon hull(2 * points.size());
  std::size_t k = 0;
  for (const Point2& p : points) {
    while (k >= 2 && cross2(hull[k - 2], hull[k - 1], p) <= 0) --k;
    hull[k++] = p;
  }
  for (std::size_t i = points.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cross2(hull[k - 2], hull[k - 1], points[i]) <= 0) --k;
    hull[k++] = points[i];
  }
  hull.resize(k - 1);
  return hull;
}

// Inside or on the boundary.
inline bool convex_contains(const ConvexPolygon& poly, const Point2& p) {
  for (std::size_t i = 0; i < poly.size(); ++i)
    if (cross2(poly[i], poly[(i + 1) % poly.size()], p) < 0) return false;
  return true;
}

}  // namespace locard::detail
