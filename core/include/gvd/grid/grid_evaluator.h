#pragma once

// The per-range distance evaluation of the uniform-grid GVD (paper §5) behind an interface,
// so that it runs on the OpenCL backend (kernels/cl/grid_distance.cl) or on its CPU twin;
// both run gvd_grid_item (grid_item.h) per cell.

#include <atomic>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "gvd/geometry/vec.h"
#include "gvd/grid/compute_grid.h"
#include "gvd/grid/grid_item.h"

namespace gvd::grid {

/// The sites of a grid computation: the scene's objects. Every simplex in one flat list
/// (three vertex indices each; segments repeat their first vertex), numbered object by
/// object, and one BVH per object over its own simplices, built by build_bvh_nodes as
/// SimplexBvh's are, all in `nodes` (depth-first; inner nodes: left child next, right child
/// at `first`, count 0; leaves: order[first .. first + count) are simplex indices).
struct GridGeometry {
  int dimension = 3;
  std::vector<Vec3> points;
  std::vector<uint32_t> simplices;         ///< 3 per simplex
  std::vector<scene::ObjectId> object_of;  ///< per simplex
  std::vector<item::GvdBvhNode> nodes;
  std::vector<uint32_t> order;
  std::vector<uint32_t> roots;  ///< per object: its BVH's root in `nodes`
  uint32_t object_count() const { return static_cast<uint32_t>(roots.size()); }
};

/// The sites of a scene (user coordinates; 2D with z = 0). O(S log S). `cancel` (may be
/// null) is read per object and every 16k simplices of a BVH: set, gvd::Error{kCancelled}.
GridGeometry make_grid_geometry(const scene::Scene& scene,
                                const std::atomic<bool>* cancel = nullptr);

/// Signs the distances of the cells whose centre lies inside their nearest object when that
/// object is closed (`closed`, per object): ray parity along each row of cells (x), with the
/// symbolic perturbation of docs/ALGORITHM.md ("Signs") for rows through vertices and edges.
/// `out.label` and `out.distance` (unsigned) are read and the distances negated in place.
/// Shared by compute_grid and sample_result_grid, so both sign the same cells. O(simplices x
/// rows they cross + cells).
/// `cancel` (may be null) is read every few thousand simplices and every row: set, it stops
/// with gvd::Error{kCancelled}.
void sign_grid_distances(const scene::Scene& scene, const GridGeometry& geometry,
                         const GridSpec& spec, const std::vector<uint8_t>& closed,
                         DistanceGrid& out, int threads, const std::atomic<bool>* cancel = nullptr);
/// Sets `out.closed` (is_closed_object per object; all 0 without `signed_distance`) and signs
/// the distances of the closed ones (sign_grid_distances), with their count and time in
/// `out.stats`. The last step of compute_grid and sample_result_grid.
void sign_closed_objects(const scene::Scene& scene, const GridGeometry& geometry,
                         const GridSpec& spec, bool signed_distance, int threads, DistanceGrid& out,
                         const std::atomic<bool>* cancel = nullptr);

/// The device-side grid description of a spec and metric.
item::GvdGridSpec make_item_spec(const GridSpec& spec, GridMetric metric);

/// Runs the per-range evaluation batch after batch on one grid; holds each cell's best key
/// and site (initially +inf / none).
class GridEvaluator {
 public:
  virtual ~GridEvaluator() = default;
  /// gvd_grid_item for every item 0..items-1 of one batch: `jobs` are disjoint ranges with
  /// their candidate sites in `sites`; `visible` (one flag per entry of `sites`, zeroed by
  /// the caller) gets the visibility flags. `items` = total rows (y, z) of the jobs; every
  /// job's dist_first + site_count x cells is at most max_pairs().
  virtual void evaluate(std::span<const item::GvdGridJob> jobs, std::span<const uint32_t> sites,
                        uint32_t items, std::span<int32_t> visible) = 0;
  /// Each cell's best key and site so far.
  virtual void read_best(std::span<double> key, std::span<uint32_t> site) = 0;
  /// How many site x cell distances one batch may hold (the scratch buffer).
  static constexpr uint64_t max_pairs() { return uint64_t{1} << 22; }
  /// A flag (may be null) that evaluate() reads inside a batch: the CPU twin every row of
  /// cells, the OpenCL evaluator between slices of its launch. Set, evaluate() throws
  /// gvd::Error{kCancelled}; the best keys are then those of an unfinished batch.
  void set_cancel(const std::atomic<bool>* cancel) { cancel_ = cancel; }

 protected:
  const std::atomic<bool>* cancel_ = nullptr;
};

/// The CPU twin: gvd_grid_item over the items on `threads` threads (0 = all cores).
std::unique_ptr<GridEvaluator> make_cpu_grid_evaluator(const GridGeometry& geometry,
                                                       const item::GvdGridSpec& spec,
                                                       int threads = 0);

}  // namespace gvd::grid
