#pragma once

#include <vector>

#include "gvd/geometry/vec.h"
#include "gvd/scene/scene.h"
#include "gvd/surface/gvd.h"

namespace gvd {

/// An edge of the dual graph: objects `a` < `b` whose cells share boundary.
struct DualEdge {
  ObjectId a = kNoObject;
  ObjectId b = kNoObject;
  double area = 0;           ///< interface area (3D) or length (2D) inside the domain, user units
  double min_clearance = 0;  ///< least distance from the shared boundary to the objects
  Vec3 tightest_point;       ///< a boundary point where `min_clearance` is attained
};

/// Objects as nodes (by index), edges sorted by (a, b).
struct DualGraph {
  uint32_t node_count = 0;
  std::vector<DualEdge> edges;
};

/// Builds the dual graph from the cells of a GVD: an edge for every pair of objects whose
/// cells share at least one simplex of positive measure; area summed over the shared simplices
/// (each counted once), clearance = minimum over their vertices. O(GVD size). Paper §7.3.
DualGraph build_dual_graph(const Gvd& gvd);

}  // namespace gvd
