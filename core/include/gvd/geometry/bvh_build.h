#pragma once

// The one builder of the BVH node layout that item::gvd_bvh_nearest and the grid's per-item
// walk read (closest_point_item.h): SimplexBvh's trees and the uniform grid's per-object trees
// are both made by build_bvh_nodes.

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "gvd/common/cancel.h"
#include "gvd/geometry/closest_point_item.h"
#include "gvd/geometry/vec.h"

namespace gvd {

/// Items per BVH leaf (the median splits stop there).
inline constexpr uint32_t kBvhLeafSize = 4;
/// Items a build partitions between two reads of the cancel flag (about 1 ms of work).
inline constexpr uint32_t kBvhCancelGrain = 1u << 14;

/// The number of nodes build_bvh_nodes makes for n items, so that arrays can be allocated once
/// at their size. O(log n).
inline size_t bvh_node_count(uint32_t n) {
  if (n <= kBvhLeafSize) return 1;
  return 1 + bvh_node_count(n / 2) + bvh_node_count(n - n / 2);
}

/// Builds the tree of `items[begin, end)` and appends it to `nodes`: top-down median splits
/// along the largest axis of the items' centre bounds (`center_of(item)`), down to leaves of at
/// most kBvhLeafSize; each node's box holds its items' boxes (`box_of(item)`). Depth-first
/// layout: a left child directly follows its parent, an inner node's `first` is its right
/// child's index in `nodes`, a leaf's `first` the position of its first item in `items`
/// (reordered in place). Every node's object is kMixed (GVD_MIXED): callers that know objects
/// fill them in. Reads `cancel` (may be null) after every kBvhCancelGrain items partitioned,
/// `work` carrying the count between calls; set, it throws gvd::Error{kCancelled} naming
/// `stage`. O(n log n).
template <class BoxOf, class CenterOf>
void build_bvh_nodes(std::vector<uint32_t>& items, uint32_t begin, uint32_t end, BoxOf&& box_of,
                     CenterOf&& center_of, std::vector<item::GvdBvhNode>& nodes,
                     const std::atomic<bool>* cancel, uint32_t& work, const char* stage) {
  struct Frame {
    uint32_t begin, end, parent;  // parent: node whose `first` (right child) to set, or ~0
  };
  std::vector<Frame> stack;
  stack.push_back({begin, end, ~0u});
  while (!stack.empty()) {
    const Frame f = stack.back();
    stack.pop_back();
    work += f.end - f.begin;
    if (work >= kBvhCancelGrain) {
      work = 0;
      throw_if_cancelled(cancel, stage);
    }
    const uint32_t self = static_cast<uint32_t>(nodes.size());
    if (f.parent != ~0u) nodes[f.parent].first = self;
    nodes.push_back({});
    item::GvdBvhNode& node = nodes[self];
    Box box, cbox;
    for (uint32_t k = f.begin; k < f.end; ++k) {
      box.extend(box_of(items[k]));
      cbox.extend(center_of(items[k]));
    }
    for (int a = 0; a < 3; ++a) {
      node.lo[a] = box.lo[a];
      node.hi[a] = box.hi[a];
    }
    const bool leaf = f.end - f.begin <= kBvhLeafSize;
    node.tag = item::gvd_node_tag(leaf ? f.end - f.begin : 0, GVD_MIXED);
    if (leaf) {
      node.first = f.begin;
      continue;
    }
    const Vec3 ext = cbox.hi - cbox.lo;
    int axis = 0;
    if (ext.y > ext[axis]) axis = 1;
    if (ext.z > ext[axis]) axis = 2;
    const uint32_t mid = f.begin + (f.end - f.begin) / 2;
    std::nth_element(
        items.begin() + f.begin, items.begin() + mid, items.begin() + f.end,
        [&](uint32_t a, uint32_t b) { return center_of(a)[axis] < center_of(b)[axis]; });
    // The right half is pushed first so that the left one (popped next) directly follows `self`.
    stack.push_back({mid, f.end, self});
    stack.push_back({f.begin, mid, ~0u});
  }
}

}  // namespace gvd
