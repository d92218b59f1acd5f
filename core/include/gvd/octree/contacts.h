#pragma once

// Contact pairs: objects whose surfaces come within a tolerance of each other (normally one
// finest cell, which could never separate them). Refinement that only separates such a pair
// stops at the contact depth. find_contact_pairs takes BVH candidates and confirms each pair by
// exact distances, in O(M log M + candidate pairs); a set cancel flag stops it with
// gvd::Error{kCancelled}.

#include <atomic>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "gvd/common/flat_hash.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/scene/scene.h"

namespace gvd::octree {

/// Pairs of objects that touch or intersect: their surfaces come closer than a tolerance
/// (normally the finest cell, which could never separate them). Refinement that only serves
/// to separate such a pair stops at a contact depth instead of the depth limit, so touching
/// objects cost cells along their contact, not 2^depth of them.
class ContactPairs {
 public:
  ContactPairs() = default;
  explicit ContactPairs(const std::vector<std::pair<scene::ObjectId, scene::ObjectId>>& pairs);

  bool touching(scene::ObjectId a, scene::ObjectId b) const {
    if (a == b || set_.size() == 0) return false;
    if (a > b) std::swap(a, b);
    return set_.contains(uint64_t{a} << 32 | b);
  }
  /// The pairs, a < b, sorted.
  const std::vector<std::pair<scene::ObjectId, scene::ObjectId>>& pairs() const { return pairs_; }
  bool empty() const { return pairs_.empty(); }

 private:
  std::vector<std::pair<scene::ObjectId, scene::ObjectId>> pairs_;
  FlatMap64 set_;
};

/// The contact tolerance (unit domain) of an octree whose depth limit is `max_depth`: one
/// finest cell, the lattice's resolution. Pairs further apart are separated, by finest cells or
/// certified pair cells, and keep their true clearance; closer ones cannot be told from touching.
inline double contact_tolerance(int max_depth) { return std::ldexp(1.0, -max_depth); }

/// Finds the object pairs whose simplices come within `tolerance` (unit domain) of each other,
/// intersecting included. BVH candidates (boxes within the tolerance), then exact
/// segment/triangle distances; each pair is confirmed once. O(M log M + candidate pairs).
/// With `cancel`, a set flag stops it within one simplex's walk (gvd::Error{kCancelled}).
ContactPairs find_contact_pairs(const scene::UnitGeometry& geometry, const SimplexBvh& bvh,
                                double tolerance, int threads = 0,
                                const std::atomic<bool>* cancel = nullptr);

}  // namespace gvd::octree
