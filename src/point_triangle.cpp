// SPDX-License-Identifier: Apache-2.0
#include <cmath>

#include "distance_internal.hpp"
#include "osteon/hausdorff.hpp"

// Based on: C. Ericson, "Real-Time Collision Detection", 2005, section 5.1.5: the closest point of
// a triangle found by testing which Voronoi region of its vertices, edges or face holds the query
// point, with dot products only (no square root, no normal).

namespace osteon {

namespace {

// Below this sine squared of the angle at a, a triangle is measured as its three edges.
constexpr double kSliver = 1e-20;

// The point of segment [a, b] closest to p (a itself when the segment is a point).
Vec3d closest_on_segment(const Vec3d& p, const Vec3d& a, const Vec3d& b) {
  Vec3d ab = b - a;
  double length2 = dot(ab, ab);
  if (!(length2 > 0)) return a;
  double t = dot(p - a, ab) / length2;
  t = t < 0 ? 0 : (t > 1 ? 1 : t);
  return a + t * ab;
}

}  // namespace

namespace detail {

namespace {

// Sets *q and returns |p - q|^2.
double at(const Vec3d& p, const Vec3d& q_value, Vec3d* q) {
  *q = q_value;
  return squared_length(p - q_value);
}

}  // namespace

// The seven regions of the triangle's plane (and the prisms above and below them): three vertex
// regions (A, B, C), three edge regions and the face.
//
//                   C
//                   c
//       ac side    / \    bc side
//                 /   \   (beyond edge bc)
//                / face\  (p projects inside)
//      A ------ a ----- b ------ B
//                ab side
//
// Vertex regions lie beyond both edges that meet at the vertex (the two dot products against
// those edges say so); edge regions lie outside the edge and between its two ends (the sign of
// the barycentric coordinate of the opposite vertex, an area computed from the same dot products,
// says outside). Whatever is left projects inside the face.
double closest_on_triangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c,
                           Vec3d* q) {
  Vec3d ab = b - a, ac = c - a;
  Vec3d n = cross(ab, ac);
  double nn = dot(n, n);
  // Zero area (collinear or repeated corners), or so nearly that the region tests below would
  // be rounding noise (sine of the angle at a below 1e-10): the triangle is the union of its
  // edges, within 1e-10 of its longest edge.
  if (!(nn > kSliver * dot(ab, ab) * dot(ac, ac))) {
    double best = at(p, closest_on_segment(p, a, b), q);
    Vec3d other;
    double d2 = at(p, closest_on_segment(p, b, c), &other);
    if (d2 < best) best = at(p, other, q);
    d2 = at(p, closest_on_segment(p, c, a), &other);
    if (d2 < best) best = at(p, other, q);
    return best;
  }

  Vec3d ap = p - a;
  double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return at(p, a, q);

  Vec3d bp = p - b;
  double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return at(p, b, q);

  // vc: the barycentric coordinate of c times twice the squared area; <= 0 puts p outside ab.
  double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return at(p, a + (d1 / (d1 - d3)) * ab, q);

  Vec3d cp = p - c;
  double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return at(p, c, q);

  double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return at(p, a + (d2 / (d2 - d6)) * ac, q);

  double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
    double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return at(p, b + w * (c - b), q);
  }

  // Inside the face: the foot of the perpendicular. Computed from the normal rather than from
  // va, vb, vc (whose sum is |n|^2 by Lagrange's identity, but each with cancellation), which
  // keeps thin triangles accurate.
  double height = dot(ap, n) / nn;
  *q = p - height * n;
  return height * height * nn;
}

}  // namespace detail

ClosestPoint closest_point_on_triangle(const Vec3d& p, const Vec3d& a, const Vec3d& b,
                                       const Vec3d& c) {
  ClosestPoint result;
  result.distance = std::sqrt(detail::closest_on_triangle(p, a, b, c, &result.point));
  return result;
}

}  // namespace osteon
