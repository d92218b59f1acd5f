#pragma once

// The distance transform's data (paper §4): the closest object point of every octree vertex.
// compute_distances.h makes it.

#include <cstdint>
#include <span>
#include <vector>

#include "gvd/common/growable_array.h"
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

  /// The boundary vertices of every leaf (CSR over leaves: vertex ids and their slots in
  /// the leaf's LeafGrid). Built by compute_distances and kept for the refinement checks and
  /// the surfacing; empty in a field loaded from disk.
  std::vector<uint32_t> leaf_begin;
  /// Grown in place by a refinement's update (the rows of unchanged leaves move up within it),
  /// so that the old and the new lists, the refinement's largest arrays, are never both held.
  GrowableArray<uint32_t> leaf_vertex;
  /// Per leaf: bit k set when slot k of its LeafGrid holds a vertex; the leaf's row of
  /// leaf_vertex lists those vertices in slot order.
  std::vector<uint32_t> leaf_slots;

  size_t size() const { return label.size(); }
  /// Frees the per-leaf lists (grid() then looks vertices up by key, as in a loaded field).
  void drop_leaf_lists() {
    std::vector<uint32_t>().swap(leaf_begin);
    leaf_vertex.release();
    std::vector<uint32_t>().swap(leaf_slots);
  }
  /// Keeps the per-leaf lists of `leaves` (ascending) only: the other rows are emptied in
  /// place and their slot masks set to 0, and the array shrinks to what is left. O(entries).
  void keep_leaf_lists_of(std::span<const uint32_t> leaves);
  /// The LeafGrid of a leaf, from its CSR row when it has one (a non-zero slot mask), else by
  /// key lookups.
  octree::LeafGrid grid(const octree::Octree& octree, uint32_t leaf) const;
  /// Distance from vertex v to its assigned closest point (unit domain; inf if none).
  double distance(uint32_t v) const;
  size_t memory_bytes() const;
};

}  // namespace gvd::distance
