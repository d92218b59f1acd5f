#pragma once

// The distance transform's data (paper §4): the closest object point of every octree vertex.
// compute_distances.h makes it.

#include <cstdint>
#include <vector>

#include "gvd/geometry/vec.h"
#include "gvd/octree/octree.h"
#include "gvd/octree/vertices.h"
#include "gvd/scene/scene.h"

namespace gvd::distance {

/// Label and closest point of every octree vertex (paper §4), in unit-domain coordinates.
struct DistanceField {
  octree::OctreeVertices vertices;
  std::vector<scene::ObjectId> label;  ///< per vertex; kNoObject when no object was reached
  std::vector<uint32_t> point;         ///< per vertex: index into `closest`, kNoVertex if none
  std::vector<Vec3> closest;           ///< closest points on objects (shared between vertices)
  std::vector<uint8_t> exact;          ///< per vertex: 1 = exact closest point
  /// Per vertex: 1 when new or changed since the `previous` field (all 1 without one).
  std::vector<uint8_t> changed;
  uint64_t exact_count = 0;     ///< non-empty vertices initialised exactly
  uint64_t exact_reused = 0;    ///< of those, taken from the previous field (refinement)
  uint64_t exact_near_gvd = 0;  ///< empty vertices made exact because the GVD crosses their cell

  size_t size() const { return label.size(); }
  /// The LeafGrid of a leaf, by key lookups of its vertices (leaf_vertices.h reads it from
  /// the leaf's row instead, where the distance transform kept the rows).
  octree::LeafGrid grid(const octree::Octree& octree, uint32_t leaf) const {
    return octree::leaf_grid(octree, vertices, leaf);
  }
  /// Distance from vertex v to its assigned closest point (unit domain; inf if none).
  double distance(uint32_t v) const;
  size_t memory_bytes() const;
};

}  // namespace gvd::distance
