#pragma once

// Geometric primitives on Vec3 (2D data has z = 0), free functions without state: closest points
// on segments and triangles (exact up to rounding), squared distances between points, boxes,
// segments and triangles (0 where they cross, by crossing tests; segment to box only a lower
// bound), conservative simplex-box overlap tests (never false when they touch) and the perturbed
// row-crossing tests whose parity tells inside from outside, consistent on shared edges.

#include <algorithm>

#include "gvd/geometry/vec.h"

namespace gvd {

/// Closest point to `p` on the closed segment [a, b] (a degenerate segment gives a).
Vec3 closest_point_on_segment(Vec3 p, Vec3 a, Vec3 b);

/// Closest point to `p` on the closed triangle (a, b, c), by Voronoi regions of the
/// triangle's features (Ericson, Real-Time Collision Detection §5.1.5). Exact up to rounding;
/// degenerate triangles fall back to their longest edge.
Vec3 closest_point_on_triangle(Vec3 p, Vec3 a, Vec3 b, Vec3 c);

/// Squared distance from `p` to box `b` (0 inside). Inline: the BVH's inner loop.
inline double box_distance2(Vec3 p, const Box& b) {
  const double dx = std::max({b.lo.x - p.x, p.x - b.hi.x, 0.0});
  const double dy = std::max({b.lo.y - p.y, p.y - b.hi.y, 0.0});
  const double dz = std::max({b.lo.z - p.z, p.z - b.hi.z, 0.0});
  return dx * dx + dy * dy + dz * dz;
}

/// Conservative overlap test of a closed 3D triangle and a closed box: never false when they
/// touch. Separating axis test (Akenine-Möller) on the box inflated by `slack` (absolute).
bool triangle_overlaps_box(Vec3 a, Vec3 b, Vec3 c, const Box& box, double slack);

/// Conservative overlap test of a closed 2D segment (z ignored) and a closed box (x, y).
bool segment_overlaps_box_2d(Vec3 a, Vec3 b, const Box& box, double slack);

/// Squared distance between segments [p0, p1] and [q0, q1] and their closest points.
double segment_segment_closest(Vec3 p0, Vec3 p1, Vec3 q0, Vec3 q1, Vec3& on_p, Vec3& on_q);

/// Squared distance between segments [p0, p1] and [q0, q1] (3D; 2D data has z = 0).
double segment_segment_dist2(Vec3 p0, Vec3 p1, Vec3 q0, Vec3 q1);

/// Squared distance between 2D segments (z ignored): exactly 0 when they cross (orientation
/// tests), else segment_segment_dist2 (whose closest points of crossing segments only agree
/// up to rounding).
double segment_segment_dist2_2d(Vec3 p0, Vec3 p1, Vec3 q0, Vec3 q1);

/// Squared distance between two triangles (0 when they intersect): the minimum over
/// vertex-triangle and edge-edge pairs, with an exact crossing test for the intersecting case.
double triangle_triangle_dist2(const Vec3 a[3], const Vec3 b[3]);

/// Squared distance between segment [p0, p1] and the closed triangle (a, b, c) (0 when the
/// segment crosses it): the minimum of the crossing test, the endpoints' closest points and
/// the three edge-segment distances.
double segment_triangle_dist2(Vec3 p0, Vec3 p1, Vec3 a, Vec3 b, Vec3 c);

/// A lower bound of the squared distance between segment [p0, p1] and box `b` (0 when they
/// may touch): the larger of the box-to-box distance of the segment's bounding box and the
/// distance from the midpoint less half the length.
double segment_box_distance2_bound(Vec3 p0, Vec3 p1, const Box& b);

/// Squared distance between two simplices (2D: segments q[0..1], s[0..1]; 3D: triangles
/// q[0..2], s[0..2]) and a point of q nearest to s: 0 when they cross (a point near the
/// crossing), else the least of the vertex-to-simplex and edge-to-edge distances, where the
/// closest pair of two disjoint convex polygons lies.
double simplex_simplex_closest(int dimension, const Vec3* q, const Vec3* s, Vec3& on_q);

/// Whether the line {(t, y, z) : t real} (3D), perturbed to (t, y + eps, z + eps^2) for an
/// infinitesimal eps > 0, crosses triangle abc, and at which t (`x`). The perturbation
/// (simulation of simplicity) makes the answer consistent where the line meets an edge or a
/// vertex: every such line crosses a closed mesh an even number of times, and the two
/// triangles of an edge decide their shared edge bit for bit alike, so the parity of the
/// crossings on one side of a point says whether it is inside (ray casting). Edge-on
/// triangles are never crossed.
bool row_crosses_triangle(Vec3 a, Vec3 b, Vec3 c, double y, double z, double& x);
/// 2D: whether the line {(t, y)}, perturbed to y + eps, crosses segment ab (a vertex exactly
/// on the line counts as below it), and at which t (`x`). Segments along the line never are.
bool row_crosses_segment(Vec3 a, Vec3 b, double y, double& x);

}  // namespace gvd
