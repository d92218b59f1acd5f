#include <algorithm>
#include <map>

#include "gvd/graph/dual_graph.h"

namespace gvd {

DualGraph build_dual_graph(const Gvd& gvd) {
  DualGraph graph;
  graph.node_count = static_cast<uint32_t>(gvd.cells.size());
  std::map<std::pair<ObjectId, ObjectId>, DualEdge> edges;
  const int arity = gvd.dimension == 2 ? 2 : 3;
  for (const GvdCell& cell : gvd.cells) {
    for (size_t s = 0; s + arity <= cell.indices.size(); s += arity) {
      const uint32_t i0 = cell.indices[s];
      const ObjectId other = cell.other[i0];
      // Each interface simplex is stored once per side; count it from the smaller object.
      if (other == kNoObject || other <= cell.object) continue;
      DualEdge& e = edges[{cell.object, other}];
      if (e.a == kNoObject) {
        e.a = cell.object;
        e.b = other;
        e.min_clearance = 1e300;
      }
      const Vec3 p0 = cell.positions[cell.indices[s]];
      const Vec3 p1 = cell.positions[cell.indices[s + 1]];
      e.area += arity == 2 ? dist(p0, p1)
                           : 0.5 * norm(cross(p1 - p0, cell.positions[cell.indices[s + 2]] - p0));
      for (int k = 0; k < arity; ++k) {
        const uint32_t v = cell.indices[s + k];
        if (cell.clearance[v] < e.min_clearance) {
          e.min_clearance = cell.clearance[v];
          e.tightest_point = cell.positions[v];
        }
      }
    }
  }
  graph.edges.reserve(edges.size());
  for (auto& [key, e] : edges) graph.edges.push_back(e);
  return graph;
}

}  // namespace gvd
