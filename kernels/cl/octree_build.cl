/* The data-parallel octree build (parallel-quadtree-construction draft §3.2-3.5): shims
 * around the per-item functions of octree_build_item.h (embedded in front of this file).
 * CPU twins: make_cpu_octree_build_steps in core (build_octree_data_parallel.cpp). */

__kernel void gvd_vertex_keys(const int dimension, __global const GvdPoint* points,
                              const uint count, const int shift, __global ulong* keys) {
  const uint i = (uint)get_global_id(0);
  if (i >= count) return;
  keys[i] = gvd_point_code(dimension, points[i]) >> shift;
}

__kernel void gvd_radix_nodes(__global const ulong* keys, const int count, const int bits,
                              __global GvdRadixNode* nodes) {
  const int i = (int)get_global_id(0);
  if (i >= count - 1) return;
  nodes[i] = gvd_radix_node(keys, count, bits, i);
}

/* Every internal node names its internal children: each parent entry is written once. */
__kernel void gvd_radix_parents(__global const GvdRadixNode* nodes, const int internal_count,
                                __global int* parent) {
  const int i = (int)get_global_id(0);
  if (i >= internal_count) return;
  const GvdRadixNode n = nodes[i];
  if (n.first != n.split) parent[n.split] = i;
  if (n.last != n.split + 1) parent[n.split + 1] = i;
  if (i == 0) parent[0] = -1;
}

/* Cells each simplex is stored in: count pass (fill = 0), then fill at out_begin[s]. */
__kernel void gvd_facet_cell_lists(const int dimension, __global const GvdPoint* points,
                              __global const uint* simplices, const uint count,
                              const double slack, const int max_level, const int fill,
                              __global uint* counts, __global const uint* out_begin,
                              __global ulong* codes, __global int* levels) {
  const uint s = (uint)get_global_id(0);
  if (s >= count) return;
  if (!fill) {
    counts[s] = (uint)gvd_facet_cells(dimension, points, simplices, s, slack, max_level, 0, 0);
    return;
  }
  gvd_facet_cells(dimension, points, simplices, s, slack, max_level, codes + out_begin[s],
                  levels + out_begin[s]);
}

/* Algorithm 2, lines 10-28: count pass (out_begin = 0) and fill pass. */
__kernel void gvd_cell_facets(const int dimension, __global const GvdPoint* points,
                              __global const uint* simplices, __global const ulong* scc_code,
                              __global const uint* scc_simplex, __global const GvdPoint* scc_lo,
                              __global const GvdPoint* scc_hi,
                              __global const uint* scc_level_begin,
                              __global const ulong* cell_code, __global const uchar* cell_level,
                              const uint count, const int fill, __global uint* counts,
                              __global const uint* out_begin, __global uint* out) {
  const uint i = (uint)get_global_id(0);
  if (i >= count) return;
  const uint n =
      gvd_leaf_facets(dimension, points, simplices, scc_code, scc_simplex, scc_lo, scc_hi,
                      scc_level_begin, cell_code[i], cell_level[i], fill ? out + out_begin[i] : 0);
  if (!fill) counts[i] = n;
}

/* Algorithm 3, one level: child i keeps the facets of its parent's list that touch it. */
__kernel void gvd_child_facets(const int dimension, __global const GvdPoint* points,
                               __global const uint* simplices, __global const uint* list_begin,
                               __global const uint* list_items, __global const uint* parent,
                               __global const ulong* child_code, __global const uchar* child_level,
                               const uint count, const int fill, __global uint* counts,
                               __global const uint* out_begin, __global uint* out) {
  const uint i = (uint)get_global_id(0);
  if (i >= count) return;
  const uint p = parent[i];
  uint n = 0;
  GvdPoint lo, hi;
  gvd_cell_box(dimension, child_code[i], child_level[i], &lo, &hi);
  const double slack = gvd_slack(child_level[i]);
  for (uint k = list_begin[p]; k < list_begin[p + 1]; ++k) {
    const uint s = list_items[k];
    if (gvd_simplex_touches_box(dimension, points, simplices, s, lo, hi, slack)) {
      if (fill) out[out_begin[i] + n] = s;
      ++n;
    }
  }
  if (!fill) counts[i] = n;
}
