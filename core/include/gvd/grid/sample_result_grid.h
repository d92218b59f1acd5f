#pragma once

// A uniform grid sampled from a finished adaptive result: for every cell
// centre the nearest object and the (signed where closed) distance, exactly, without running
// the CuRV sweeps on the scene again. The octree already knows roughly where every object is:
// the closest points stored on the vertices of the leaf holding a cell centre bound its
// distance from above, and that bound prunes one exact search over the scene's simplices.

#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>

#include "gvd/grid/compute_grid.h"
#include "gvd/result/gvd_result.h"

namespace gvd::grid {

/// Options of `sample_result_grid`.
struct ResultGridOptions {
  /// Cells along the longest side of the box (>= 1), as GridOptions::resolution.
  int resolution = 256;
  GridMetric metric = GridMetric::kL2;
  /// Box to sample (user units; it must hold every vertex, as for compute_grid). Default: the
  /// result's domain (Domain::box(): the cube itself when the octree's frame is the user's
  /// axes), so resolution N gives N^D cells.
  std::optional<Box> box;
  /// Negative distances inside closed objects (the rule of compute_grid, same cells).
  bool signed_distance = true;
  /// Refused before any work: more cells than this (gvd::Error{kLimitExceeded}).
  uint64_t max_cells = uint64_t{1} << 27;
  int threads = 0;  ///< 0 = all cores
  /// Set to true by another thread to stop with gvd::Error{kCancelled}; read every row of
  /// cells (and while signing, as compute_grid).
  const std::atomic<bool>* cancel = nullptr;
  /// Called on the calling thread with the fraction done (0 .. 1, non-decreasing) as rows of
  /// cells are finished; an exception it throws stops the computation.
  std::function<void(double)> progress;
};

/// The grid `sample_result_grid` samples (validated as make_grid_spec: resolution >= 1, a
/// box that holds every vertex, at most max_cells cells; a result without objects is
/// gvd::Error{kInvalidScene}). Cheap: check limits with it before work starts.
GridSpec make_result_grid_spec(const result::GvdResult& result,
                               const ResultGridOptions& options = {});

/// The uniform-grid GVD of a finished result: for every cell centre q (GridSpec), the nearest
/// object and its distance in the metric, and the sign of compute_grid (ray parity; negative
/// inside closed objects). Per cell: the closest points stored on the vertices of the octree
/// leaf holding q (points on objects, so their distance bounds q's from above) name a first
/// object and a bound; that object's exact distance (the per-object BVH walk of
/// grid_item.h, the function compute_grid evaluates) replaces the bound; then a SimplexBvh
/// over all the scene's simplices (user coordinates, the result's scene) is asked for any
/// other object within that distance (SimplexBvh::nearest_excluding, pruned by it; for L1 and
/// L-infinity within the Euclidean radius that metric's distance implies), each found object
/// is evaluated exactly and the search repeats without it until none is left. So labels are
/// the exact nearest object (exact ties: the lower index) and distances exact in double, the
/// same keys compute_grid computes: the two grids agree bit for bit on the same box. Not
/// interpolated from the octree. Cost per cell: one leaf lookup and one or two bounded BVH
/// searches (cheap away from objects, where the leaf's bound is tight); O(cells) memory.
/// `stats.pairs_evaluated` counts the exact object evaluations.
DistanceGrid sample_result_grid(const result::GvdResult& result,
                                const ResultGridOptions& options = {});

}  // namespace gvd::grid
