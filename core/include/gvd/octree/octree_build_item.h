/* Per-item functions of the data-parallel octree build (parallel-quadtree-construction
 * draft §3.2-3.5, after Karras 2012): Morton codes of object vertices, the binary radix tree
 * over them, the smallest containing cell (SCC) of a simplex, and the conservative
 * simplex/cell overlap test. ONE source for the CPU twins (build_octree_data_parallel.cpp) and the
 * OpenCL kernels (kernels/cl/octree_build.cl): written in the common subset of OpenCL C 1.2
 * and C++20. The overlap tests transcribe triangle_overlaps_box / segment_overlaps_box_2d of
 * primitives.cpp in the same operation order, so the data-parallel build sees exactly the
 * cell contents the level-synchronous build sees. */
#ifndef GVD_OCTREE_OCTREE_BUILD_ITEM_H
#define GVD_OCTREE_OCTREE_BUILD_ITEM_H

#ifndef __OPENCL_VERSION__ /* the kernel source embeds closest_point_item.h before this file */
#include "gvd/geometry/closest_point_item.h"
#endif

#ifdef __OPENCL_VERSION__
typedef ulong gvd_u64;
#define GVD_CLZ64(x) ((int)clz(x))
#define GVD_FABS(x) fabs(x)
#else
#include <bit>
#include <cmath>
namespace gvd::item {
typedef std::uint64_t gvd_u64;
#define GVD_CLZ64(x) (std::countl_zero(static_cast<std::uint64_t>(x)))
#define GVD_FABS(x) std::fabs(x)
#endif

/* Lattice bits per axis: 31 in 2D, 21 in 3D (lattice.h). */
GVD_ITEM_FN int gvd_lattice_bits(int dim) { return dim == 2 ? 31 : 21; }

GVD_ITEM_FN gvd_u64 gvd_spread2(gvd_u64 x) {
  x &= 0xffffffffUL;
  x = (x | (x << 16)) & 0x0000ffff0000ffffUL;
  x = (x | (x << 8)) & 0x00ff00ff00ff00ffUL;
  x = (x | (x << 4)) & 0x0f0f0f0f0f0f0f0fUL;
  x = (x | (x << 2)) & 0x3333333333333333UL;
  x = (x | (x << 1)) & 0x5555555555555555UL;
  return x;
}
GVD_ITEM_FN gvd_u64 gvd_spread3(gvd_u64 x) {
  x &= 0x1fffffUL;
  x = (x | (x << 32)) & 0x001f00000000ffffUL;
  x = (x | (x << 16)) & 0x001f0000ff0000ffUL;
  x = (x | (x << 8)) & 0x100f00f00f00f00fUL;
  x = (x | (x << 4)) & 0x10c30c30c30c30c3UL;
  x = (x | (x << 2)) & 0x1249249249249249UL;
  return x;
}

/* Lattice coordinate of the finest cell containing unit coordinate u (clamped), as
 * lattice::from_unit. */
GVD_ITEM_FN gvd_u64 gvd_lattice_coord(int dim, double u) {
  const double n = (double)((gvd_u64)1 << gvd_lattice_bits(dim));
  double v = u * n;
  if (!(v >= 0)) v = 0;
  if (v > n - 1) v = n - 1;
  return (gvd_u64)v;
}

/* Morton code (x bit first) of the finest lattice cell containing unit point p. */
GVD_ITEM_FN gvd_u64 gvd_point_code(int dim, GvdPoint p) {
  if (dim == 2)
    return gvd_spread2(gvd_lattice_coord(2, p.x)) | (gvd_spread2(gvd_lattice_coord(2, p.y)) << 1);
  return gvd_spread3(gvd_lattice_coord(3, p.x)) | (gvd_spread3(gvd_lattice_coord(3, p.y)) << 1) |
         (gvd_spread3(gvd_lattice_coord(3, p.z)) << 2);
}

/* The code truncated to the cell of `level` containing it (lower corner). */
GVD_ITEM_FN gvd_u64 gvd_truncate(int dim, gvd_u64 code, int level) {
  const int shift = dim * (gvd_lattice_bits(dim) - level);
  return shift >= 64 ? (gvd_u64)0 : (code >> shift) << shift;
}

/* Karras' delta: length of the common prefix of keys i and j (keys are unique, `bits` long),
 * -1 when j is outside [0, n). */
GVD_ITEM_FN int gvd_delta(GVD_GLOBAL const gvd_u64* keys, int n, int bits, int i, int j) {
  if (j < 0 || j >= n) return -1;
  return GVD_CLZ64(keys[i] ^ keys[j]) - (64 - bits);
}

/* One internal node i (0 <= i < n-1) of the binary radix tree over n >= 2 sorted unique keys
 * (Karras 2012, Fig. 4): its key range [first, last], split, and prefix length. Children
 * are internal nodes split / split+1 unless a range of one key (then a leaf). */
typedef struct GvdRadixNode {
  int first, last, split, prefix;
  int pad0, pad1; /* 24 bytes on both sides */
} GvdRadixNode;

GVD_ITEM_FN GvdRadixNode gvd_radix_node(GVD_GLOBAL const gvd_u64* keys, int n, int bits, int i) {
  const int d =
      gvd_delta(keys, n, bits, i, i + 1) - gvd_delta(keys, n, bits, i, i - 1) >= 0 ? 1 : -1;
  const int dmin = gvd_delta(keys, n, bits, i, i - d);
  int lmax = 2;
  while (gvd_delta(keys, n, bits, i, i + lmax * d) > dmin) lmax *= 2;
  int l = 0;
  for (int t = lmax / 2; t >= 1; t /= 2)
    if (gvd_delta(keys, n, bits, i, i + (l + t) * d) > dmin) l += t;
  const int j = i + l * d;
  const int dnode = gvd_delta(keys, n, bits, i, j);
  int s = 0;
  int t = l;
  do {
    t = (t + 1) / 2;
    if (gvd_delta(keys, n, bits, i, i + (s + t) * d) > dnode) s += t;
  } while (t > 1);
  GvdRadixNode node;
  node.first = d > 0 ? i : j;
  node.last = d > 0 ? j : i;
  node.split = i + s * d + (d < 0 ? -1 : 0);
  node.prefix = dnode;
  node.pad0 = 0;
  node.pad1 = 0;
  return node;
}

/* Octree cells (levels) an internal radix node contributes: the cells along its prefix from
 * just below its parent's deepest full level to its own, clamped to max_level. */
GVD_ITEM_FN int gvd_radix_cell_first_level(int dim, int parent_prefix) {
  return parent_prefix < 0 ? 0 : parent_prefix / dim + 1;
}
GVD_ITEM_FN int gvd_radix_cell_last_level(int dim, int prefix, int max_level) {
  const int l = prefix / dim;
  return l < max_level ? l : max_level;
}

/* The bounding box of simplex s inflated by `slack` on every side. */
GVD_ITEM_FN void gvd_facet_box(int dim, GVD_GLOBAL const GvdPoint* points,
                               GVD_GLOBAL const gvd_uint* simplices, gvd_uint s, double slack,
                               GvdPoint* lo_out, GvdPoint* hi_out) {
  GvdPoint lo = points[simplices[3 * s]];
  GvdPoint hi = lo;
  for (int k = 1; k < (dim == 2 ? 2 : 3); ++k) {
    const GvdPoint p = points[simplices[3 * s + k]];
    lo.x = p.x < lo.x ? p.x : lo.x;
    lo.y = p.y < lo.y ? p.y : lo.y;
    lo.z = p.z < lo.z ? p.z : lo.z;
    hi.x = p.x > hi.x ? p.x : hi.x;
    hi.y = p.y > hi.y ? p.y : hi.y;
    hi.z = p.z > hi.z ? p.z : hi.z;
  }
  *lo_out = gvd_pt(lo.x - slack, lo.y - slack, lo.z - slack);
  *hi_out = gvd_pt(hi.x + slack, hi.y + slack, hi.z + slack);
}

/* The smallest containing cell of a simplex (draft §3.5, container(f)): the longest common
 * prefix of the Morton codes of the corners of its bounding box, inflated by the largest
 * overlap slack so that every cell the overlap test can accept lies inside it, truncated to
 * whole levels and to max_level. Returns the level; *code = the cell's lower-corner code. */
GVD_ITEM_FN int gvd_scc(int dim, GVD_GLOBAL const GvdPoint* points,
                        GVD_GLOBAL const gvd_uint* simplices, gvd_uint s, double slack,
                        int max_level, gvd_u64* code) {
  GvdPoint lo, hi;
  gvd_facet_box(dim, points, simplices, s, slack, &lo, &hi);
  const gvd_u64 a = gvd_point_code(dim, lo);
  const gvd_u64 b = gvd_point_code(dim, hi);
  const int bits = dim * gvd_lattice_bits(dim);
  const int lcp = a == b ? bits : GVD_CLZ64(a ^ b) - (64 - bits);
  int level = lcp / dim;
  if (level > max_level) level = max_level;
  *code = gvd_truncate(dim, a, level);
  return level;
}

/* The cells simplex s is stored in for conflict detection. The draft stores a facet in its
 * smallest containing cell only; a small facet that straddles a coarse boundary (the mid-
 * planes of the domain cut thousands of them) then sits in a cell near the root, and every
 * leaf below tests it. Here such a facet goes instead to the cells it overlaps on the deepest
 * level whose cells are at least as large as its (inflated) bounding box: at most 2^D cells,
 * each a descendant of the SCC; a facet already fitting that level keeps its SCC. Every leaf
 * the facet touches lies inside one of the returned cells (or contains one, see the clamp in
 * build_octree_data_parallel). Writes the cells when out_code is non-null; returns how many. */
GVD_ITEM_FN int gvd_facet_cells(int dim, GVD_GLOBAL const GvdPoint* points,
                                GVD_GLOBAL const gvd_uint* simplices, gvd_uint s, double slack,
                                int max_level, GVD_GLOBAL gvd_u64* out_code,
                                GVD_GLOBAL int* out_level) {
  gvd_u64 scc = 0;
  const int scc_level = gvd_scc(dim, points, simplices, s, slack, max_level, &scc);
  GvdPoint lo, hi;
  gvd_facet_box(dim, points, simplices, s, slack, &lo, &hi);
  double ext = hi.x - lo.x;
  if (hi.y - lo.y > ext) ext = hi.y - lo.y;
  if (dim == 3 && hi.z - lo.z > ext) ext = hi.z - lo.z;
  int level = scc_level;
  while (level < max_level && 1.0 / (double)((gvd_u64)1 << (level + 1)) >= ext) ++level;
  if (level == scc_level) {
    if (out_code) {
      out_code[0] = scc;
      out_level[0] = scc_level;
    }
    return 1;
  }
  const int shift = gvd_lattice_bits(dim) - level;
  const gvd_u64 x0 = gvd_lattice_coord(dim, lo.x) >> shift,
                x1 = gvd_lattice_coord(dim, hi.x) >> shift;
  const gvd_u64 y0 = gvd_lattice_coord(dim, lo.y) >> shift,
                y1 = gvd_lattice_coord(dim, hi.y) >> shift;
  gvd_u64 z0 = 0, z1 = 0;
  if (dim == 3) {
    z0 = gvd_lattice_coord(dim, lo.z) >> shift;
    z1 = gvd_lattice_coord(dim, hi.z) >> shift;
  }
  int n = 0;
  for (gvd_u64 z = z0; z <= z1; ++z)
    for (gvd_u64 y = y0; y <= y1; ++y)
      for (gvd_u64 x = x0; x <= x1; ++x) {
        if (out_code) {
          const gvd_u64 code = dim == 2 ? gvd_spread2(x << shift) | (gvd_spread2(y << shift) << 1)
                                        : gvd_spread3(x << shift) | (gvd_spread3(y << shift) << 1) |
                                              (gvd_spread3(z << shift) << 2);
          out_code[n] = code;
          out_level[n] = level;
        }
        ++n;
      }
  return n;
}

GVD_ITEM_FN gvd_u64 gvd_compact2(gvd_u64 x) {
  x &= 0x5555555555555555UL;
  x = (x | (x >> 1)) & 0x3333333333333333UL;
  x = (x | (x >> 2)) & 0x0f0f0f0f0f0f0f0fUL;
  x = (x | (x >> 4)) & 0x00ff00ff00ff00ffUL;
  x = (x | (x >> 8)) & 0x0000ffff0000ffffUL;
  x = (x | (x >> 16)) & 0x00000000ffffffffUL;
  return x;
}
GVD_ITEM_FN gvd_u64 gvd_compact3(gvd_u64 x) {
  x &= 0x1249249249249249UL;
  x = (x | (x >> 2)) & 0x10c30c30c30c30c3UL;
  x = (x | (x >> 4)) & 0x100f00f00f00f00fUL;
  x = (x | (x >> 8)) & 0x001f0000ff0000ffUL;
  x = (x | (x >> 16)) & 0x001f00000000ffffUL;
  x = (x | (x >> 32)) & 0x00000000001fffffUL;
  return x;
}

/* The unit-domain box of the cell (code, level), as lattice::cell_box. */
GVD_ITEM_FN void gvd_cell_box(int dim, gvd_u64 code, int level, GvdPoint* lo, GvdPoint* hi) {
  gvd_u64 c[3] = {0, 0, 0};
  if (dim == 2) {
    c[0] = gvd_compact2(code);
    c[1] = gvd_compact2(code >> 1);
  } else {
    c[0] = gvd_compact3(code);
    c[1] = gvd_compact3(code >> 1);
    c[2] = gvd_compact3(code >> 2);
  }
  const double s = 1.0 / (double)((gvd_u64)1 << gvd_lattice_bits(dim));
  const double size = (double)((gvd_u64)1 << (gvd_lattice_bits(dim) - level)) * s;
  *lo = gvd_pt((double)c[0] * s, (double)c[1] * s, dim == 3 ? (double)c[2] * s : 0.0);
  *hi = gvd_add(*lo, gvd_pt(size, size, dim == 3 ? size : 0.0));
}

/* Overlap slack of cells at `level`: the one definition (subdivision_rule.h overlap_slack). */
GVD_ITEM_FN double gvd_slack(int level) {
  return (double)1.0 / (double)((gvd_u64)1 << level) * 1e-9 + 1e-15;
}

GVD_ITEM_FN double gvd_min3(double a, double b, double c) {
  double m = a;
  if (b < m) m = b;
  if (c < m) m = c;
  return m;
}
GVD_ITEM_FN double gvd_max3(double a, double b, double c) {
  double m = a;
  if (m < b) m = b;
  if (m < c) m = c;
  return m;
}

GVD_ITEM_FN int gvd_separated_on_axis(GvdPoint axis, GvdPoint v0, GvdPoint v1, GvdPoint v2,
                                      GvdPoint hsize) {
  const double p0 = gvd_dot(v0, axis);
  const double p1 = gvd_dot(v1, axis);
  const double p2 = gvd_dot(v2, axis);
  const double r =
      hsize.x * GVD_FABS(axis.x) + hsize.y * GVD_FABS(axis.y) + hsize.z * GVD_FABS(axis.z);
  const double lo = gvd_min3(p0, p1, p2);
  const double hi = gvd_max3(p0, p1, p2);
  const double alo = GVD_FABS(lo), ahi = GVD_FABS(hi);
  const double eps = 1e-12 * (r + (alo < ahi ? ahi : alo));
  return lo > r + eps || hi < -r - eps;
}

GVD_ITEM_FN double gvd_comp(GvdPoint p, int i) { return i == 0 ? p.x : (i == 1 ? p.y : p.z); }

/* Conservative overlap of a closed 3D triangle and the closed box [blo, bhi] inflated by
 * slack (separating axes, Akenine-Moller), as triangle_overlaps_box. */
GVD_ITEM_FN int gvd_triangle_overlaps_box(GvdPoint a, GvdPoint b, GvdPoint c, GvdPoint blo,
                                          GvdPoint bhi, double slack) {
  const GvdPoint center = gvd_scale(gvd_add(blo, bhi), 0.5);
  const GvdPoint hsize = gvd_add(gvd_scale(gvd_sub(bhi, blo), 0.5), gvd_pt(slack, slack, slack));
  const GvdPoint v0 = gvd_sub(a, center);
  const GvdPoint v1 = gvd_sub(b, center);
  const GvdPoint v2 = gvd_sub(c, center);
  for (int i = 0; i < 3; ++i) {
    const double lo = gvd_min3(gvd_comp(v0, i), gvd_comp(v1, i), gvd_comp(v2, i));
    const double hi = gvd_max3(gvd_comp(v0, i), gvd_comp(v1, i), gvd_comp(v2, i));
    if (lo > gvd_comp(hsize, i) || hi < -gvd_comp(hsize, i)) return 0;
  }
  const GvdPoint e[3] = {gvd_sub(v1, v0), gvd_sub(v2, v1), gvd_sub(v0, v2)};
  const GvdPoint n = gvd_cross(e[0], e[1]);
  if (gvd_dot(n, n) > 0 && gvd_separated_on_axis(n, v0, v1, v2, hsize)) return 0;
  const GvdPoint axes[3] = {gvd_pt(1, 0, 0), gvd_pt(0, 1, 0), gvd_pt(0, 0, 1)};
  for (int k = 0; k < 3; ++k) {
    for (int m = 0; m < 3; ++m) {
      const GvdPoint axis = gvd_cross(e[k], axes[m]);
      if (gvd_dot(axis, axis) > 0 && gvd_separated_on_axis(axis, v0, v1, v2, hsize)) return 0;
    }
  }
  return 1;
}

/* Conservative overlap of a closed 2D segment and a closed box (x, y), as
 * segment_overlaps_box_2d. */
GVD_ITEM_FN int gvd_segment_overlaps_box(GvdPoint a, GvdPoint b, GvdPoint blo, GvdPoint bhi,
                                         double slack) {
  const double lox = blo.x - slack, hix = bhi.x + slack;
  const double loy = blo.y - slack, hiy = bhi.y + slack;
  if ((a.x < b.x ? b.x : a.x) < lox || (b.x < a.x ? b.x : a.x) > hix) return 0;
  if ((a.y < b.y ? b.y : a.y) < loy || (b.y < a.y ? b.y : a.y) > hiy) return 0;
  const double nx = -(b.y - a.y);
  const double ny = b.x - a.x;
  const double cx = 0.5 * (lox + hix), cy = 0.5 * (loy + hiy);
  const double hx = 0.5 * (hix - lox), hy = 0.5 * (hiy - loy);
  const double s = nx * (cx - a.x) + ny * (cy - a.y);
  const double r = hx * GVD_FABS(nx) + hy * GVD_FABS(ny);
  const double eps = 1e-12 * (r + GVD_FABS(s));
  return GVD_FABS(s) <= r + eps;
}

/* Does simplex s touch the box [lo, hi] inflated by slack? The test of build_octree.cpp. */
GVD_ITEM_FN int gvd_simplex_touches_box(int dim, GVD_GLOBAL const GvdPoint* points,
                                        GVD_GLOBAL const gvd_uint* simplices, gvd_uint s,
                                        GvdPoint lo, GvdPoint hi, double slack) {
  const GvdPoint a = points[simplices[3 * s]];
  const GvdPoint b = points[simplices[3 * s + 1]];
  if (dim == 2) return gvd_segment_overlaps_box(a, b, lo, hi, slack);
  return gvd_triangle_overlaps_box(a, b, points[simplices[3 * s + 2]], lo, hi, slack);
}

/* Does simplex s touch the cell (code, level)? */
GVD_ITEM_FN int gvd_simplex_touches_cell(int dim, GVD_GLOBAL const GvdPoint* points,
                                         GVD_GLOBAL const gvd_uint* simplices, gvd_uint s,
                                         gvd_u64 code, int level) {
  GvdPoint lo, hi;
  gvd_cell_box(dim, code, level, &lo, &hi);
  return gvd_simplex_touches_box(dim, points, simplices, s, lo, hi, gvd_slack(level));
}

/* A cheap early reject before the exact test: true only when the simplex's bounding box
 * [slo, shi] is farther than twice the slack from the cell box on some axis, where the exact
 * test must reject too (its rounding is far below the slack). */
GVD_ITEM_FN int gvd_bbox_apart(GvdPoint slo, GvdPoint shi, GvdPoint lo, GvdPoint hi, double slack) {
  const double m = 2 * slack;
  return slo.x > hi.x + m || shi.x < lo.x - m || slo.y > hi.y + m || shi.y < lo.y - m ||
         slo.z > hi.z + m || shi.z < lo.z - m;
}

/* First index in [begin, end) of the sorted `codes` equal to `code`, or end. */
GVD_ITEM_FN gvd_uint gvd_find_code(GVD_GLOBAL const gvd_u64* codes, gvd_uint begin, gvd_uint end,
                                   gvd_u64 code) {
  gvd_uint lo = begin, hi = end;
  while (lo < hi) {
    const gvd_uint mid = lo + (hi - lo) / 2;
    if (codes[mid] < code)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo < end && codes[lo] == code ? lo : end;
}

/* Algorithm 2, lines 10-28, for one leaf (code, level): the facets stored at the leaf's
 * ancestors (and itself) that touch it. The SCC array is sorted by (level, code):
 * scc_level_begin[l] .. [l+1] are the entries of level l; scc_lo/scc_hi are the facets'
 * bounding boxes (an early reject). Writes the facets to `out` when non-null; returns how
 * many touch (the count pass calls it with out = null). */
GVD_ITEM_FN gvd_uint gvd_leaf_facets(
    int dim, GVD_GLOBAL const GvdPoint* points, GVD_GLOBAL const gvd_uint* simplices,
    GVD_GLOBAL const gvd_u64* scc_code, GVD_GLOBAL const gvd_uint* scc_simplex,
    GVD_GLOBAL const GvdPoint* scc_lo, GVD_GLOBAL const GvdPoint* scc_hi,
    GVD_GLOBAL const gvd_uint* scc_level_begin, gvd_u64 code, int level, GVD_GLOBAL gvd_uint* out) {
  GvdPoint lo, hi;
  gvd_cell_box(dim, code, level, &lo, &hi);
  const double slack = gvd_slack(level);
  gvd_uint count = 0;
  for (int l = 0; l <= level; ++l) {
    const gvd_u64 a = gvd_truncate(dim, code, l);
    const gvd_uint end = scc_level_begin[l + 1];
    for (gvd_uint k = gvd_find_code(scc_code, scc_level_begin[l], end, a);
         k < end && scc_code[k] == a; ++k) {
      if (gvd_bbox_apart(scc_lo[k], scc_hi[k], lo, hi, slack)) continue;
      const gvd_uint s = scc_simplex[k];
      if (gvd_simplex_touches_box(dim, points, simplices, s, lo, hi, slack)) {
        if (out) out[count] = s;
        ++count;
      }
    }
  }
  return count;
}

#ifndef __OPENCL_VERSION__
}  // namespace gvd::item
#endif

#endif /* GVD_OCTREE_OCTREE_BUILD_ITEM_H */
