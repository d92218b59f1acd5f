#pragma once

// SimplexBvh, the bounding volume hierarchy over a scene's simplices: exact closest points (on any
// simplex, within one object, or excluding some objects), least distances from a segment, a
// simplex or a whole object (exact up to rounding) and walks over the simplices whose boxes overlap
// a box. Built once in O(M log M), cancellable, gvd::Error past its size limits; then queried
// concurrently. Also ClosestHit and the closest-point and overlap tests of one simplex.

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <span>
#include <type_traits>
#include <vector>

#include "gvd/geometry/closest_point_item.h"
#include "gvd/geometry/primitives.h"
#include "gvd/geometry/simplex.h"
#include "gvd/geometry/vec.h"

namespace gvd {

/// Closest point on one simplex: exact point, its squared distance and the simplex index.
struct ClosestHit {
  Vec3 point;
  double dist2 = 1e300;
  uint32_t simplex = 0xFFFFFFFFu;
  bool found() const { return simplex != 0xFFFFFFFFu; }
};

/// Converts the per-item answer (closest_point_item.h) to a ClosestHit.
inline ClosestHit to_closest_hit(const item::GvdHit& h) {
  ClosestHit r;
  r.point = {h.x, h.y, h.z};
  r.dist2 = h.dist2;
  r.simplex = h.simplex;
  return r;
}

/// Closest point on simplex `s` (segment in 2D, triangle in 3D) to `p`.
Vec3 closest_point_on_simplex(int dimension, std::span<const Vec3> points, const Simplex& s,
                              Vec3 p);

/// Conservative overlap of simplex `s` with `box` inflated by `slack` (absolute): never false
/// when they touch (triangle_overlaps_box in 3D, segment_overlaps_box_2d in 2D).
bool simplex_overlaps_box(int dimension, std::span<const Vec3> points, const Simplex& s,
                          const Box& box, double slack);

/// Bounding volume hierarchy over the simplices of a scene for exact nearest-simplex queries.
/// Flat arrays (nodes in depth-first order), built once in O(M log M), queried concurrently.
class SimplexBvh {
 public:
  SimplexBvh() = default;
  /// Copies the vertices the simplices use (in the order the tree first meets them) and the
  /// simplices' indices into them, so the inputs need not outlive it. At most kMaxSimplices
  /// simplices and kMaxObjects objects (gvd::Error{kLimitExceeded}).
  /// With `object_of` (the object of every simplex), nodes remember when all their simplices
  /// belong to one object, which lets nearest_excluding skip those objects' subtrees, and the
  /// tree's top is built over whole objects where they lie apart, so that each such object's
  /// simplices fill one subtree, which the in-object queries walk (the others, nested in or
  /// interleaved with another, get a tree of their own).
  /// `cancel` (may be null) is read every few thousand simplices of the build: set, it stops
  /// with gvd::Error{kCancelled} (a 327k-triangle scene takes a few hundred ms to index).
  SimplexBvh(int dimension, std::span<const Vec3> points, std::span<const Simplex> simplices,
             std::span<const uint32_t> object_of = {}, const std::atomic<bool>* cancel = nullptr);

  /// The exact closest point on any simplex to `p`, searching only boxes nearer than the best
  /// hit so far and than `max_dist2` (pass a known upper bound to prune harder).
  ClosestHit nearest(Vec3 p, double max_dist2 = 1e300) const;

  /// Like `nearest`, but only among simplices for which `accept(simplex)` is true.
  template <class Accept>
  ClosestHit nearest_if(Vec3 p, Accept&& accept, double max_dist2 = 1e300) const;

  /// The least squared distance between segment [a, b] and any simplex (0 when the segment
  /// touches or crosses one), searching only boxes nearer than `max_dist2`; returns
  /// `max_dist2` when nothing is nearer. Exact up to rounding.
  double segment_distance2(Vec3 a, Vec3 b, double max_dist2 = 1e300) const;
  /// The least squared distance between a simplex q of the BVH's dimension (2D: segment
  /// q[0..1], 3D: triangle q[0..2]) and any of its simplices (0 when q crosses one), with
  /// the point of q where it is reached (`point`); not found when nothing is nearer than
  /// `max_dist2`. Exact up to rounding (simplex_simplex_closest). With `skip_object` (needs
  /// `object_of` at construction), that object's simplices are not candidates: the distance
  /// from one of its own simplices to the rest of the scene.
  ClosestHit closest_to_simplex(const Vec3* q, double max_dist2 = 1e300,
                                uint32_t skip_object = kMixed) const;
  /// Like closest_to_simplex, among the simplices of one object only (needs `object_of` at
  /// construction; walks that object's own tree).
  ClosestHit closest_to_simplex_in_object(const Vec3* q, uint32_t object,
                                          double max_dist2 = 1e300) const;
  /// The least squared distance between objects a and b (needs `object_of` at construction;
  /// 0 when they touch or intersect) and a closest pair of points, one on each (`on_a`,
  /// `on_b`; where they intersect, points of the crossing simplices). Both objects' trees are
  /// walked together, pairs of boxes farther apart than the best pair so far pruned. Exact up
  /// to rounding (segment/triangle distances with crossing tests). Not found when an object
  /// has no simplices or nothing is nearer than `max_dist2`. With `shift_a`, object a is
  /// taken as moved by it (its boxes and corners; `on_a` is then on the moved object): the
  /// distances of an exploded view's moving objects.
  struct ObjectPair {
    double dist2 = 1e300;
    Vec3 on_a, on_b;
    bool found = false;
  };
  ObjectPair object_distance(uint32_t a, uint32_t b, double max_dist2 = 1e300,
                             Vec3 shift_a = {}) const;
  /// The exact closest point on the simplices of objects other than excluded[0..count) (needs
  /// `object_of` at construction): subtrees holding only excluded objects are not entered,
  /// so it is cheap where those objects crowd the query point.
  ClosestHit nearest_excluding(Vec3 p, const uint32_t* excluded, int count,
                               double max_dist2 = 1e300) const;
  /// The exact closest point on the simplices of one object (needs `object_of` at
  /// construction).
  ClosestHit nearest_in_object(Vec3 p, uint32_t object, double max_dist2 = 1e300) const;
  /// Calls `visit(simplex)` for every simplex whose bounding box overlaps `box` (and for the
  /// other simplices of the BVH leaves holding one: callers test the simplex itself); with
  /// `skip_object` (needs `object_of` at construction), subtrees whose simplices all belong to
  /// that object are not entered (a pruning hint: its simplices in mixed leaves are visited).
  template <class Visit>
  void for_each_overlapping(const Box& box, Visit&& visit, uint32_t skip_object = kMixed) const;
  /// Like for_each_overlapping, but `visit(simplex)` returns false to stop the walk; returns
  /// false when it was stopped (a bounded gather: callers give up past a size).
  template <class Visit>
  bool visit_overlapping(const Box& box, Visit&& visit, uint32_t skip_object = kMixed) const;
  /// Calls `visit(simplex)` for every simplex of `object` whose bounding box overlaps `box`
  /// (needs `object_of` at construction); walks that object's own tree only.
  template <class Visit>
  void for_each_overlapping_in_object(uint32_t object, const Box& box, Visit&& visit) const;

  size_t memory_bytes() const;
  /// The objects the in-object queries walk a tree of their own for (the others walk the one
  /// subtree of the shared tree that holds exactly their simplices).
  uint32_t objects_with_own_tree() const;

  static constexpr uint32_t kMixed = GVD_MIXED;
  /// The node layout the walk and the OpenCL kernel read (closest_point_item.h: box, first
  /// index, `tag` packing the leaf's simplex count and the one object below).
  using Node = item::GvdBvhNode;
  /// A node's box, its simplex count (0: inner node) and the one object of its simplices
  /// (kMixed when they are several or the objects were not given).
  static Box node_box(const Node& n) {
    return {{n.lo[0], n.lo[1], n.lo[2]}, {n.hi[0], n.hi[1], n.hi[2]}};
  }
  static uint32_t node_count(const Node& n) { return item::gvd_node_count(&n); }
  static uint32_t node_object(const Node& n) { return item::gvd_node_object(&n); }
  /// Objects and simplices a BVH can index (the node's packed fields).
  static constexpr uint32_t kMaxObjects = (1u << 29) - 1;
  static constexpr uint32_t kMaxSimplices = 1u << 28;
  /// The flat arrays item::gvd_bvh_nearest walks, for the data-parallel closest-point twin
  /// and the OpenCL kernel (uploaded as they are): depth-first nodes whose leaf ranges index
  /// `order` (position k -> simplex index), `dimension` corner indices per position into
  /// `points`.
  std::span<const Node> nodes() const { return nodes_; }
  std::span<const uint32_t> order() const { return order_; }
  std::span<const uint32_t> corner() const { return corner_; }
  std::span<const item::GvdPoint> points() const { return points_; }
  int dimension() const { return dimension_; }

 private:
  int dimension_ = 3;
  std::vector<Node> nodes_;
  std::vector<uint32_t> order_;
  /// The simplices' vertices: `corner_` holds `arity_` indices into `points_` per simplex in
  /// `order_` sequence, and `points_` the vertices in the order those first use them, so a
  /// leaf's simplices and their shared vertices lie together in memory (36 B per triangle
  /// instead of 72 for a copy of every corner).
  std::vector<uint32_t> corner_;
  std::vector<item::GvdPoint> points_;
  /// The corners of the simplex at position k of `order_`.
  void load_corners(uint32_t k, Vec3* c) const {
    const uint32_t* v = &corner_[static_cast<size_t>(k) * arity_];
    for (int j = 0; j < arity_; ++j) c[j] = {points_[v[j]].x, points_[v[j]].y, points_[v[j]].z};
  }
  std::vector<uint32_t> object_in_order_;  ///< per simplex in `order_` sequence (if given)
  /// Per object (with object_of), the root of the tree the in-object queries walk: a node of
  /// the shared tree (flag kInShared) that holds exactly the object's simplices, or else of the
  /// object's own tree in `object_nodes_`, whose leaf ranges index `object_items_` (positions
  /// k in `order_`).
  std::vector<Node> object_nodes_;
  std::vector<uint32_t> object_root_;
  std::vector<uint32_t> object_items_;
  static constexpr uint32_t kNoRoot = 0xFFFFFFFFu;
  static constexpr uint32_t kInShared = 1u << 31;
  /// One object's tree: `nodes` from `root`; leaf ranges index `items`, or are positions in
  /// `order_` themselves when `items` is null. No nodes (exists() false) for an object without
  /// simplices (or with no objects given).
  struct ObjectTree {
    const Node* nodes = nullptr;
    uint32_t node_count = 0;
    uint32_t root = 0;
    const uint32_t* items = nullptr;
    bool exists() const { return nodes != nullptr; }
  };
  ObjectTree object_tree(uint32_t object) const;
  int arity_ = 3;

  /// item::gvd_bvh_nearest over the shared tree with `filter` (its gvd_walk_accepts and
  /// gvd_walk_skips: see the filters in simplex_bvh.cpp and nearest_if).
  template <class Filter>
  ClosestHit nearest_filtered(Vec3 p, Filter filter, double max_dist2) const {
    return to_closest_hit(item::gvd_bvh_nearest(
        dimension_, static_cast<uint32_t>(nodes_.size()), nodes_.data(), 0, nullptr, order_.data(),
        corner_.data(), points_.data(), item::gvd_pt(p.x, p.y, p.z), max_dist2, filter));
  }

  /// closest_to_simplex's search in one tree.
  ClosestHit closest_to_simplex_in_tree(const Vec3* q, const ObjectTree& tree, uint32_t skip_object,
                                        double max_dist2) const;
};

namespace bvh_detail {
/// nearest_if's filter: the simplex at position k is a candidate when `accept(order[k])`;
/// no subtree is skipped. Found by item::gvd_bvh_nearest through argument-dependent lookup.
template <class Accept>
struct AcceptSimplex {
  const uint32_t* order;
  Accept* accept;
  friend int gvd_walk_accepts(const AcceptSimplex& f, uint32_t k) {
    return (*f.accept)(f.order[k]) ? 1 : 0;
  }
  friend int gvd_walk_skips(const AcceptSimplex&, const item::GvdBvhNode*) { return 0; }
};
}  // namespace bvh_detail

template <class Accept>
ClosestHit SimplexBvh::nearest_if(Vec3 p, Accept&& accept, double max_dist2) const {
  using A = std::remove_reference_t<Accept>;
  return nearest_filtered(p, bvh_detail::AcceptSimplex<A>{order_.data(), &accept}, max_dist2);
}

template <class Visit>
void SimplexBvh::for_each_overlapping(const Box& box, Visit&& visit, uint32_t skip_object) const {
  if (nodes_.empty()) return;
  uint32_t stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& n = nodes_[stack[--top]];
    if (skip_object != kMixed && node_object(n) == skip_object) continue;
    bool overlap = true;
    for (int i = 0; i < 3; ++i)
      if (n.lo[i] > box.hi[i] || n.hi[i] < box.lo[i]) overlap = false;
    if (!overlap) continue;
    if (node_count(n) > 0) {
      for (uint32_t k = n.first; k < n.first + node_count(n); ++k) visit(order_[k]);
      continue;
    }
    const uint32_t self = static_cast<uint32_t>(&n - nodes_.data());
    stack[top++] = n.first;
    stack[top++] = self + 1;
  }
}

template <class Visit>
bool SimplexBvh::visit_overlapping(const Box& box, Visit&& visit, uint32_t skip_object) const {
  if (nodes_.empty()) return true;
  uint32_t stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& n = nodes_[stack[--top]];
    if (skip_object != kMixed && node_object(n) == skip_object) continue;
    bool overlap = true;
    for (int i = 0; i < 3; ++i)
      if (n.lo[i] > box.hi[i] || n.hi[i] < box.lo[i]) overlap = false;
    if (!overlap) continue;
    if (node_count(n) > 0) {
      for (uint32_t k = n.first; k < n.first + node_count(n); ++k)
        if (!visit(order_[k])) return false;
      continue;
    }
    const uint32_t self = static_cast<uint32_t>(&n - nodes_.data());
    stack[top++] = n.first;
    stack[top++] = self + 1;
  }
  return true;
}

template <class Visit>
void SimplexBvh::for_each_overlapping_in_object(uint32_t object, const Box& box,
                                                Visit&& visit) const {
  const ObjectTree tree = object_tree(object);
  if (!tree.exists()) return;
  uint32_t stack[128];
  int top = 0;
  stack[top++] = tree.root;
  while (top > 0) {
    const uint32_t self = stack[--top];
    const Node& n = tree.nodes[self];
    bool overlap = true;
    for (int i = 0; i < 3; ++i)
      if (n.lo[i] > box.hi[i] || n.hi[i] < box.lo[i]) overlap = false;
    if (!overlap) continue;
    if (node_count(n) > 0) {
      for (uint32_t i = n.first; i < n.first + node_count(n); ++i)
        visit(order_[tree.items != nullptr ? tree.items[i] : i]);
      continue;
    }
    stack[top++] = n.first;
    stack[top++] = self + 1;
  }
}

/// The objects that can be nearest to some point within `r` of `c`: the nearest one (at
/// distance d) and every other one within d + 2r of c (a point x there has d_k(x) >= d_k(c) - r
/// > d + r >= its nearest distance otherwise), nearest first, with their distances at c, a
/// little generous so that rounding never drops one. Needs `object_of` at the BVH's
/// construction. Returns how many (0 for an empty scene), or -1 when there are more than
/// `max`; `objects` and `dist` hold max + 1 entries.
int objects_in_reach(const SimplexBvh& bvh, std::span<const uint32_t> object_of, Vec3 c, double r,
                     int max, uint32_t* objects, double* dist);

}  // namespace gvd
