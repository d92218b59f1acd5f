#pragma once

// The simplices that touch each leaf of an octree: what the builds find on the way down
// (build_octree.h) and the refinement reads (refine/). Acceleration data, held beside the
// Octree rather than in it: a computation frees it once the refinement is over, and a result
// loaded from disk has none.

#include <cstdint>
#include <span>
#include <vector>

namespace gvd::octree {

/// Per leaf, the simplices that may intersect it (the builds' tests are conservative), as
/// compressed rows: leaf i's are index[begin[i] .. begin[i + 1]). Empty, or begin has
/// leaves + 1 entries.
struct LeafSimplices {
  std::vector<uint32_t> begin;
  std::vector<uint32_t> index;

  bool empty() const { return begin.empty(); }
  /// Whether the rows are those of an octree with `leaves` leaves.
  bool covers(size_t leaves) const { return begin.size() == leaves + 1; }
  std::span<const uint32_t> of(uint32_t leaf) const {
    return {index.data() + begin[leaf], begin[leaf + 1] - begin[leaf]};
  }
  void release() {
    std::vector<uint32_t>().swap(begin);
    std::vector<uint32_t>().swap(index);
  }
};

}  // namespace gvd::octree
