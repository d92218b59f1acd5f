/* Closest-point initialisation (paper §4): one work-item per query, a shim around the shared
 * per-item function gvd_nearest_item (closest_point_item.h, embedded in front of this file).
 * The arrays are SimplexBvh's own, uploaded as they are. CPU twin: closest_points_cpu in
 * core. */

__kernel void gvd_closest_points(const int dimension, const uint node_count,
                                 __global const GvdBvhNode* nodes, __global const uint* order,
                                 __global const GvdPoint* points, __global const uint* corner,
                                 __global const GvdPoint* queries,
                                 __global const double* bound2, const uint count,
                                 __global GvdHit* hits) {
  const uint i = (uint)get_global_id(0);
  if (i >= count) return;
  hits[i] = gvd_nearest_item(dimension, node_count, nodes, order, corner, points, queries[i],
                             bound2[i]);
}
