#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "gvd/geometry/closest_point_item.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/scene/scene.h"

namespace gvd {

/// The inputs of the per-item closest-point function (closest_point_item.h) as flat arrays
/// of device-ready PODs: the BVH nodes and leaf order of a SimplexBvh, the unit-domain points
/// and 3 vertex indices per simplex (2D: the third is unused). What the OpenCL backend uploads
/// once per scene and the CPU twin reads directly.
struct ClosestPointData {
  int dimension = 3;
  std::vector<item::GvdBvhNode> nodes;
  std::vector<uint32_t> order;
  std::vector<item::GvdPoint> points;
  std::vector<uint32_t> simplices;  ///< 3 per simplex

  size_t memory_bytes() const;
};

/// Flattens `bvh` (built over `geometry`) for the per-item function. O(M).
ClosestPointData make_closest_point_data(const UnitGeometry& geometry, const SimplexBvh& bvh);

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

/// Converts the per-item answer to the core's ClosestHit.
inline ClosestHit to_closest_hit(const item::GvdHit& h) {
  ClosestHit r;
  r.point = {h.x, h.y, h.z};
  r.dist2 = h.dist2;
  r.simplex = h.simplex;
  return r;
}

/// A batch closest-point solver bound to one scene's geometry (see ComputeBackend). Same
/// contract as closest_points_cpu. Not thread-safe: one compute_distances at a time.
class ClosestPointSolver {
 public:
  virtual ~ClosestPointSolver() = default;
  virtual void solve(std::span<const Vec3> queries, std::span<const double> bound2,
                     std::span<ClosestHit> hits) = 0;
};

}  // namespace gvd
