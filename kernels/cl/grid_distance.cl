/* The per-range distance evaluation of the uniform-grid GVD (Sud et al. 2006 §5): one work
 * item per row of cells of a range, a shim around the shared per-item function gvd_grid_item
 * (grid_item.h, embedded with closest_point_item.h in front of this file).
 * CPU twin: make_cpu_grid_evaluator in core (core/src/grid/grid_evaluator.cpp). */

__kernel void gvd_grid_distance(__global const GvdGridSpec* spec, __global const GvdBvhNode* nodes,
                                __global const uint* order, __global const uint* roots,
                                __global const GvdPoint* points, __global const uint* simplices,
                                __global const GvdGridJob* jobs, const uint job_count,
                                __global const uint* sites, const uint items,
                                __global double* best_key, __global uint* best_site,
                                __global double* dist, __global int* visible) {
  const uint i = (uint)get_global_id(0);
  if (i >= items) return;
  gvd_grid_item(spec, nodes, order, roots, points, simplices, jobs, job_count, sites, i, best_key,
                best_site, dist, visible);
}
