#pragma once

// The dual graph's data: objects as nodes and an edge for every pair whose GVD cells share
// boundary, with the interface's area, the least clearance and where it is reached, the exact gap
// between the two objects and whether they are in contact. Edges are sorted by (a, b).
// build_dual_graph.h makes it from a GVD, grid/grid_graph.h from a uniform grid.

#include <vector>

#include "gvd/geometry/vec.h"
#include "gvd/scene/scene.h"

namespace gvd::graph {

/// An edge of the dual graph: objects `a` < `b` whose cells share boundary.
struct DualEdge {
  scene::ObjectId a = scene::kNoObject;
  scene::ObjectId b = scene::kNoObject;
  double area = 0;           ///< interface area (3D) or length (2D) inside the domain, user units
  double min_clearance = 0;  ///< least distance from the shared boundary to the objects
  Vec3 tightest_point;       ///< a boundary point where `min_clearance` is attained
  /// The gap: the least distance between the two objects themselves (user units; 0 when
  /// they touch or intersect), measured exactly (measure_gaps). Where nothing else comes
  /// between them it is twice min_clearance. < 0: not measured (results saved before it was).
  double gap = -1;
  /// A contact pair: they touch, intersect or come closer than the finest cells can
  /// separate (contacts.h). Then min_clearance is 0 and tightest_point the middle of their
  /// closest points; `gap` still says how far apart they are.
  bool touching = false;
};

/// Objects as nodes (by index), edges sorted by (a, b).
struct DualGraph {
  uint32_t node_count = 0;
  std::vector<DualEdge> edges;
};

}  // namespace gvd::graph
