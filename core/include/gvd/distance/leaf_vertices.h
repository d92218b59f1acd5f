#pragma once

// The vertices on the boundary of every leaf of an octree, as the distance transform finds
// them (compute_distances.h) and the refinement's checks and the surfacing read them.
// Acceleration data, held beside the DistanceField rather than in it: without them a leaf's
// vertices are looked up by key (DistanceField::grid), as in a result loaded from disk.

#include <cstdint>
#include <span>
#include <vector>

#include "gvd/common/growable_array.h"
#include "gvd/octree/octree.h"
#include "gvd/octree/vertices.h"

namespace gvd::distance {

/// Per leaf, its boundary vertices in the order of their slots in the leaf's LeafGrid, as
/// compressed rows: leaf i's are vertex[begin[i] .. begin[i + 1]), and bit k of slots[i] is
/// set when slot k holds one. Empty, or begin has leaves + 1 entries.
struct LeafVertices {
  std::vector<uint32_t> begin;
  /// Grown in place by a refinement's update (the rows of unchanged leaves move up within it),
  /// so that the old and the new lists, the refinement's largest arrays, are never both held.
  GrowableArray<uint32_t> vertex;
  std::vector<uint32_t> slots;

  bool empty() const { return begin.empty(); }
  /// Whether the rows are those of an octree with `leaves` leaves.
  bool covers(size_t leaves) const { return begin.size() == leaves + 1; }
  std::span<const uint32_t> of(uint32_t leaf) const {
    return {vertex.data() + begin[leaf], begin[leaf + 1] - begin[leaf]};
  }
  void release() {
    std::vector<uint32_t>().swap(begin);
    vertex.release();
    std::vector<uint32_t>().swap(slots);
  }
  /// Keeps the rows of `leaves` (ascending) only: the other rows are emptied in place and
  /// their slot masks set to 0, and the array shrinks to what is left. O(entries).
  void keep_only(std::span<const uint32_t> leaves);
  /// The LeafGrid of a leaf of `octree` (whose vertices are `vertices`), from its row when it
  /// has one (a non-zero slot mask), else by key lookups.
  octree::LeafGrid grid(const octree::Octree& octree, const octree::OctreeVertices& vertices,
                        uint32_t leaf) const;
};

}  // namespace gvd::distance
