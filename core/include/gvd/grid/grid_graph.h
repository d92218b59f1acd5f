#pragma once

// The dual graph of the uniform-grid discrete GVD (`gvd compute --mode grid`): which objects'
// labels meet across a cell face, with the interface's area and the pair's exact gap and
// clearance, in the adaptive pipeline's DualGraph so that every writer and query takes it.

#include <atomic>
#include <functional>

#include "gvd/graph/dual_graph.h"
#include "gvd/grid/compute_grid.h"
#include "gvd/scene/scene.h"

namespace gvd::grid {

/// Options of `grid_dual_graph`.
struct GridGraphOptions {
  int threads = 0;  ///< 0 = all cores
  /// Set to true by another thread to stop with gvd::Error{kCancelled}; read every row of
  /// cells in both passes over the faces and by the touching-pair pass.
  const std::atomic<bool>* cancel = nullptr;
  /// Called on the calling thread with the fraction done (0 .. 1, non-decreasing) as slices of
  /// the grid are finished; an exception it throws stops the computation.
  std::function<void(double)> progress;
};

/// The dual graph of `grid` (compute_grid on `scene`): an edge for every pair of objects whose
/// labels lie on two cells sharing a face. `area` is the shared faces' area (length in 2D),
/// user units: the discrete interface, which lies within a cell of the true one. Measured
/// exactly on the scene's simplices, Euclidean whatever the grid's metric: `gap`
/// (SimplexBvh::object_distance), `touching` (closer than the adaptive pipeline's finest cells
/// separate: find_contact_pairs, clearance 0), and `min_clearance` / `tightest_point`: half
/// the gap at the middle of the pair's closest points where no third object is nearer to it
/// (measure_gaps), else the least exact distance from a shared face's centre to the objects.
/// Cells labelled -1 (no object) meet nothing. O(cells + interface faces · log M).
graph::DualGraph grid_dual_graph(const DistanceGrid& grid, const scene::Scene& scene,
                                 const GridGraphOptions& options = {});

}  // namespace gvd::grid
