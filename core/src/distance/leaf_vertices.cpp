#include "gvd/distance/leaf_vertices.h"

#include <bit>
#include <cstring>

namespace gvd::distance {

using namespace gvd::octree;

void LeafVertices::keep_only(std::span<const uint32_t> leaves) {
  if (begin.empty()) return;
  const size_t n = slots.size();
  uint32_t k = 0;
  size_t next = 0;
  for (size_t leaf = 0; leaf < n; ++leaf) {
    const uint32_t lo = begin[leaf], hi = begin[leaf + 1];
    begin[leaf] = k;
    if (next < leaves.size() && leaves[next] == leaf) {
      // k <= lo: rows only move down, so a forward copy never overwrites what it reads next.
      std::memmove(vertex.data() + k, vertex.data() + lo, (hi - lo) * sizeof(uint32_t));
      k += hi - lo;
      ++next;
    } else {
      slots[leaf] = 0;
    }
  }
  begin[n] = k;
  vertex.resize(k);
}

LeafGrid LeafVertices::grid(const Octree& octree, const OctreeVertices& vertices,
                            uint32_t leaf) const {
  // Every leaf's corners are vertices: an empty mask is a row that was not kept.
  if (begin.empty() || slots[leaf] == 0) return leaf_grid(octree, vertices, leaf);
  LeafGrid g;
  g.fill(kNoVertex);
  uint32_t k = begin[leaf];
  for (uint32_t m = slots[leaf]; m != 0; m &= m - 1) g[std::countr_zero(m)] = vertex[k++];
  return g;
}

}  // namespace gvd::distance
