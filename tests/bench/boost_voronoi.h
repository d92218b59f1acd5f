#pragma once

// The exact segment Voronoi diagram of a 2D scene by Boost.Polygon, reduced to object
// adjacency: the ground truth the dual graph of our GVD is compared with.

#include <cstdint>
#include <utility>
#include <vector>

#include "gvd/scene/scene.h"

namespace gvd::bench {

/// Two objects whose exact Voronoi regions share a boundary inside the box.
struct BoostAdjacentPair {
  scene::ObjectId a = scene::kNoObject;  ///< a < b
  scene::ObjectId b = scene::kNoObject;
  double length = 0;  ///< length of the shared boundary inside the box (user units; curved
                      ///< edges sampled with 32 chords)
};

struct BoostAdjacency {
  std::vector<BoostAdjacentPair> pairs;  ///< sorted by (a, b)
  double voronoi_seconds = 0;            ///< construct_voronoi only
  double adjacency_seconds = 0;          ///< clipping edges and collecting pairs
  double input_seconds = 0;              ///< scaling to integers + exact intersection check
  uint64_t segments = 0;
  uint64_t voronoi_edges = 0;  ///< primary, counted once per twin pair
  uint64_t edges_outside = 0;  ///< primary edges between different objects entirely outside
  double scale = 0;            ///< integer units per user unit
};

/// Scales the 2D scene's segments to the integer grid [0, 2^30]^2 spanning `box` (which must
/// contain every vertex; pass the GVD domain), checks with exact integer predicates that no two
/// segments intersect except at shared endpoints (throws std::runtime_error naming the objects
/// otherwise — Boost requires it), builds the segment Voronoi diagram and reports every pair of
/// objects separated by a primary Voronoi edge of positive length inside `box` (infinite edges
/// are clipped to the box, curved edges sampled).
BoostAdjacency boost_voronoi_adjacency(const scene::Scene& scene, const Box& box);

}  // namespace gvd::bench
