#pragma once

// The CPU closest-point queries of the distance transform (paper §4): for a batch of points, the
// exact closest point on any simplex within each point's squared-distance bound, over a view of
// a SimplexBvh's arrays (the BVH must outlive it). closest_points_cpu (O(n log M)) and its coherent
// variant give bit-identical answers, also to SimplexBvh::nearest and the OpenCL kernel.
// ClosestPointSolver, the interface a backend implements, is not thread-safe.

#include <cstdint>
#include <span>

#include "gvd/geometry/closest_point_item.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/scene/scene.h"

namespace gvd::distance {

/// The inputs of the per-item closest-point function (closest_point_item.h): a SimplexBvh's
/// flat arrays, in the layout it stores them (SimplexBvh::nodes, order, corner, points), which
/// the OpenCL backend uploads as they are. A view, not a copy: the BVH must outlive it (a copy
/// held beside the BVH was 24 MB of the 64-sphere lattice's peak).
struct ClosestPointData {
  int dimension = 3;
  std::span<const item::GvdBvhNode> nodes;
  std::span<const uint32_t> order;
  std::span<const uint32_t> corner;  ///< `dimension` indices into `points` per position in `order`
  std::span<const item::GvdPoint> points;
};

/// The arrays of `bvh` for the per-item function, viewed in place. O(1).
ClosestPointData make_closest_point_data(const SimplexBvh& bvh);

/// The CPU twin of the closest-point kernel (paper §4, initialisation of non-empty vertices):
/// for every i, `hits[i]` = the exact closest point among all simplices to `queries[i]` whose
/// squared distance is at most `bound2[i]` (unit domain; ties to the lower simplex index, or to the
/// one the point is behind when both share their closest point; not found when none is that near).
/// Runs gvd_nearest_item over `threads` threads (0 = all cores). Bit-identical to
/// SimplexBvh::nearest and to the OpenCL kernel. O(n log M).
void closest_points_cpu(const ClosestPointData& data, std::span<const Vec3> queries,
                        std::span<const double> bound2, std::span<ClosestHit> hits,
                        int threads = 0);

/// closest_points_cpu for batches in spatial order (consecutive queries near each other, as
/// compute_distances issues them, in Z order): each item's search is first bounded by its
/// distance to the previous item's answer, a point on a simplex, so it skips more of the tree.
/// The answers are closest_points_cpu's (tested bit for bit, ties included); about a fifth
/// less time on the benchmark scenes' octree vertices.
void closest_points_cpu_coherent(const ClosestPointData& data, std::span<const Vec3> queries,
                                 std::span<const double> bound2, std::span<ClosestHit> hits,
                                 int threads = 0);

/// The same per-item loop on one thread, without the task split: the scalar baseline the
/// benchmarks compare the kernel with.
void closest_points_scalar(const ClosestPointData& data, std::span<const Vec3> queries,
                           std::span<const double> bound2, std::span<ClosestHit> hits);

/// A batch closest-point solver bound to one scene's geometry (see ComputeBackend). Same
/// contract as closest_points_cpu. Not thread-safe: one compute_distances at a time.
class ClosestPointSolver {
 public:
  virtual ~ClosestPointSolver() = default;
  virtual void solve(std::span<const Vec3> queries, std::span<const double> bound2,
                     std::span<ClosestHit> hits) = 0;
};

}  // namespace gvd::distance
