#pragma once

// When a uniform grid would do: from the gaps the pipeline measured between
// neighbouring objects, the grid resolution that would separate the closest pair, and whether
// `gvd grid` would take it within its default cell limit.

#include <cstdint>

#include "gvd/graph/dual_graph.h"
#include "gvd/scene/scene.h"

namespace gvd::grid {

/// What a uniform L2 grid (compute_grid's default box: the vertices' bounding box padded by 5 %
/// of its longest side) would need to separate the closest pair of different objects.
struct GridAdvice {
  /// false: no gap between two objects was measured (one object, no neighbours, or a result
  /// saved before gaps were measured); nothing else is set.
  bool measured = false;
  scene::ObjectId a = scene::kNoObject;  ///< the closest pair of objects at a positive gap (a < b)
  scene::ObjectId b = scene::kNoObject;
  double gap = 0;  ///< their least distance (user units; DualEdge::gap); 0 when every pair touches
  uint64_t touching_pairs =
      0;  ///< neighbour pairs at gap 0 (touch or intersect): no grid separates them
  double longest_side = 0;  ///< longest side of the grid's box (user units)
  /// The least resolution (cells along the longest side) whose cell diagonal h sqrt(D) is below
  /// the gap: floor(longest_side sqrt(D) / gap) + 1. 0 when there is no positive gap.
  double resolution = 0;
  double cells = 0;         ///< cells of that grid (double: may exceed 2^64)
  uint64_t cell_limit = 0;  ///< the default cell limit of gvd grid (GridOptions::max_cells)
  bool fits = false;        ///< cells <= cell_limit
};

/// The advice for a scene and the dual graph of its GVD (edges with measured gaps). The
/// closest pair of two objects are Voronoi neighbours (no third object is nearer than half the
/// gap to the middle of their closest points: it would be nearer than the gap to one of them),
/// so the least positive edge gap of the dual graph is the scene's least gap. O(V + E).
GridAdvice grid_advice(const scene::Scene& scene, const graph::DualGraph& graph);

}  // namespace gvd::grid
