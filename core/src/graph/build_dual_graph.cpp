#include "gvd/graph/build_dual_graph.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "gvd/common/cancel.h"
#include "gvd/common/parallel.h"
#include "gvd/graph/dual_graph.h"

namespace gvd::graph {

using namespace gvd::scene;
using namespace gvd::surface;

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

void tighten_clearances(DualGraph& graph, const Gvd& gvd, const SimplexBvh& bvh,
                        const Domain& domain, int threads, const std::atomic<bool>* cancel,
                        const std::vector<std::pair<ObjectId, ObjectId>>& touching) {
  const int arity = gvd.dimension == 2 ? 2 : 3;
  struct Piece {
    uint32_t cell, first;  // the simplex's first index in cell.indices
    uint32_t edge;         // its dual edge
    double clearance;      // least vertex clearance (user units)
  };
  std::map<std::pair<ObjectId, ObjectId>, uint32_t> edge_of;
  for (uint32_t e = 0; e < graph.edges.size(); ++e) {
    const std::pair<ObjectId, ObjectId> pair{graph.edges[e].a, graph.edges[e].b};
    if (!std::binary_search(touching.begin(), touching.end(), pair)) edge_of[pair] = e;
  }
  std::vector<Piece> pieces;
  for (uint32_t c = 0; c < gvd.cells.size(); ++c) {
    const GvdCell& cell = gvd.cells[c];
    for (size_t s = 0; s + arity <= cell.indices.size(); s += arity) {
      const ObjectId other = cell.other[cell.indices[s]];
      if (other == kNoObject || other <= cell.object) continue;
      double clearance = 1e300, longest2 = 0;
      for (int k = 0; k < arity; ++k) {
        const uint32_t v = cell.indices[s + k], w = cell.indices[s + (k + 1) % arity];
        clearance = std::min(clearance, cell.clearance[v]);
        longest2 = std::max(longest2, dist2(cell.positions[v], cell.positions[w]));
      }
      if (longest2 <= 4 * clearance * clearance) continue;
      const auto it = edge_of.find({cell.object, other});
      if (it == edge_of.end()) continue;
      pieces.push_back({c, static_cast<uint32_t>(s), it->second, clearance});
    }
  }
  std::vector<ClosestHit> hits(pieces.size());
  parallel_for(
      pieces.size(), threads,
      [&](size_t b, size_t e, int) {
        for (size_t i = b; i < e && !is_cancelled(cancel); ++i) {
          const GvdCell& cell = gvd.cells[pieces[i].cell];
          Vec3 q[3];
          for (int k = 0; k < arity; ++k)
            q[k] = domain.to_unit(cell.positions[cell.indices[pieces[i].first + k]]);
          const double bound = pieces[i].clearance / domain.side;
          hits[i] = bvh.closest_to_simplex(q, bound * bound);
        }
      },
      64);
  throw_if_cancelled(cancel, "clearances");
  for (size_t i = 0; i < pieces.size(); ++i) {
    if (!hits[i].found()) continue;
    DualEdge& e = graph.edges[pieces[i].edge];
    const double clearance = std::sqrt(hits[i].dist2) * domain.side;
    if (clearance < e.min_clearance) {
      e.min_clearance = clearance;
      e.tightest_point = domain.from_unit(hits[i].point);
    }
  }
}

void measure_gaps(DualGraph& graph, const SimplexBvh& bvh, const Domain& domain,
                  const std::vector<std::pair<ObjectId, ObjectId>>& contacts, int threads,
                  const std::atomic<bool>* cancel) {
  std::vector<SimplexBvh::ObjectPair> pairs(graph.edges.size());
  parallel_for(
      graph.edges.size(), threads,
      [&](size_t b, size_t e, int) {
        for (size_t i = b; i < e && !is_cancelled(cancel); ++i)
          pairs[i] = bvh.object_distance(graph.edges[i].a, graph.edges[i].b);
      },
      1);
  throw_if_cancelled(cancel, "gap measurement");
  for (size_t i = 0; i < graph.edges.size(); ++i) {
    if ((i & 255) == 0) throw_if_cancelled(cancel, "gap measurement");
    DualEdge& e = graph.edges[i];
    if (!pairs[i].found) continue;
    e.gap = std::sqrt(pairs[i].dist2) * domain.side;
    e.touching = std::binary_search(contacts.begin(), contacts.end(), std::pair{e.a, e.b});
    const Vec3 middle = (pairs[i].on_a + pairs[i].on_b) * 0.5;
    if (e.touching) {
      e.min_clearance = 0;
      e.tightest_point = domain.from_unit(middle);
      continue;
    }
    // Every point equidistant from a and b is at least half the gap from them, and the middle
    // of their closest pair is exactly that far: where no third object is nearer to it, it
    // lies on the interface and the interface's least clearance is half the gap, exactly
    // (the GVD's pieces, curved ones kept within a tolerance of it, may pass a little nearer).
    const uint32_t pair[2] = {e.a, e.b};
    const double half = 0.5 * std::sqrt(pairs[i].dist2);
    if (!bvh.nearest_excluding(middle, pair, 2, half * half * (1 - 1e-12)).found()) {
      e.min_clearance = half * domain.side;
      e.tightest_point = domain.from_unit(middle);
    }
  }
}

}  // namespace gvd::graph
