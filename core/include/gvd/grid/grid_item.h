/* The per-item function of the uniform-grid discrete GVD (Sud et al. 2006, "CuRV", §5): the
 * distances from one grid cell centre to the candidate sites of its range (the potentially
 * intersecting swept set of the range), the cell's running minimum (distance, site), and the
 * range's visibility flags (paper §5: "check D_T(p) for visibility", with the conservative
 * sampling of §5.3).
 *
 * ONE source for both sides, as closest_point_item.h: written in the common subset of OpenCL
 * C 1.2 and C++20, included by the CPU twin (core/src/grid/grid_evaluator.cpp) and embedded
 * after closest_point_item.h in front of kernels/cl/grid_distance.cl. The kernel is built
 * without FP contraction or relaxed math, so twin and kernel agree bit for bit.
 *
 * Sites are the scene's objects, each with a BVH of its own simplices (segments in 2D,
 * triangles in 3D); a cell's label is its nearest object. Distances are kept as "keys": the squared
 * distance for L2 (no sqrt in the kernel), the distance itself for L1 and L-infinity; keys order
 * like distances. */
#ifndef GVD_GRID_GRID_ITEM_H
#define GVD_GRID_GRID_ITEM_H

#ifdef __OPENCL_VERSION__
#define GVD_GRID_SET_FLAG(p) (*(p) = 1)
#define GVD_GRID_FLAG(p) (*(p))
#else
#include <cmath>

#include "gvd/geometry/closest_point_item.h"
/* Several work items may raise one flag: relaxed atomics on the host (no data race). */
#define GVD_GRID_SET_FLAG(p) __atomic_store_n((p), 1, __ATOMIC_RELAXED)
#define GVD_GRID_FLAG(p) __atomic_load_n((p), __ATOMIC_RELAXED)
namespace gvd::item {
#endif

#define GVD_METRIC_L2 0
#define GVD_METRIC_L1 1
#define GVD_METRIC_LINF 2
/* Keys of a cell kept in private memory (the rest go through the batch's dist buffer). */
#define GVD_GRID_LOCAL 64
/* "Farther than the bound": the key of an object no nearer than the bound (+infinity would
 * do, but OpenCL C 1.2 and C++ spell it differently). */
#define GVD_GRID_FAR 1e300

/* The grid: cell (i, j, k) has its centre at origin + (i + 0.5, j + 0.5, k + 0.5) * h; cells
 * are stored x fastest. `threshold` is the conservative-sampling slack of §5.3 (the metric
 * length of one cell diagonal, a little enlarged for rounding). 64 bytes on host and device. */
typedef struct GvdGridSpec {
  double origin[3];
  double h;
  double threshold;
  int n[3];
  int dimension;
  int metric;
  int pad;
} GvdGridSpec;

/* One range of a batch: its cells [lo, lo + size), its candidate sites
 * sites[site_first .. site_first + site_count), the first work item of its rows (items of a
 * batch are numbered range after range, one per row of cells along x) and the first entry of
 * its site x cell distance block (site-major). 40 bytes. */
typedef struct GvdGridJob {
  int lo[3];
  int size[3];
  gvd_uint site_first;
  gvd_uint site_count;
  gvd_uint item_first;
  gvd_uint dist_first;
} GvdGridJob;

GVD_ITEM_FN double gvd_abs(double x) { return x < 0 ? -x : x; }

/* The metric norm of v (L1, L-infinity; L2 squared: a key). */
GVD_ITEM_FN double gvd_metric_key(GvdPoint v, int metric) {
  if (metric == GVD_METRIC_L1) return gvd_abs(v.x) + gvd_abs(v.y) + gvd_abs(v.z);
  if (metric == GVD_METRIC_LINF) {
    double m = gvd_abs(v.x);
    if (gvd_abs(v.y) > m) m = gvd_abs(v.y);
    if (gvd_abs(v.z) > m) m = gvd_abs(v.z);
    return m;
  }
  return gvd_dot(v, v);
}

GVD_ITEM_FN double gvd_coord(GvdPoint p, int i) { return i == 0 ? p.x : (i == 1 ? p.y : p.z); }

/* The L1 / L-infinity distance from p to the closed segment [a, b]: f(t) = |c - t d| with
 * c = p - a, d = b - a is convex and piecewise linear in t, so its minimum over [0, 1] lies
 * at an end or where a piece changes: c_i - t d_i = 0 (L1, L-infinity), or
 * c_i - t d_i = +-(c_j - t d_j) (L-infinity). Every candidate is evaluated; exact up to
 * rounding. */
GVD_ITEM_FN double gvd_segment_metric(GvdPoint p, GvdPoint a, GvdPoint b, int metric) {
  const GvdPoint c = gvd_sub(p, a);
  const GvdPoint d = gvd_sub(b, a);
  double best = gvd_metric_key(c, metric);
  const double at1 = gvd_metric_key(gvd_sub(c, d), metric);
  if (at1 < best) best = at1;
  for (int i = 0; i < 3; ++i) {
    const double ci = gvd_coord(c, i), di = gvd_coord(d, i);
    if (di != 0) {
      const double t = ci / di;
      if (t > 0 && t < 1) {
        const double f = gvd_metric_key(gvd_sub(c, gvd_scale(d, t)), metric);
        if (f < best) best = f;
      }
    }
    if (metric != GVD_METRIC_LINF) continue;
    for (int j = i + 1; j < 3; ++j) {
      const double cj = gvd_coord(c, j), dj = gvd_coord(d, j);
      for (int s = -1; s <= 1; s += 2) {
        const double den = di - s * dj;
        if (den == 0) continue;
        const double t = (ci - s * cj) / den;
        if (t > 0 && t < 1) {
          const double f = gvd_metric_key(gvd_sub(c, gvd_scale(d, t)), metric);
          if (f < best) best = f;
        }
      }
    }
  }
  return best;
}

/* The L1 / L-infinity distance from p to the closed triangle (a, b, c). With
 * g(u, v) = (p - a) - u (b - a) - v (c - a), f = |g| is convex and piecewise linear over the
 * parameter triangle u, v >= 0, u + v <= 1; its pieces change on the lines g_i = 0 (and
 * g_i = +-g_j for L-infinity). The minimum is on the triangle's edges (segment case, exact)
 * or at a crossing of two such lines inside it; every crossing is evaluated (clamped into the
 * triangle, so no value is below the true distance). */
GVD_ITEM_FN double gvd_triangle_metric(GvdPoint p, GvdPoint a, GvdPoint b, GvdPoint c, int metric) {
  double best = gvd_segment_metric(p, a, b, metric);
  double f = gvd_segment_metric(p, b, c, metric);
  if (f < best) best = f;
  f = gvd_segment_metric(p, c, a, metric);
  if (f < best) best = f;
  const GvdPoint q = gvd_sub(p, a);
  const GvdPoint e1 = gvd_sub(b, a);
  const GvdPoint e2 = gvd_sub(c, a);
  /* Lines alpha u + beta v = gamma: g_i = 0, then g_i = g_j, g_i = -g_j. */
  double la[9], lb[9], lg[9];
  int lines = 0;
  for (int i = 0; i < 3; ++i) {
    la[lines] = gvd_coord(e1, i);
    lb[lines] = gvd_coord(e2, i);
    lg[lines] = gvd_coord(q, i);
    ++lines;
  }
  if (metric == GVD_METRIC_LINF) {
    for (int i = 0; i < 3; ++i) {
      for (int j = i + 1; j < 3; ++j) {
        for (int s = -1; s <= 1; s += 2) {
          la[lines] = gvd_coord(e1, i) - s * gvd_coord(e1, j);
          lb[lines] = gvd_coord(e2, i) - s * gvd_coord(e2, j);
          lg[lines] = gvd_coord(q, i) - s * gvd_coord(q, j);
          ++lines;
        }
      }
    }
  }
  for (int i = 0; i < lines; ++i) {
    for (int j = i + 1; j < lines; ++j) {
      const double det = la[i] * lb[j] - la[j] * lb[i];
      if (det == 0) continue;
      double u = (lg[i] * lb[j] - lg[j] * lb[i]) / det;
      double v = (la[i] * lg[j] - la[j] * lg[i]) / det;
      if (u < -1e-9 || v < -1e-9 || u + v > 1 + 1e-9) continue;
      if (u < 0) u = 0;
      if (v < 0) v = 0;
      if (u + v > 1) {
        const double s = u + v;
        u = u / s;
        v = v / s;
      }
      f = gvd_metric_key(gvd_sub(gvd_sub(q, gvd_scale(e1, u)), gvd_scale(e2, v)), metric);
      if (f < best) best = f;
    }
  }
  return best;
}

/* The key (see the file comment) from p to simplex s. */
GVD_ITEM_FN double gvd_grid_site_key(int dimension, int metric, GVD_GLOBAL const GvdPoint* points,
                                     GVD_GLOBAL const gvd_uint* simplices, gvd_uint s, GvdPoint p) {
  const GvdPoint a = points[simplices[3 * s]];
  const GvdPoint b = points[simplices[3 * s + 1]];
  if (metric == GVD_METRIC_L2) {
    if (dimension == 2) return gvd_dist2(p, gvd_closest_on_segment(p, a, b));
    return gvd_dist2(p, gvd_closest_on_triangle(p, a, b, points[simplices[3 * s + 2]]));
  }
  if (dimension == 2) return gvd_segment_metric(p, a, b, metric);
  return gvd_triangle_metric(p, a, b, points[simplices[3 * s + 2]], metric);
}

/* The distance a key stands for: its square root for L2. */
GVD_ITEM_FN double gvd_key_distance(double key, int metric) {
#ifdef __OPENCL_VERSION__
  return metric == GVD_METRIC_L2 ? sqrt(key) : key;
#else
  return metric == GVD_METRIC_L2 ? std::sqrt(key) : key;
#endif
}

/* The key of the metric distance from p to a box (0 inside): a lower bound of the key of
 * anything in it. */
GVD_ITEM_FN double gvd_box_key(GvdPoint p, GVD_GLOBAL const GvdBvhNode* n, int metric) {
  const double q[3] = {p.x, p.y, p.z};
  double g[3];
  for (int i = 0; i < 3; ++i) {
    double d = 0;
    if (q[i] < n->lo[i]) d = n->lo[i] - q[i];
    if (q[i] > n->hi[i]) d = q[i] - n->hi[i];
    g[i] = d;
  }
  return gvd_metric_key(gvd_pt(g[0], g[1], g[2]), metric);
}

/* The key from p to object `site`: the least key over its simplices, by a depth-first walk
 * of the object's own BVH (root node roots[site]; inner nodes: left child next, right child
 * at `first`; leaves: order[first .. first + count) are simplex indices). Only keys <= bound
 * count: returns GVD_GRID_FAR (> bound) when the object is farther, pruning every box beyond
 * the bound or the best key so far. Exact up to rounding otherwise. */
GVD_ITEM_FN double gvd_grid_object_key(
    int dimension, int metric, GVD_GLOBAL const GvdBvhNode* nodes, GVD_GLOBAL const gvd_uint* order,
    GVD_GLOBAL const gvd_uint* roots, GVD_GLOBAL const GvdPoint* points,
    GVD_GLOBAL const gvd_uint* simplices, gvd_uint site, GvdPoint p, double bound) {
  double best = GVD_GRID_FAR;
  gvd_uint stack[GVD_BVH_STACK];
  int top = 0;
  stack[top++] = roots[site];
  while (top > 0) {
    const gvd_uint node = stack[--top];
    GVD_GLOBAL const GvdBvhNode* n = nodes + node;
    const double limit = best < bound ? best : bound;
    if (gvd_box_key(p, n, metric) > limit) continue;
    const gvd_uint count = gvd_node_count(n);
    if (count > 0) {
      for (gvd_uint k = n->first; k < n->first + count; ++k) {
        /* The simplex's own box first (a lower bound, like the node's). */
        const gvd_uint s = order[k];
        const GvdPoint a = points[simplices[3 * s]], b = points[simplices[3 * s + 1]],
                       c = points[simplices[3 * s + 2]];
        double g[3];
        const double q[3] = {p.x, p.y, p.z};
        const double pa[3] = {a.x, a.y, a.z}, pb[3] = {b.x, b.y, b.z}, pc[3] = {c.x, c.y, c.z};
        for (int i = 0; i < 3; ++i) {
          double lo = pa[i] < pb[i] ? pa[i] : pb[i];
          double hi = pa[i] < pb[i] ? pb[i] : pa[i];
          lo = pc[i] < lo ? pc[i] : lo;
          hi = pc[i] > hi ? pc[i] : hi;
          g[i] = q[i] < lo ? lo - q[i] : (q[i] > hi ? q[i] - hi : 0.0);
        }
        const double lim = best < bound ? best : bound;
        if (gvd_metric_key(gvd_pt(g[0], g[1], g[2]), metric) > lim) continue;
        const double key = gvd_grid_site_key(dimension, metric, points, simplices, s, p);
        if (key <= bound && key < best) best = key;
      }
      continue;
    }
    const gvd_uint l = node + 1, r = n->first;
    /* The nearer child is searched first (pushed last). */
    if (gvd_box_key(p, nodes + l, metric) <= gvd_box_key(p, nodes + r, metric)) {
      stack[top++] = r;
      stack[top++] = l;
    } else {
      stack[top++] = l;
      stack[top++] = r;
    }
  }
  return best;
}

/* Whether site s at key k beats the cell's best (best_key, best_site): smaller key, or an
 * exact tie and the lower site (object) index. Exact ties only: the order of evaluation must
 * not change the answer. */
GVD_ITEM_FN int gvd_grid_better(double k, gvd_uint s, double best_key, gvd_uint best_site) {
  return k < best_key || (k == best_key && s < best_site);
}

/* Work item `item` of a batch of `job_count` ranges stands for one row of cells (along x) of
 * one range: for each cell, its keys to the range's sites (the first GVD_GRID_LOCAL in
 * private memory, the rest in dist, site-major within the range's block), the cell's running
 * best (best_key / best_site, for the whole grid, read and written here only) and, once that
 * best is final for this batch, the range's visibility flags: visible[site_first + k] is set
 * when site k's distance at the cell is within spec->threshold of the best distance (the
 * site's Voronoi region, grown by one cell diagonal, reaches the cell; §5.3). Items of a
 * batch are numbered range after range, sy * sz rows each. */
GVD_ITEM_FN void gvd_grid_item(GVD_GLOBAL const GvdGridSpec* spec,
                               GVD_GLOBAL const GvdBvhNode* nodes, GVD_GLOBAL const gvd_uint* order,
                               GVD_GLOBAL const gvd_uint* roots, GVD_GLOBAL const GvdPoint* points,
                               GVD_GLOBAL const gvd_uint* simplices,
                               GVD_GLOBAL const GvdGridJob* jobs, gvd_uint job_count,
                               GVD_GLOBAL const gvd_uint* sites, gvd_uint item,
                               GVD_GLOBAL double* best_key, GVD_GLOBAL gvd_uint* best_site,
                               GVD_GLOBAL double* dist, GVD_GLOBAL int* visible) {
  /* The range of this item: the last job whose item_first <= item. */
  gvd_uint lo = 0, hi = job_count;
  while (hi - lo > 1) {
    const gvd_uint mid = (lo + hi) / 2;
    if (jobs[mid].item_first <= item)
      lo = mid;
    else
      hi = mid;
  }
  GVD_GLOBAL const GvdGridJob* job = jobs + lo;
  const gvd_uint row = item - job->item_first;
  const gvd_uint sx = (gvd_uint)job->size[0], sy = (gvd_uint)job->size[1];
  const gvd_uint cells = sx * sy * (gvd_uint)job->size[2];
  const int iy = job->lo[1] + (int)(row % sy);
  const int iz = job->lo[2] + (int)(row / sy);
  const double py = spec->origin[1] + (iy + 0.5) * spec->h;
  const double pz = spec->dimension == 2 ? 0.0 : spec->origin[2] + (iz + 0.5) * spec->h;
  const gvd_uint row_cell =
      ((gvd_uint)iz * (gvd_uint)spec->n[1] + (gvd_uint)iy) * (gvd_uint)spec->n[0];
  /* Keys of one cell kept in private memory; longer lists spill to dist. */
  double keys[GVD_GRID_LOCAL];
  gvd_uint hint = 0, next_hint = 0;
  for (gvd_uint c = 0; c < sx; ++c) {
    const int ix = job->lo[0] + (int)c;
    const gvd_uint cell = row_cell + (gvd_uint)ix;
    const gvd_uint at = row * sx + c; /* cell within the range ("local" is reserved in OpenCL C) */
    const GvdPoint p = gvd_pt(spec->origin[0] + (ix + 0.5) * spec->h, py, pz);
    double bk = best_key[cell];
    gvd_uint bs = best_site[cell];
    for (gvd_uint j = 0; j < job->site_count; ++j) {
      /* Start with the site nearest to the previous cell of the row: its distance bounds the
       * other walks early. The answer does not depend on the order (exact minimum, ties by
       * index; a walk is cut only where the site can be neither nearest nor visible). */
      gvd_uint k = hint + j;
      if (k >= job->site_count) k -= job->site_count;
      const gvd_uint s = sites[job->site_first + k];
      /* Farther than the best so far plus the threshold: neither better nor visible (the
       * final best is no larger), so the walk may stop there. */
      double bound = gvd_key_distance(bk, spec->metric) + spec->threshold;
      if (spec->metric == GVD_METRIC_L2) bound = bound * bound;
      const double key = gvd_grid_object_key(spec->dimension, spec->metric, nodes, order, roots,
                                             points, simplices, s, p, bound);
      if (k < GVD_GRID_LOCAL)
        keys[k] = key;
      else
        dist[job->dist_first + k * cells + at] = key;
      if (gvd_grid_better(key, s, bk, bs)) {
        bk = key;
        bs = s;
        next_hint = k;
      }
    }
    hint = next_hint;
    best_key[cell] = bk;
    best_site[cell] = bs;
    /* Visibility: distance <= best distance + threshold, compared as keys. */
    double limit = gvd_key_distance(bk, spec->metric) + spec->threshold;
    if (spec->metric == GVD_METRIC_L2) limit = limit * limit;
    for (gvd_uint k = 0; k < job->site_count; ++k) {
      GVD_GLOBAL int* flag = visible + job->site_first + k;
      const double key = k < GVD_GRID_LOCAL ? keys[k] : dist[job->dist_first + k * cells + at];
      if (key <= limit && GVD_GRID_FLAG(flag) == 0) GVD_GRID_SET_FLAG(flag);
    }
  }
}

#ifndef __OPENCL_VERSION__
}  // namespace gvd::item
#endif

#endif /* GVD_GRID_GRID_ITEM_H */
