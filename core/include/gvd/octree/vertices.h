#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "gvd/common/flat_hash.h"
#include "gvd/octree/octree.h"

namespace gvd {

inline constexpr uint32_t kNoVertex = ~0u;

/// The vertices of an octree: every leaf corner (hanging vertices of coarser leaves are
/// corners of finer ones), sorted by lattice key, with an O(1) key -> index map.
struct OctreeVertices {
  int dimension = 3;
  std::vector<uint64_t> key;  ///< sorted lattice keys (lattice::vertex_key)
  FlatMap64 index;            ///< key -> position in `key`

  size_t size() const { return key.size(); }
  uint32_t find(uint64_t k) const { return index.find(k); }
  Vec3 position(uint32_t v) const {
    return lattice::to_unit(dimension, lattice::vertex_coord(dimension, key[v]));
  }
  size_t memory_bytes() const { return key.size() * sizeof(uint64_t) + index.memory_bytes(); }
};

/// Enumerates the vertices of a balanced octree. O(N) expected.
OctreeVertices enumerate_vertices(const Octree& octree, int threads = 0);

/// The vertices on the boundary of one leaf on its half-size local grid: entry i + 3j (+ 9k)
/// is the vertex at local position (i, j, k) in {0,1,2}^D (corners always exist; edge
/// midpoints and face centres exist only where a neighbour is finer), kNoVertex otherwise.
/// The centre entry is always kNoVertex. 2D uses the first 9 entries.
using LeafGrid = std::array<uint32_t, 27>;
LeafGrid leaf_grid(const Octree& octree, const OctreeVertices& vertices, uint32_t leaf);

}  // namespace gvd
