#pragma once

// Internal to core/surface: the boundary polygons of a leaf, shared by ambiguity detection
// and surfacing so both see the same graph.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>

#include "gvd/distance/distance_field.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/octree/octree.h"
#include "gvd/octree/vertices.h"

namespace gvd::surface::detail {

/// A boundary polygon of a leaf: its vertices in a canonical cyclic order that depends only on
/// the face's position in the lattice (so both cells of a face see the same order). In 3D the
/// order is counter-clockwise around +axis; in 2D (axis = 2) counter-clockwise in the plane.
struct FacePolygon {
  int n = 0;
  uint32_t v[8] = {};
  uint8_t slot[8] = {};    ///< grid index (LeafGrid) of each vertex
  int axis = 2;            ///< normal axis of the face (2 for the 2D cell itself)
  int side = 0;            ///< 0: face at the cell's lower coordinate, 2: upper (3D only)
  bool on_domain = false;  ///< 3D: the face lies on the domain box
};

inline int grid_index(int i, int j, int k) { return i + 3 * j + 9 * k; }

/// Eq. (1) of the paper in vector form: the point of edge [x0, x1] equidistant from the
/// closest points a and b of its ends, clamped to the edge. Computed from the endpoint with
/// the smaller index so that every cell sharing the edge gets the identical point. The clamp
/// keeps a hair inside the edge: where the GVD runs exactly through octree vertices (common
/// in symmetric scenes) the vertex's label decides its side, and pieces of neighbouring cells
/// never collapse onto a shared face.
/// `inside` is the hair as a fraction of the edge; callers on edges much longer than the
/// distance to the objects (certified pair cells, thin gaps) pass less, so that the hair stays
/// far below the local clearance.
inline Vec3 bisector_on_edge(Vec3 x0, Vec3 x1, Vec3 a, Vec3 b, double inside = 1e-6) {
  const Vec3 ba = b - a;
  const Vec3 d = x1 - x0;
  const double den = dot(d, ba);
  double t = 0.5;
  if (den != 0) t = dot((a + b) * 0.5 - x0, ba) / den;
  if (!(t >= inside)) t = inside;  // also NaN
  if (t > 1 - inside) t = 1 - inside;
  return x0 + d * t;
}

/// bisector_on_edge for octree edge (v0, v1) with the closest points of its ends.
inline Vec3 bisector_point(const distance::DistanceField& field, uint32_t v0, uint32_t v1) {
  if (v0 > v1) std::swap(v0, v1);
  return bisector_on_edge(field.vertices.position(v0), field.vertices.position(v1),
                          field.closest[field.point[v0]], field.closest[field.point[v1]]);
}

/// Whether Eq. (1) needs refining on edge (v0, v1) with first estimate p: the edge is longer
/// than a twentieth of the distance from p to the ends' closest points.
inline bool coarse_edge(const distance::DistanceField& field, uint32_t v0, uint32_t v1, Vec3 p) {
  constexpr double kCoarse = 0.05;
  const double h2 = dist2(field.vertices.position(v0), field.vertices.position(v1));
  const double d2 =
      std::min(dist2(p, field.closest[field.point[v0]]), dist2(p, field.closest[field.point[v1]]));
  return h2 > kCoarse * kCoarse * d2;
}

/// The root of f on [t_lo, t_hi], where f(t_lo) = f_lo and f(t_hi) = f_hi have opposite signs:
/// regula falsi with the Illinois step (the stale end's value halved when the same end moves
/// twice), at most `steps` evaluations `eval(t)`, until `done(t, f(t), t_hi - t_lo)`. Returns
/// the last point evaluated (an end where f is 0 there).
template <class Eval, class Done>
double bracketed_root(double t_lo, double f_lo, double t_hi, double f_hi, int steps, Eval&& eval,
                      Done&& done) {
  if (f_lo == 0) return t_lo;
  if (f_hi == 0) return t_hi;
  double t = 0.5 * (t_lo + t_hi);
  int side = 0;
  for (int it = 0; it < steps; ++it) {
    t = (t_lo * f_hi - t_hi * f_lo) / (f_hi - f_lo);
    if (!(t > t_lo && t < t_hi)) t = 0.5 * (t_lo + t_hi);
    const double f = eval(t);
    if (done(t, f, t_hi - t_lo)) break;
    if ((f < 0) == (f_lo < 0)) {
      t_lo = t;
      f_lo = f;
      if (side < 0) f_hi *= 0.5;
      side = -1;
    } else {
      t_hi = t;
      f_hi = f;
      if (side > 0) f_lo *= 0.5;
      side = 1;
    }
  }
  return t;
}

/// Eq. (1) with the exact closest points of the two objects at the current estimate instead
/// of the ends' ones, repeated while the point moves (by more than 1e-6 of the edge; at most
/// 64 rounds): where the closest points slide along faces it converges in a few. On an edge
/// longer than the distance to the objects (a certified pair cell across a thin gap) until
/// it moves by less than 1e-12 of the edge, and the point may come as close to the edge's
/// ends as a millionth of that distance: the exact bisector there is known to rounding, and
/// a hair of the edge would be a good part of the gap. The surfacer's edge points, and the
/// ones the unseen-region test checks. With `a`, `b`: the objects' last closest points.
inline Vec3 refine_bisector(const distance::DistanceField& field, const SimplexBvh& bvh,
                            uint32_t v0, uint32_t v1, Vec3 p, Vec3* a_out = nullptr,
                            Vec3* b_out = nullptr) {
  const Vec3 x0 = field.vertices.position(v0), x1 = field.vertices.position(v1);
  Vec3 a = field.closest[field.point[v0]], b = field.closest[field.point[v1]];
  const scene::ObjectId la = field.label[v0], lb = field.label[v1];
  const double h2 = dist2(x0, x1);
  bool long_edge = false;
  double inside = 1e-6;
  for (int round = 0; round < 64; ++round) {
    const ClosestHit ha = bvh.nearest_in_object(p, la, dist2(p, a));
    const ClosestHit hb = bvh.nearest_in_object(p, lb, dist2(p, b));
    if (!ha.found() && !hb.found()) break;  // a and b are already the closest points
    if (ha.found()) a = ha.point;
    if (hb.found()) b = hb.point;
    const double d2 = std::min(dist2(p, a), dist2(p, b));
    if (d2 < h2) {
      long_edge = true;
      inside = std::min(inside, std::max(1e-6 * std::sqrt(d2 / h2), 1e-15));
    }
    const Vec3 next = bisector_on_edge(x0, x1, a, b, inside);
    const bool moved = dist2(next, p) > (long_edge ? 1e-24 : 1e-12) * h2;
    p = next;
    if (!moved) break;
  }
  // The iteration can stall where the edge enters an object (the unsigned distance bends
  // there, at a rim or an end face inside the cell): check the point and, where it is not
  // equidistant, bracket the root of d_a - d_b on the edge instead (its ends are labelled a
  // and b, so it changes sign there; regula falsi with the Illinois step).
  {
    auto gap_at = [&](Vec3 x, Vec3& pa, Vec3& pb) {
      const ClosestHit ha = bvh.nearest_in_object(x, la, dist2(x, pa) * (1 + 1e-12) + 1e-300);
      const ClosestHit hb = bvh.nearest_in_object(x, lb, dist2(x, pb) * (1 + 1e-12) + 1e-300);
      if (ha.found()) pa = ha.point;
      if (hb.found()) pb = hb.point;
      return std::sqrt(dist2(x, pa)) - std::sqrt(dist2(x, pb));
    };
    Vec3 pa = a, pb = b;
    const double f = gap_at(p, pa, pb);
    const double scale = std::max(dist(p, pa), dist(p, pb));
    if (std::abs(f) > 1e-9 * scale + 1e-15) {
      Vec3 qa = field.closest[field.point[v0]], qb = field.closest[field.point[v1]];
      double t_lo = 0, t_hi = 1;
      double f_lo = gap_at(x0, qa, qb);
      Vec3 ra = field.closest[field.point[v0]], rb = field.closest[field.point[v1]];
      double f_hi = gap_at(x1, ra, rb);
      if (f_lo <= 0 && f_hi >= 0 && f_lo < f_hi) {
        double t = bracketed_root(
            t_lo, f_lo, t_hi, f_hi, 200,
            [&](double s) { return gap_at(x0 + (x1 - x0) * s, pa, pb); },
            [&](double s, double fs, double width) {
              const Vec3 x = x0 + (x1 - x0) * s;
              return std::abs(fs) <= 1e-12 * std::max(dist(x, pa), dist(x, pb)) || width <= 1e-15;
            });
        t = std::clamp(t, inside, 1 - inside);
        p = x0 + (x1 - x0) * t;
        a = pa;
        b = pb;
      }
    }
  }
  if (a_out != nullptr) *a_out = a;
  if (b_out != nullptr) *b_out = b;
  return p;
}

// Cyclic order of a square's boundary on the half grid, starting at the lower corner.
inline constexpr int kRing[8][2] = {{0, 0}, {1, 0}, {2, 0}, {2, 1}, {2, 2}, {1, 2}, {0, 2}, {0, 1}};

/// Calls f(const FacePolygon&) for the polygons bounding `leaf`: in 2D the cell itself (4 to 8
/// vertices); in 3D each face, or its four quarter faces when the neighbour across is finer.
template <class F>
void for_each_face_polygon(const octree::Octree& octree, const octree::LeafGrid& grid,
                           uint32_t leaf, F&& f) {
  const int dim = octree.dimension;
  if (dim == 2) {
    FacePolygon poly;
    for (const auto& r : kRing) {
      const int s = grid_index(r[0], r[1], 0);
      if (grid[s] == octree::kNoVertex) continue;
      poly.slot[poly.n] = static_cast<uint8_t>(s);
      poly.v[poly.n++] = grid[s];
    }
    f(poly);
    return;
  }
  const octree::lattice::Coord c = octree.corner(leaf);
  const uint64_t size = octree::lattice::cell_size(dim, octree.level[leaf]);
  const uint64_t limit = octree::lattice::side_units(dim);
  for (int axis = 0; axis < 3; ++axis) {
    const int au = (axis + 1) % 3, av = (axis + 2) % 3;
    for (int side = 0; side <= 2; side += 2) {
      auto slot_at = [&](int iu, int iv) {
        int l[3];
        l[axis] = side;
        l[au] = iu;
        l[av] = iv;
        return grid_index(l[0], l[1], l[2]);
      };
      auto at = [&](int iu, int iv) { return grid[slot_at(iu, iv)]; };
      const bool on_domain = side == 0 ? c.c[axis] == 0 : c.c[axis] + size == limit;
      if (at(1, 1) != octree::kNoVertex) {
        for (int qv = 0; qv <= 1; ++qv) {
          for (int qu = 0; qu <= 1; ++qu) {
            FacePolygon poly;
            poly.axis = axis;
            poly.side = side;
            poly.on_domain = on_domain;
            poly.n = 4;
            const int corner[4][2] = {{qu, qv}, {qu + 1, qv}, {qu + 1, qv + 1}, {qu, qv + 1}};
            for (int i = 0; i < 4; ++i) {
              poly.slot[i] = static_cast<uint8_t>(slot_at(corner[i][0], corner[i][1]));
              poly.v[i] = grid[poly.slot[i]];
            }
            f(poly);
          }
        }
      } else {
        FacePolygon poly;
        poly.axis = axis;
        poly.side = side;
        poly.on_domain = on_domain;
        for (const auto& r : kRing) {
          const int s = slot_at(r[0], r[1]);
          if (grid[s] == octree::kNoVertex) continue;
          poly.slot[poly.n] = static_cast<uint8_t>(s);
          poly.v[poly.n++] = grid[s];
        }
        f(poly);
      }
    }
  }
}

}  // namespace gvd::surface::detail
