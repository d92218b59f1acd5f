/* The flat simplex BVH and its nearest-simplex walk (paper §4: the exact closest point to
 * one query among all simplices), with the closest-point primitives the walk runs.
 *
 * ONE source for both sides: this file is written in the common subset of OpenCL C 1.2 and
 * C++20. It holds the only definition of the BVH's layout (GvdBvhNode, the leaf order, the
 * corner lists, GvdPoint) and of the walk (gvd_bvh_nearest: stack, pruning, tie rule).
 * SimplexBvh stores its arrays in this layout and answers nearest/nearest_if/
 * nearest_in_object/nearest_excluding by calling the walk; the CPU twin (closest_points.h)
 * runs gvd_nearest_item on a copy of those arrays; the build embeds this file in front of
 * kernels/cl/closest_points.cl (a shim around get_global_id), which reads the same arrays
 * uploaded as they are. So the CPU backend, the twin and the kernel agree bit for bit; the
 * kernel turns off FP contraction (fused multiply-add would round differently) and is never
 * built with relaxed math.
 *
 * Structs shared with the device hold no double3/size_t/bool (their size or alignment differs
 * between host and device); the host static_asserts their sizes (simplex_bvh.cpp,
 * closest_points.cpp). Include-guarded, not #pragma once, because OpenCL compilers need not
 * know the pragma. */
#ifndef GVD_GEOMETRY_CLOSEST_POINT_ITEM_H
#define GVD_GEOMETRY_CLOSEST_POINT_ITEM_H

#ifdef __OPENCL_VERSION__
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#pragma OPENCL FP_CONTRACT OFF
#define GVD_GLOBAL __global
#define GVD_ITEM_FN static inline
typedef uint gvd_uint;
#else
#include <cstdint>
#define GVD_GLOBAL
#define GVD_ITEM_FN inline
namespace gvd::item {
typedef std::uint32_t gvd_uint;
#endif

/* A point (24 bytes on host and device; double3 would be 32 on the device). */
typedef struct GvdPoint {
  double x, y, z;
} GvdPoint;

/* A BVH node: the one layout SimplexBvh stores and the device reads (56 bytes on both).
 * The box stays in doubles: float boxes rounded outward would save 24 bytes but no longer tie
 * exactly with the faces of flat parts, and the searches prune ties (across a uniform gap
 * every facing simplex ties): 10-30 % slower there. `first`: a leaf's first index into the
 * leaf ranges (`order`, or a per-object tree's item list); an inner node's right child (the
 * left child follows the node). `tag` packs the leaf's item count (low GVD_NODE_COUNT_BITS
 * bits; 0 for an inner node) and the one object of all items below (the upper bits; all ones
 * when they are mixed or unknown): gvd_node_count, gvd_node_object, gvd_node_tag. */
typedef struct GvdBvhNode {
  double lo[3];
  double hi[3];
  gvd_uint first;
  gvd_uint tag;
} GvdBvhNode;

/* Leaves hold at most 7 items; 29 bits are left for the object. */
#define GVD_NODE_COUNT_BITS 3
#define GVD_NODE_COUNT_MASK 7u
/* The object of a node whose items belong to more than one object (or whose objects are not
 * known). */
#define GVD_MIXED 0xFFFFFFFFu

/* The answer for one query: closest point, squared distance, simplex (0xFFFFFFFF = none
 * within the bound). */
typedef struct GvdHit {
  double x, y, z;
  double dist2;
  gvd_uint simplex;
  gvd_uint pad;
} GvdHit;

#define GVD_NO_SIMPLEX 0xFFFFFFFFu
/* The BVH splits at the median, so its depth is <= log2(M / 4) + 1 < 32 and a depth-first
 * walk holds at most depth + 1 entries; 64 keeps the per-work-item stack small (PoCL keeps
 * one per work-item of a work-group). */
#define GVD_BVH_STACK 64

GVD_ITEM_FN GvdPoint gvd_pt(double x, double y, double z) {
  GvdPoint r;
  r.x = x;
  r.y = y;
  r.z = z;
  return r;
}
GVD_ITEM_FN GvdPoint gvd_add(GvdPoint a, GvdPoint b) {
  return gvd_pt(a.x + b.x, a.y + b.y, a.z + b.z);
}
GVD_ITEM_FN GvdPoint gvd_sub(GvdPoint a, GvdPoint b) {
  return gvd_pt(a.x - b.x, a.y - b.y, a.z - b.z);
}
GVD_ITEM_FN GvdPoint gvd_scale(GvdPoint a, double s) { return gvd_pt(a.x * s, a.y * s, a.z * s); }
GVD_ITEM_FN double gvd_dot(GvdPoint a, GvdPoint b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
GVD_ITEM_FN GvdPoint gvd_cross(GvdPoint a, GvdPoint b) {
  return gvd_pt(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
GVD_ITEM_FN double gvd_dist2(GvdPoint a, GvdPoint b) {
  const GvdPoint d = gvd_sub(a, b);
  return gvd_dot(d, d);
}

/* A node's item count (0: inner node), its one object (GVD_MIXED when mixed) and the tag that
 * packs both (`count` <= GVD_NODE_COUNT_MASK, `object` < 2^29 or GVD_MIXED). */
GVD_ITEM_FN gvd_uint gvd_node_count(GVD_GLOBAL const GvdBvhNode* n) {
  return n->tag & GVD_NODE_COUNT_MASK;
}
GVD_ITEM_FN gvd_uint gvd_node_object(GVD_GLOBAL const GvdBvhNode* n) {
  const gvd_uint o = n->tag >> GVD_NODE_COUNT_BITS;
  return o == (GVD_MIXED >> GVD_NODE_COUNT_BITS) ? GVD_MIXED : o;
}
GVD_ITEM_FN gvd_uint gvd_node_tag(gvd_uint count, gvd_uint object) {
  return (object == GVD_MIXED ? GVD_MIXED << GVD_NODE_COUNT_BITS : object << GVD_NODE_COUNT_BITS) |
         count;
}

/* Closest point to p on the closed segment [a, b]; a degenerate segment gives a. */
GVD_ITEM_FN GvdPoint gvd_closest_on_segment(GvdPoint p, GvdPoint a, GvdPoint b) {
  const GvdPoint ab = gvd_sub(b, a);
  const double len2 = gvd_dot(ab, ab);
  if (len2 <= 0) return a;
  double t = gvd_dot(gvd_sub(p, a), ab) / len2;
  t = t < 0.0 ? 0.0 : (1.0 < t ? 1.0 : t);
  return gvd_add(a, gvd_scale(ab, t));
}

/* Closest point to p on the closed triangle (a, b, c) by the Voronoi regions of its
 * features; a degenerate triangle falls back to the nearest of its edges. */
GVD_ITEM_FN GvdPoint gvd_closest_on_triangle(GvdPoint p, GvdPoint a, GvdPoint b, GvdPoint c) {
  const GvdPoint ab = gvd_sub(b, a);
  const GvdPoint ac = gvd_sub(c, a);
  const GvdPoint n = gvd_cross(ab, ac);
  if (gvd_dot(n, n) <= 0) {
    const GvdPoint q1 = gvd_closest_on_segment(p, a, b);
    const GvdPoint q2 = gvd_closest_on_segment(p, b, c);
    const GvdPoint q3 = gvd_closest_on_segment(p, c, a);
    GvdPoint best = q1;
    if (gvd_dist2(p, q2) < gvd_dist2(p, best)) best = q2;
    if (gvd_dist2(p, q3) < gvd_dist2(p, best)) best = q3;
    return best;
  }
  const GvdPoint ap = gvd_sub(p, a);
  const double d1 = gvd_dot(ab, ap);
  const double d2 = gvd_dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const GvdPoint bp = gvd_sub(p, b);
  const double d3 = gvd_dot(ab, bp);
  const double d4 = gvd_dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return gvd_add(a, gvd_scale(ab, d1 / (d1 - d3)));
  const GvdPoint cp = gvd_sub(p, c);
  const double d5 = gvd_dot(ab, cp);
  const double d6 = gvd_dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return gvd_add(a, gvd_scale(ac, d2 / (d2 - d6)));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    return gvd_add(b, gvd_scale(gvd_sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6))));
  }
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom;
  const double w = vc * denom;
  return gvd_add(gvd_add(a, gvd_scale(ab, v)), gvd_scale(ac, w));
}

/* Squared distance from p to the node's box (0 inside). */
GVD_ITEM_FN double gvd_box_distance2(GvdPoint p, GVD_GLOBAL const GvdBvhNode* n) {
  const double q[3] = {p.x, p.y, p.z};
  double d2 = 0;
  for (int i = 0; i < 3; ++i) {
    double d = 0;
    if (q[i] < n->lo[i]) d = n->lo[i] - q[i];
    if (q[i] > n->hi[i]) d = q[i] - n->hi[i];
    d2 += d * d;
  }
  return d2;
}

/* Squared distance from p to the bounding box of the simplex with corners a, b, c (a segment
 * passes c = b). */
GVD_ITEM_FN double gvd_simplex_box_distance2(GvdPoint a, GvdPoint b, GvdPoint c, GvdPoint p) {
  const double q[3] = {p.x, p.y, p.z};
  const double pa[3] = {a.x, a.y, a.z}, pb[3] = {b.x, b.y, b.z}, pc[3] = {c.x, c.y, c.z};
  double d2 = 0;
  for (int i = 0; i < 3; ++i) {
    double lo = pa[i] < pb[i] ? pa[i] : pb[i];
    double hi = pa[i] < pb[i] ? pb[i] : pa[i];
    lo = pc[i] < lo ? pc[i] : lo;
    hi = pc[i] > hi ? pc[i] : hi;
    double d = 0;
    if (q[i] < lo) d = lo - q[i];
    if (q[i] > hi) d = q[i] - hi;
    d2 += d * d;
  }
  return d2;
}

/* Near ties: squared distances within a relative GVD_TIE of each other count as equal, and
 * the lower simplex index (the lower object: simplices are numbered object by object) wins
 * (unless the two share their closest point: gvd_better_hit_sided).
 * Points on a bisector then get the same label whatever rounding did to the two distances,
 * as if the bisector were moved by ~1e-12 of the distance toward the higher object: where a
 * GVD runs exactly along an octree plane (mirror-symmetric objects), its vertices are labelled
 * alike instead of in a rounding-noise pattern that folds the surface. */
#define GVD_TIE 4e-12

/* Whether p lies strictly behind simplex (a, b, c): on the side its normal (b - a) x (c - a)
 * points away from (3D); in 2D left of the directed segment a -> b (whose normal is
 * (dy, -dx)). For outward-oriented closed boundaries that is their inside. */
GVD_ITEM_FN int gvd_behind(int dimension, GvdPoint a, GvdPoint b, GvdPoint c, GvdPoint p) {
  const double ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z;
  const double px = p.x - a.x, py = p.y - a.y, pz = p.z - a.z;
  if (dimension == 2) return ux * py - uy * px > 0;
  const double vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z;
  const double nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
  return px * nx + py * ny + pz * nz < 0;
}

/* Whether a simplex s at squared distance d2, closest point q, beats the best hit so far
 * (see GVD_TIE). Among near ties at the same closest point (coincident faces: flush parts,
 * the shared faces of a segmentation's labels), one that has the point behind it (`behind`,
 * gvd_behind) beats one that has not, so a point inside one of two objects that share a face
 * goes to that one. Otherwise (ties between distinct points, as on a bisector) the lower
 * index wins. */
GVD_ITEM_FN int gvd_better_hit_sided(double d2, gvd_uint s, int behind, GvdPoint q,
                                     double best_dist2, gvd_uint best_simplex, int best_behind,
                                     GvdPoint best_q) {
  if (best_simplex == GVD_NO_SIMPLEX) return d2 <= best_dist2;
  if (d2 < best_dist2 * (1.0 - GVD_TIE)) return 1;
  if (!(d2 <= best_dist2 * (1.0 + GVD_TIE))) return 0;
  if (behind != best_behind && gvd_dist2(q, best_q) <= GVD_TIE * best_dist2) return behind;
  return s < best_simplex;
}

/* How far the search must still look: boxes farther than this cannot hold a better hit. */
GVD_ITEM_FN double gvd_search_limit(double best_dist2, gvd_uint best_simplex) {
  return best_simplex == GVD_NO_SIMPLEX ? best_dist2 : best_dist2 * (1.0 + GVD_TIE);
}

/* The filter of a walk: gvd_walk_accepts(filter, k) says whether the simplex at position k
 * of the leaf order may be the answer, gvd_walk_skips(filter, node) whether a whole subtree
 * holds no simplex it accepts. The device needs no filter and walks with GvdAcceptAll; the
 * C++ side passes its own filter type (a template parameter, found by argument-dependent
 * lookup: SimplexBvh::nearest_if, nearest_excluding), so a filter costs the unfiltered walk
 * nothing. */
typedef struct GvdAcceptAll {
  int unused; /* C needs a member */
} GvdAcceptAll;
GVD_ITEM_FN int gvd_walk_accepts(GvdAcceptAll filter, gvd_uint k) {
  (void)filter;
  (void)k;
  return 1;
}
GVD_ITEM_FN int gvd_walk_skips(GvdAcceptAll filter, GVD_GLOBAL const GvdBvhNode* node) {
  (void)filter;
  (void)node;
  return 0;
}

#ifdef __OPENCL_VERSION__
/* OpenCL C has no templates: the device's one filter. */
typedef GvdAcceptAll GvdWalkFilter;
#define GVD_WALK_FN GVD_ITEM_FN
#else
#define GVD_WALK_FN              \
  template <class GvdWalkFilter> \
  inline
#endif

/* The nearest-simplex walk of the flat simplex BVH (paper §4), the one definition behind
 * SimplexBvh::nearest* and the closest-point kernel. Takes the tree `nodes[0 .. node_count)`
 * walked from `root`; its leaf ranges index `items` (positions in the leaf order), or are
 * those positions themselves when `items` is null; the simplex at position k has the
 * `dimension` corners points[corner[dimension * k + j]] (2D: a segment, 3D: a triangle) and
 * the index order[k]. Gives the exact closest point to p among the simplices `filter` accepts
 * whose squared distance is <= max_dist2; simplex = GVD_NO_SIMPLEX when there is none. Near
 * ties go to the lower simplex index (GVD_TIE), except between coincident faces
 * (gvd_better_hit_sided). Nearer child first; a subtree is skipped when its box is farther
 * than the best hit so far (gvd_search_limit). O(log M) typical, O(M) worst case; no
 * allocation (a fixed stack of GVD_BVH_STACK entries). */
GVD_WALK_FN GvdHit gvd_bvh_nearest(int dimension, gvd_uint node_count,
                                   GVD_GLOBAL const GvdBvhNode* nodes, gvd_uint root,
                                   GVD_GLOBAL const gvd_uint* items,
                                   GVD_GLOBAL const gvd_uint* order,
                                   GVD_GLOBAL const gvd_uint* corner,
                                   GVD_GLOBAL const GvdPoint* points, GvdPoint p, double max_dist2,
                                   GvdWalkFilter filter) {
  GvdHit best;
  best.x = 0;
  best.y = 0;
  best.z = 0;
  best.dist2 = max_dist2;
  best.simplex = GVD_NO_SIMPLEX;
  best.pad = 0;
  int best_behind = 0; /* whether p is behind best's simplex (gvd_better_hit_sided) */
  if (node_count == 0 || gvd_walk_skips(filter, nodes + root) ||
      gvd_box_distance2(p, nodes + root) > best.dist2) {
    return best;
  }
  /* Each entry carries its box distance, computed once when the parent was visited. */
  gvd_uint stack_node[GVD_BVH_STACK];
  double stack_dist2[GVD_BVH_STACK];
  int top = 0;
  stack_node[top] = root;
  stack_dist2[top] = 0.0;
  ++top;
  while (top > 0) {
    --top;
    const gvd_uint node = stack_node[top];
    if (stack_dist2[top] > gvd_search_limit(best.dist2, best.simplex)) continue;
    GVD_GLOBAL const GvdBvhNode* n = nodes + node;
    const gvd_uint count = gvd_node_count(n);
    if (count > 0) {
      for (gvd_uint i = n->first; i < n->first + count; ++i) {
        const gvd_uint k = items != 0 ? items[i] : i;
        if (!gvd_walk_accepts(filter, k)) continue;
        GVD_GLOBAL const gvd_uint* v = corner + (gvd_uint)dimension * k;
        const GvdPoint a = points[v[0]];
        const GvdPoint b = points[v[1]];
        const GvdPoint c = points[v[dimension - 1]];
        /* The simplex's own box first: farther than the search limit (with a margin far
         * above rounding), it cannot be accepted, and the exact test is skipped. */
        if (gvd_simplex_box_distance2(a, b, c, p) >
            gvd_search_limit(best.dist2, best.simplex) * (1.0 + 1e-9)) {
          continue;
        }
        const gvd_uint s = order[k];
        const GvdPoint q =
            dimension == 2 ? gvd_closest_on_segment(p, a, b) : gvd_closest_on_triangle(p, a, b, c);
        const double d2 = gvd_dist2(p, q);
        const int behind = gvd_behind(dimension, a, b, c, p);
        if (gvd_better_hit_sided(d2, s, behind, q, best.dist2, best.simplex, best_behind,
                                 gvd_pt(best.x, best.y, best.z))) {
          best.x = q.x;
          best.y = q.y;
          best.z = q.z;
          best.dist2 = d2;
          best.simplex = s;
          best_behind = behind;
        }
      }
      continue;
    }
    const gvd_uint l = node + 1, r = n->first;
    /* A skipped subtree is farther than any limit. */
    const double dl = gvd_walk_skips(filter, nodes + l) ? 1e308 : gvd_box_distance2(p, nodes + l);
    const double dr = gvd_walk_skips(filter, nodes + r) ? 1e308 : gvd_box_distance2(p, nodes + r);
    const double limit = gvd_search_limit(best.dist2, best.simplex);
    /* Push the farther child first so the nearer one is searched first. */
    if (dl <= dr) {
      if (dr <= limit) {
        stack_node[top] = r;
        stack_dist2[top] = dr;
        ++top;
      }
      if (dl <= limit) {
        stack_node[top] = l;
        stack_dist2[top] = dl;
        ++top;
      }
    } else {
      if (dl <= limit) {
        stack_node[top] = l;
        stack_dist2[top] = dl;
        ++top;
      }
      if (dr <= limit) {
        stack_node[top] = r;
        stack_dist2[top] = dr;
        ++top;
      }
    }
  }
  return best;
}

/* The closest-point kernel's item: gvd_bvh_nearest over the whole tree (root 0, leaf ranges
 * are positions in the leaf order), every simplex a candidate. */
GVD_ITEM_FN GvdHit gvd_nearest_item(int dimension, gvd_uint node_count,
                                    GVD_GLOBAL const GvdBvhNode* nodes,
                                    GVD_GLOBAL const gvd_uint* order,
                                    GVD_GLOBAL const gvd_uint* corner,
                                    GVD_GLOBAL const GvdPoint* points, GvdPoint p,
                                    double max_dist2) {
  GvdAcceptAll all;
  all.unused = 0;
  return gvd_bvh_nearest(dimension, node_count, nodes, 0, 0, order, corner, points, p, max_dist2,
                         all);
}

#ifndef __OPENCL_VERSION__
}  // namespace gvd::item
#endif

#endif /* GVD_GEOMETRY_CLOSEST_POINT_ITEM_H */
