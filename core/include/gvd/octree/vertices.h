#pragma once

// The vertices of a balanced octree: every leaf corner, sorted by lattice key, with an O(1) hash
// index and a bit filter that makes lookups of absent keys cheap (enumerate_vertices: O(N)
// expected). Without the index, find binary-searches the keys; insert needs it. leaf_grid gives
// the vertices on one leaf's boundary.

#include <algorithm>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "gvd/common/error.h"
#include "gvd/common/flat_hash.h"
#include "gvd/octree/octree.h"

namespace gvd::octree {

inline constexpr uint32_t kNoVertex = ~0u;
/// Below this many vertices the vertex index is small (a few MB): the refinement keeps it
/// across rounds, with room to grow in place, rather than freeing it near its memory peak.
inline constexpr size_t kSmallVertexIndex = size_t{1} << 19;

/// The vertices of an octree: every leaf corner (hanging vertices of coarser leaves are
/// corners of finer ones), sorted by lattice key, with an O(1) key -> index map.
struct OctreeVertices {
  int dimension = 3;
  std::vector<uint64_t> key;  ///< sorted lattice keys (lattice::vertex_key)
  FlatMap64 index;            ///< key -> position in `key`
  /// One bit per hash of a key (about 8 bits per key): a clear bit means "no such vertex"
  /// without touching the (much larger) index. Most lookups of a leaf's edge and face
  /// midpoints miss, and this makes them cheap.
  std::vector<uint64_t> filter;

  size_t size() const { return key.size(); }
  /// Whether `index` maps every key (else it was dropped: drop_index).
  bool indexed() const { return index.size() == key.size(); }
  uint32_t find(uint64_t k) const {
    if (!filter.empty()) {
      const uint64_t h = filter_hash(k);
      if (!(filter[h >> 6] >> (h & 63) & 1)) return kNoVertex;
    }
    if (indexed()) return index.find(k);
    const auto it = std::lower_bound(key.begin(), key.end(), k);
    return it != key.end() && *it == k ? static_cast<uint32_t>(it - key.begin()) : kNoVertex;
  }
  /// Frees the hash index of a finished vertex set (its keys sorted): find then
  /// binary-searches the keys (O(log n)); rebuild_index restores it. insert needs it.
  void drop_index() { index = FlatMap64(); }
  /// Whether k may be a vertex (false: certainly not), by the filter alone.
  bool maybe(uint64_t k) const {
    if (filter.empty()) return true;
    const uint64_t h = filter_hash(k);
    return filter[h >> 6] >> (h & 63) & 1;
  }
  /// Builds `index` and `filter` from `key` (distinct keys), on `threads` threads, with room
  /// for `room` more keys before the index must grow (growing holds two tables at once).
  void rebuild_index(int threads = 1, size_t room = 0);
  /// Appends keys that are not vertices yet (distinct): inserted into the index and the filter
  /// where both have room for them, else both are built again with room for `room` more.
  void append(std::span<const uint64_t> added, int threads = 1, size_t room = 0);
  /// Appends k unless present; returns its index.
  uint32_t insert(uint64_t k) {
    GVD_CHECK(indexed(), "OctreeVertices::insert after drop_index");
    const uint32_t next = static_cast<uint32_t>(key.size());
    const uint32_t at = index.insert(k, next);
    if (at == next) {
      key.push_back(k);
      if (!filter.empty()) {
        const uint64_t h = filter_hash(k);
        filter[h >> 6] |= uint64_t{1} << (h & 63);
      }
    }
    return at;
  }
  Vec3 position(uint32_t v) const {
    return lattice::to_unit(dimension, lattice::vertex_coord(dimension, key[v]));
  }
  size_t memory_bytes() const {
    return key.size() * sizeof(uint64_t) + index.memory_bytes() + filter.size() * sizeof(uint64_t);
  }

 private:
  int filter_bits_ = 0;  ///< log2 of the filter's size in bits
  uint64_t filter_hash(uint64_t k) const {
    return (k * 0x9e3779b97f4a7c15ull) >> (64 - filter_bits_);
  }
};

/// Calls f(key) with the lattice keys of the 2^D corners of a leaf.
template <class F>
void for_each_corner_key(const Octree& octree, uint32_t leaf, F&& f) {
  const int dim = octree.dimension;
  const lattice::Coord c = octree.corner(leaf);
  const uint32_t size = static_cast<uint32_t>(lattice::cell_size(dim, octree.level[leaf]));
  for (uint32_t k = 0; k < (1u << dim); ++k) {
    lattice::Coord p = c;
    for (int a = 0; a < dim; ++a)
      if (k & (1u << a)) p.c[a] += size;
    f(lattice::vertex_key(dim, p));
  }
}

/// Enumerates the vertices of a balanced octree. O(N) expected.
OctreeVertices enumerate_vertices(const Octree& octree, int threads = 0);

/// The vertices on the boundary of one leaf on its half-size local grid: entry i + 3j (+ 9k)
/// is the vertex at local position (i, j, k) in {0,1,2}^D (corners always exist; edge
/// midpoints and face centres exist only where a neighbour is finer), kNoVertex otherwise.
/// The centre entry is always kNoVertex. 2D uses the first 9 entries.
using LeafGrid = std::array<uint32_t, 27>;
LeafGrid leaf_grid(const Octree& octree, const OctreeVertices& vertices, uint32_t leaf);

}  // namespace gvd::octree
