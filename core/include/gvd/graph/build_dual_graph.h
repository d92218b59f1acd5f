#pragma once

// The dual graph of a GVD (paper §7.3) and its exact gaps and clearances.

#include <atomic>
#include <utility>
#include <vector>

#include "gvd/geometry/simplex_bvh.h"
#include "gvd/graph/dual_graph.h"
#include "gvd/scene/scene.h"
#include "gvd/surface/gvd.h"

namespace gvd::graph {

/// Builds the dual graph from the cells of a GVD: an edge for every pair of objects whose
/// cells share at least one simplex of positive measure; area summed over the shared simplices
/// (each counted once), clearance = minimum over their vertices. O(GVD size). Paper §7.3.
DualGraph build_dual_graph(const surface::Gvd& gvd);

/// Measures every edge's `gap` exactly (SimplexBvh::object_distance over the unit-domain
/// `bvh`) and marks the contact pairs (`contacts`, a < b) `touching`, with min_clearance 0.
/// Where no third object is nearer to the middle of the pair's closest points than half the
/// gap, that middle lies on the interface and no interface point is nearer to the objects:
/// min_clearance becomes half the gap, exactly, and tightest_point that middle.
/// Reads `cancel` (may be null) between edges and stops with gvd::Error{kCancelled}: an edge
/// between two large objects is a long exact search.
void measure_gaps(DualGraph& graph, const SimplexBvh& bvh, const scene::Domain& domain,
                  const std::vector<std::pair<scene::ObjectId, scene::ObjectId>>& contacts,
                  int threads, const std::atomic<bool>* cancel = nullptr);

/// The vertex minimum of build_dual_graph is the clearance only where the GVD's simplices are
/// small next to it. Certified pair cells (refine/pair_certificate.h) span thin gaps and
/// rims with few large pieces whose least clearance lies inside them (between flush plates'
/// rims, the pieces' vertices sit far outside the gap). For every interface simplex longer
/// than twice its least vertex clearance this finds the exact least distance from the simplex
/// to the scene's simplices (`bvh`, unit domain; SimplexBvh::closest_to_simplex) and lowers
/// the edge's min_clearance and tightest_point to it.
/// `touching` (sorted pairs a < b, as measure_gaps' `contacts`): pairs whose clearance
/// measure_gaps sets to 0 anyway; their pieces are not searched (a labelled volume's
/// neighbours all touch: millions of pieces).
/// Reads `cancel` (may be null) between pieces and stops with gvd::Error{kCancelled}.
void tighten_clearances(
    DualGraph& graph, const surface::Gvd& gvd, const SimplexBvh& bvh, const scene::Domain& domain,
    int threads, const std::atomic<bool>* cancel = nullptr,
    const std::vector<std::pair<scene::ObjectId, scene::ObjectId>>& touching = {});

}  // namespace gvd::graph
