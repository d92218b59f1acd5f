#include "gvd/geometry/simplex_bvh.h"

#include <algorithm>
#include <exception>
#include <limits>
#include <numeric>
#include <string>
#include <thread>

#include "gvd/common/cancel.h"
#include "gvd/common/error.h"
#include "gvd/common/memory_account.h"
#include "gvd/geometry/bvh_build.h"
#include "gvd/geometry/primitives.h"

namespace gvd {

// The layouts the OpenCL kernel reads as they are (a mismatch would read garbage on the
// device, not fail).
static_assert(sizeof(SimplexBvh::Node) == 56 && sizeof(item::GvdPoint) == 24);

Vec3 closest_point_on_simplex(int dimension, std::span<const Vec3> points, const Simplex& s,
                              Vec3 p) {
  if (dimension == 2) return closest_point_on_segment(p, points[s.v[0]], points[s.v[1]]);
  return closest_point_on_triangle(p, points[s.v[0]], points[s.v[1]], points[s.v[2]]);
}

bool simplex_overlaps_box(int dimension, std::span<const Vec3> points, const Simplex& s,
                          const Box& box, double slack) {
  if (dimension == 2) return segment_overlaps_box_2d(points[s.v[0]], points[s.v[1]], box, slack);
  return triangle_overlaps_box(points[s.v[0]], points[s.v[1]], points[s.v[2]], box, slack);
}

namespace {

constexpr const char* kIndexing = "indexing the scene";

// nearest_excluding's filter: simplices of the excluded objects are no candidates, and
// subtrees whose simplices all belong to one of them are not entered (it is cheap where those
// objects crowd the query point). Found by item::gvd_bvh_nearest through argument-dependent
// lookup.
struct ExcludeObjects {
  const uint32_t* object_in_order;
  const uint32_t* excluded;
  int count;
  bool is_excluded(uint32_t object) const {
    return std::find(excluded, excluded + count, object) != excluded + count;
  }
  friend int gvd_walk_accepts(const ExcludeObjects& f, uint32_t k) {
    return f.is_excluded(f.object_in_order[k]) ? 0 : 1;
  }
  friend int gvd_walk_skips(const ExcludeObjects& f, const item::GvdBvhNode* node) {
    const uint32_t object = item::gvd_node_object(node);
    return object != SimplexBvh::kMixed && f.is_excluded(object) ? 1 : 0;
  }
};

// A node of the top of the shared tree, which is built over whole objects (plan_object_top):
// its simplices are positions [item_begin, item_end) of the leaf order; a block is indexed
// simplex by simplex below it (build_bvh_nodes), an inner node splits into the next node (left) and
// `right`'s.
struct TopNode {
  uint32_t item_begin, item_end;
  uint32_t parent;  // ~0 for the root
  bool right;       // the right child of `parent`
  bool block;
  Box box;
};

/// Object levels the top may have: with at most 27 levels of median splits below it, every
/// walk's path stays within GVD_BVH_STACK (64).
constexpr int kMaxObjectLevels = 24;

// The top of the shared tree, over whole objects, in depth-first order; fills `order` with the
// simplices grouped to match. Objects apart from each other get subtrees of their own, which
// the in-object queries then walk instead of a second tree of every object (15 of the 64-sphere
// lattice's 110 MB). A group of objects, sorted by their centres along the axis where those
// spread most, is split where the two halves' boxes overlap on that axis by at most half the
// narrower one's extent there (so each half's box is mostly its own), nearest half the
// simplices; a group no such split separates (nested or interleaved objects, or one object)
// becomes a block.
std::vector<TopNode> plan_object_top(std::span<const uint32_t> object_of, uint32_t objects,
                                     std::span<const Box> boxes, std::span<const Vec3> centers,
                                     std::vector<uint32_t>& order) {
  std::vector<uint32_t> count(objects, 0);
  std::vector<Box> box(objects), spread(objects);
  for (size_t s = 0; s < object_of.size(); ++s) {
    const uint32_t o = object_of[s];
    ++count[o];
    box[o].extend(boxes[s]);
    spread[o].extend(centers[s]);
  }
  std::vector<Vec3> centre(objects);
  std::vector<uint32_t> objs;
  for (uint32_t o = 0; o < objects; ++o) {
    centre[o] = spread[o].center();
    if (count[o] > 0) objs.push_back(o);
  }
  std::vector<TopNode> top;
  std::vector<uint32_t> block_of(objects, 0);
  struct Frame {
    uint32_t ob, oe, item_begin, parent;
    bool right;
    int depth;
  };
  std::vector<Frame> stack;
  stack.push_back({0, static_cast<uint32_t>(objs.size()), 0, ~0u, false, 0});
  while (!stack.empty()) {
    const Frame f = stack.back();
    stack.pop_back();
    uint32_t total = 0;
    TopNode node{f.item_begin, f.item_begin, f.parent, f.right, true, Box{}};
    Box centres;
    for (uint32_t i = f.ob; i < f.oe; ++i) {
      total += count[objs[i]];
      node.box.extend(box[objs[i]]);
      centres.extend(centre[objs[i]]);
    }
    node.item_end = f.item_begin + total;
    uint32_t split = 0;
    if (f.oe - f.ob >= 2 && f.depth < kMaxObjectLevels) {
      const Vec3 ext = centres.hi - centres.lo;
      int axis = 0;
      if (ext.y > ext[axis]) axis = 1;
      if (ext.z > ext[axis]) axis = 2;
      if (ext[axis] > 0) {
        std::sort(objs.begin() + f.ob, objs.begin() + f.oe, [&](uint32_t a, uint32_t b) {
          return centre[a][axis] < centre[b][axis] || (centre[a][axis] == centre[b][axis] && a < b);
        });
        // Of the splits whose halves' boxes overlap on the axis by at most half the narrower
        // one's extent there, the one whose left half is nearest half the simplices.
        const uint32_t k = f.oe - f.ob;
        std::vector<Box> suffix(k + 1);
        for (uint32_t i = k; i-- > 0;) {
          suffix[i] = suffix[i + 1];
          suffix[i].extend(box[objs[f.ob + i]]);
        }
        Box prefix;
        uint32_t left = 0, best_left = 0;
        uint64_t best = ~uint64_t{0};
        for (uint32_t i = 1; i < k; ++i) {
          prefix.extend(box[objs[f.ob + i - 1]]);
          left += count[objs[f.ob + i - 1]];
          const Box& rest = suffix[i];
          const double overlap = prefix.hi[axis] - rest.lo[axis];
          const double narrower =
              std::min(prefix.hi[axis] - prefix.lo[axis], rest.hi[axis] - rest.lo[axis]);
          if (overlap > 0.5 * narrower) continue;
          const uint64_t twice = left * uint64_t{2};
          const uint64_t off = twice > total ? twice - total : total - twice;
          if (off < best) {
            best = off;
            split = f.ob + i;
            best_left = left;
          }
        }
        if (split != 0) {
          node.block = false;
          const uint32_t self = static_cast<uint32_t>(top.size());
          top.push_back(node);
          // Right pushed first, so the left (popped next) directly follows its parent.
          stack.push_back({split, f.oe, f.item_begin + best_left, self, true, f.depth + 1});
          stack.push_back({f.ob, split, f.item_begin, self, false, f.depth + 1});
          continue;
        }
      }
    }
    for (uint32_t i = f.ob; i < f.oe; ++i) block_of[objs[i]] = static_cast<uint32_t>(top.size());
    top.push_back(node);
  }
  // Positions: a block's simplices in index order (one block over the whole scene, when no
  // split separates its objects, is the tree of the simplices alone, as without objects).
  std::vector<uint32_t> cursor(top.size());
  for (size_t t = 0; t < top.size(); ++t) cursor[t] = top[t].item_begin;
  order.assign(object_of.size(), 0);
  for (uint32_t s = 0; s < object_of.size(); ++s) order[cursor[block_of[object_of[s]]]++] = s;
  return top;
}

}  // namespace

SimplexBvh::SimplexBvh(int dimension, std::span<const Vec3> points,
                       std::span<const Simplex> simplices, std::span<const uint32_t> object_of,
                       const std::atomic<bool>* cancel)
    : dimension_(dimension) {
  if (simplices.size() > kMaxSimplices) {
    throw Error(ErrorCode::kLimitExceeded, "the scene has " + std::to_string(simplices.size()) +
                                               " simplices; the BVH indexes at most " +
                                               std::to_string(kMaxSimplices));
  }
  const uint32_t m = static_cast<uint32_t>(simplices.size());
  if (m == 0) return;
  const int arity = dimension == 2 ? 2 : 3;
  std::vector<Box> boxes(m);
  std::vector<Vec3> centers(m);
  for (uint32_t i = 0; i < m; ++i) {
    if (i % kBvhCancelGrain == 0) throw_if_cancelled(cancel, kIndexing);
    for (int k = 0; k < arity; ++k) boxes[i].extend(points[simplices[i].v[k]]);
    centers[i] = boxes[i].center();
  }
  uint32_t objects = 0;
  if (object_of.size() == m) {
    for (uint32_t o : object_of) objects = std::max(objects, o + 1);
    if (objects > kMaxObjects) {
      throw Error(ErrorCode::kLimitExceeded, "the scene has " + std::to_string(objects) +
                                                 " objects; the BVH indexes at most " +
                                                 std::to_string(kMaxObjects));
    }
  }
  auto box_of = [&](uint32_t s) -> const Box& { return boxes[s]; };
  auto center_of = [&](uint32_t s) -> const Vec3& { return centers[s]; };
  uint32_t work = 0;
  if (objects >= 2) {
    const std::vector<TopNode> top = plan_object_top(object_of, objects, boxes, centers, order_);
    size_t total = 0;
    for (const TopNode& t : top) total += t.block ? bvh_node_count(t.item_end - t.item_begin) : 1;
    nodes_.reserve(total);
    std::vector<uint32_t> at(top.size());
    for (size_t i = 0; i < top.size(); ++i) {
      const TopNode& t = top[i];
      at[i] = static_cast<uint32_t>(nodes_.size());
      if (t.right) nodes_[at[t.parent]].first = at[i];
      if (t.block) {
        build_bvh_nodes(order_, t.item_begin, t.item_end, box_of, center_of, nodes_, cancel, work,
                        kIndexing);
        continue;
      }
      Node n{};
      for (int a = 0; a < 3; ++a) {
        n.lo[a] = t.box.lo[a];
        n.hi[a] = t.box.hi[a];
      }
      n.tag = item::gvd_node_tag(0, kMixed);
      nodes_.push_back(n);
    }
  } else {
    order_.resize(m);
    std::iota(order_.begin(), order_.end(), 0u);
    nodes_.reserve(bvh_node_count(m));
    build_bvh_nodes(order_, 0, m, box_of, center_of, nodes_, cancel, work, kIndexing);
  }
  arity_ = arity;
  corner_.resize(static_cast<size_t>(m) * arity);
  {
    constexpr uint32_t kUnused = 0xFFFFFFFFu;
    std::vector<uint32_t> renumber(points.size(), kUnused);
    uint32_t used = 0;
    for (uint32_t k = 0; k < m; ++k) {
      for (int j = 0; j < arity; ++j) {
        uint32_t& v = renumber[simplices[order_[k]].v[j]];
        if (v == kUnused) v = used++;
        corner_[static_cast<size_t>(k) * arity + j] = v;
      }
    }
    points_.resize(used);
    for (size_t i = 0; i < points.size(); ++i)
      if (renumber[i] != kUnused)
        points_[renumber[i]] = item::gvd_pt(points[i].x, points[i].y, points[i].z);
  }
  if (object_of.size() != m) return;
  object_in_order_.resize(m);
  for (uint32_t k = 0; k < m; ++k) object_in_order_[k] = object_of[order_[k]];
  // Children follow their parents in the array: one backward pass fills every node's object
  // and counts the simplices below it.
  std::vector<uint32_t> below(nodes_.size());
  for (size_t i = nodes_.size(); i-- > 0;) {
    Node& n = nodes_[i];
    const uint32_t count = node_count(n);
    uint32_t object;
    if (count > 0) {
      object = object_in_order_[n.first];
      for (uint32_t k = n.first + 1; k < n.first + count; ++k)
        if (object_in_order_[k] != object) object = kMixed;
      below[i] = count;
    } else {
      const uint32_t l = node_object(nodes_[i + 1]), r = node_object(nodes_[n.first]);
      object = l == r ? l : kMixed;
      below[i] = below[i + 1] + below[n.first];
    }
    n.tag = item::gvd_node_tag(count, object);
  }
  // The tree the in-object queries walk, per object. Where a subtree of the shared tree holds
  // exactly the object's simplices (objects apart from the others: most scenes), that subtree
  // (the first such node in depth-first order is the highest). Otherwise a tree of the object's
  // own, so those queries never visit another object's simplices: a second tree of every
  // object was 15 of the 64-sphere lattice's 110 MB.
  std::vector<uint32_t> simplices_of(objects, 0);
  for (uint32_t o : object_of) ++simplices_of[o];
  object_root_.assign(objects, kNoRoot);
  for (uint32_t i = 0; i < nodes_.size(); ++i) {
    const uint32_t o = node_object(nodes_[i]);
    if (o != kMixed && object_root_[o] == kNoRoot && below[i] == simplices_of[o])
      object_root_[o] = i | kInShared;
  }
  below = {};
  std::vector<uint32_t> start(objects + 1, 0);
  for (uint32_t o = 0; o < objects; ++o) {
    const bool own = object_root_[o] == kNoRoot && simplices_of[o] > 0;
    start[o + 1] = start[o] + (own ? simplices_of[o] : 0);
  }
  if (start[objects] == 0) return;
  // Their items are positions k in `order_`, each object's in the order of its simplices'
  // indices (the order the tree's median splits start from).
  object_items_.resize(start[objects]);
  {
    std::vector<uint32_t> position(m);
    for (uint32_t k = 0; k < m; ++k) position[order_[k]] = k;
    std::vector<uint32_t> fill(start.begin(), start.end() - 1);
    for (uint32_t i = 0; i < m; ++i) {
      const uint32_t o = object_of[i];
      if (fill[o] < start[o + 1]) object_items_[fill[o]++] = position[i];
    }
  }
  // Two halves of the objects, by simplices, built on two threads into trees of their own and
  // then laid end to end (inner nodes' child indices moved with them).
  const uint32_t half = start[objects] / 2;
  const uint32_t split =
      static_cast<uint32_t>(std::upper_bound(start.begin(), start.end(), half) - start.begin() - 1);
  std::vector<Node> part[2];
  std::vector<uint32_t> root[2];
  auto build_objects = [&](int which, uint32_t from, uint32_t to) {
    uint32_t objects_work = 0;
    for (uint32_t o = from; o < to; ++o) {
      if (start[o] == start[o + 1]) continue;
      root[which].push_back(static_cast<uint32_t>(part[which].size()));
      build_bvh_nodes(
          object_items_, start[o], start[o + 1],
          [&](uint32_t k) -> const Box& { return boxes[order_[k]]; },
          [&](uint32_t k) -> const Vec3& { return centers[order_[k]]; }, part[which], cancel,
          objects_work, kIndexing);
    }
  };
  const bool threaded = start[objects] >= 4096;
  std::exception_ptr second_error;
  {
    std::thread second;
    // Joins the second thread however this block is left.
    struct Joiner {
      std::thread& t;
      ~Joiner() {
        if (t.joinable()) t.join();
      }
    } joiner{second};
    if (threaded) {
      second = std::thread([&, account = current_memory_account()] {
        const ScopedMemoryAccount charge(account);  // the caller's computation holds it
        try {
          build_objects(1, split, objects);
        } catch (...) {
          second_error = std::current_exception();
        }
      });
      build_objects(0, 0, split);
    } else {
      build_objects(0, 0, objects);
    }
  }
  if (second_error) std::rethrow_exception(second_error);
  object_nodes_.reserve(part[0].size() + part[1].size());
  size_t next_root[2] = {0, 0};
  for (uint32_t o = 0; o < objects; ++o) {
    if (start[o] == start[o + 1]) continue;
    const int which = threaded && o >= split ? 1 : 0;
    const uint32_t r = root[which][next_root[which]++];
    const uint32_t end = next_root[which] < root[which].size()
                             ? root[which][next_root[which]]
                             : static_cast<uint32_t>(part[which].size());
    const uint32_t offset = static_cast<uint32_t>(object_nodes_.size()) - r;
    object_root_[o] = r + offset;
    for (uint32_t i = r; i < end; ++i) {
      Node n = part[which][i];
      if (node_count(n) == 0) n.first += offset;
      object_nodes_.push_back(n);
    }
  }
}

uint32_t SimplexBvh::objects_with_own_tree() const {
  uint32_t n = 0;
  for (uint32_t r : object_root_) n += r != kNoRoot && (r & kInShared) == 0;
  return n;
}

SimplexBvh::ObjectTree SimplexBvh::object_tree(uint32_t object) const {
  if (object >= object_root_.size() || object_root_[object] == kNoRoot) return {};
  const uint32_t root = object_root_[object];
  if ((root & kInShared) != 0)
    return {nodes_.data(), static_cast<uint32_t>(nodes_.size()), root & ~kInShared, nullptr};
  return {object_nodes_.data(), static_cast<uint32_t>(object_nodes_.size()), root,
          object_items_.data()};
}

ClosestHit SimplexBvh::nearest_in_object(Vec3 p, uint32_t object, double max_dist2) const {
  GVD_CHECK(!object_in_order_.empty() || nodes_.empty(),
            "nearest_in_object needs the objects of the simplices at construction");
  const ObjectTree tree = object_tree(object);
  if (!tree.exists()) return ClosestHit{};
  return to_closest_hit(item::gvd_bvh_nearest(
      dimension_, tree.node_count, tree.nodes, tree.root, tree.items, order_.data(), corner_.data(),
      points_.data(), item::gvd_pt(p.x, p.y, p.z), max_dist2, item::GvdAcceptAll{0}));
}

ClosestHit SimplexBvh::nearest_excluding(Vec3 p, const uint32_t* excluded, int count,
                                         double max_dist2) const {
  GVD_CHECK(!object_in_order_.empty() || nodes_.empty(),
            "nearest_excluding needs the objects of the simplices at construction");
  return nearest_filtered(p, ExcludeObjects{object_in_order_.data(), excluded, count}, max_dist2);
}

size_t SimplexBvh::memory_bytes() const {
  return (nodes_.size() + object_nodes_.size()) * sizeof(Node) +
         (order_.size() + object_in_order_.size() + object_items_.size() + object_root_.size()) *
             sizeof(uint32_t) +
         corner_.size() * sizeof(uint32_t) + points_.size() * sizeof(Vec3);
}

}  // namespace gvd

namespace gvd {

ClosestHit SimplexBvh::nearest(Vec3 p, double max_dist2) const {
  return nearest_filtered(p, item::GvdAcceptAll{0}, max_dist2);
}

double SimplexBvh::segment_distance2(Vec3 a, Vec3 b, double max_dist2) const {
  double best = max_dist2;
  if (nodes_.empty()) return best;
  struct Entry {
    uint32_t node;
    double dist2;
  };
  Entry stack[128];
  int top = 0;
  stack[top++] = {0, segment_box_distance2_bound(a, b, node_box(nodes_[0]))};
  while (top > 0 && best > 0) {
    const Entry entry = stack[--top];
    if (entry.dist2 >= best) continue;
    const Node& n = nodes_[entry.node];
    if (node_count(n) > 0) {
      for (uint32_t k = n.first; k < n.first + node_count(n); ++k) {
        Vec3 c[3];
        load_corners(k, c);
        const double d2 = arity_ == 2 ? segment_segment_dist2_2d(a, b, c[0], c[1])
                                      : segment_triangle_dist2(a, b, c[0], c[1], c[2]);
        best = std::min(best, d2);
      }
      continue;
    }
    const uint32_t l = entry.node + 1, r = n.first;
    const double dl = segment_box_distance2_bound(a, b, node_box(nodes_[l]));
    const double dr = segment_box_distance2_bound(a, b, node_box(nodes_[r]));
    if (dl <= dr) {
      if (dr < best) stack[top++] = {r, dr};
      if (dl < best) stack[top++] = {l, dl};
    } else {
      if (dl < best) stack[top++] = {l, dl};
      if (dr < best) stack[top++] = {r, dr};
    }
  }
  return best;
}

ClosestHit SimplexBvh::closest_to_simplex(const Vec3* q, double max_dist2,
                                          uint32_t skip_object) const {
  GVD_CHECK(skip_object == kMixed || !object_in_order_.empty() || nodes_.empty(),
            "closest_to_simplex with a skipped object needs the objects of the simplices");
  if (nodes_.empty()) {
    ClosestHit none;
    none.dist2 = max_dist2;
    return none;
  }
  const ObjectTree whole{nodes_.data(), static_cast<uint32_t>(nodes_.size()), 0, nullptr};
  return closest_to_simplex_in_tree(q, whole, skip_object, max_dist2);
}

ClosestHit SimplexBvh::closest_to_simplex_in_object(const Vec3* q, uint32_t object,
                                                    double max_dist2) const {
  GVD_CHECK(!object_in_order_.empty() || nodes_.empty(),
            "closest_to_simplex_in_object needs the objects of the simplices at construction");
  ClosestHit none;
  none.dist2 = max_dist2;
  const ObjectTree tree = object_tree(object);
  if (!tree.exists()) return none;
  return closest_to_simplex_in_tree(q, tree, kMixed, max_dist2);
}

ClosestHit SimplexBvh::closest_to_simplex_in_tree(const Vec3* q, const ObjectTree& tree,
                                                  uint32_t skip_object, double max_dist2) const {
  ClosestHit best;
  best.dist2 = max_dist2;
  const Node* nodes = tree.nodes;
  const uint32_t* items = tree.items;
  const uint32_t root = tree.root;
  Box qb;
  for (int i = 0; i < arity_; ++i) qb.extend(q[i]);
  auto bound = [&](const Box& b) {
    double d2 = 0;
    for (int a = 0; a < 3; ++a) {
      const double gap = std::max({b.lo[a] - qb.hi[a], qb.lo[a] - b.hi[a], 0.0});
      d2 += gap * gap;
    }
    return d2;
  };
  struct Entry {
    uint32_t node;
    double dist2;
  };
  Entry stack[128];
  int top = 0;
  stack[top++] = {root, bound(node_box(nodes[root]))};
  while (top > 0 && best.dist2 > 0) {
    const Entry entry = stack[--top];
    if (entry.dist2 >= best.dist2) continue;
    const Node& n = nodes[entry.node];
    if (skip_object != kMixed && node_object(n) == skip_object) continue;
    if (node_count(n) > 0) {
      for (uint32_t i = n.first; i < n.first + node_count(n); ++i) {
        const uint32_t k = items != nullptr ? items[i] : i;
        if (skip_object != kMixed && object_in_order_[k] == skip_object) continue;
        Vec3 on, c[3];
        load_corners(k, c);
        const double d2 = simplex_simplex_closest(dimension_, q, c, on);
        if (d2 < best.dist2) {
          best.dist2 = d2;
          best.point = on;
          best.simplex = order_[k];
        }
      }
      continue;
    }
    const uint32_t l = entry.node + 1, r = n.first;
    const double dl = bound(node_box(nodes[l])), dr = bound(node_box(nodes[r]));
    if (dl <= dr) {
      if (dr < best.dist2) stack[top++] = {r, dr};
      if (dl < best.dist2) stack[top++] = {l, dl};
    } else {
      if (dl < best.dist2) stack[top++] = {l, dl};
      if (dr < best.dist2) stack[top++] = {r, dr};
    }
  }
  return best;
}

SimplexBvh::ObjectPair SimplexBvh::object_distance(uint32_t a, uint32_t b, double max_dist2,
                                                   Vec3 shift_a) const {
  GVD_CHECK(!object_in_order_.empty() || nodes_.empty(),
            "object_distance needs the objects of the simplices at construction");
  ObjectPair best;
  best.dist2 = max_dist2;
  const ObjectTree ta = object_tree(a), tb = object_tree(b);
  if (!ta.exists() || !tb.exists()) return best;
  auto item_a = [&](uint32_t i) { return ta.items != nullptr ? ta.items[i] : i; };
  auto item_b = [&](uint32_t i) { return tb.items != nullptr ? tb.items[i] : i; };
  auto box_gap2 = [](const Box& x, const Box& y) {
    double d2 = 0;
    for (int i = 0; i < 3; ++i) {
      const double gap = std::max({x.lo[i] - y.hi[i], y.lo[i] - x.hi[i], 0.0});
      d2 += gap * gap;
    }
    return d2;
  };
  // Object a's boxes and corners, moved by shift_a.
  auto box_a = [&](uint32_t node) {
    Box bx = node_box(ta.nodes[node]);
    bx.lo = bx.lo + shift_a;
    bx.hi = bx.hi + shift_a;
    return bx;
  };
  auto corners_a = [&](uint32_t k, Vec3* c) {
    load_corners(k, c);
    for (int i = 0; i < arity_; ++i) c[i] = c[i] + shift_a;
  };
  // The exact distance of two simplices (0 when they cross).
  auto pair_distance = [&](uint32_t ka, uint32_t kb) {
    Vec3 p[3], q[3];
    corners_a(ka, p);
    load_corners(kb, q);
    if (arity_ == 2) return segment_segment_dist2_2d(p[0], p[1], q[0], q[1]);
    double d2 = 1e300;
    for (int e = 0; e < 3; ++e) {
      d2 = std::min(d2, segment_triangle_dist2(p[e], p[(e + 1) % 3], q[0], q[1], q[2]));
      d2 = std::min(d2, segment_triangle_dist2(q[e], q[(e + 1) % 3], p[0], p[1], p[2]));
    }
    return d2;
  };
  // A closest pair of points of two simplices: only for a pair that is the best so far.
  auto pair_witness = [&](uint32_t ka, uint32_t kb, Vec3& pa, Vec3& pb) {
    Vec3 p[3], q[3];
    corners_a(ka, p);
    load_corners(kb, q);
    if (arity_ == 2) {
      segment_segment_closest(Vec3{p[0].x, p[0].y, 0}, Vec3{p[1].x, p[1].y, 0},
                              Vec3{q[0].x, q[0].y, 0}, Vec3{q[1].x, q[1].y, 0}, pa, pb);
      return;
    }
    simplex_simplex_closest(3, p, q, pa);
    pb = closest_point_on_triangle(pa, q[0], q[1], q[2]);
  };
  struct Entry {
    uint32_t na, nb;
    double dist2;
  };
  std::vector<Entry> stack;
  stack.push_back({ta.root, tb.root, box_gap2(box_a(ta.root), node_box(tb.nodes[tb.root]))});
  while (!stack.empty() && best.dist2 > 0) {
    const Entry entry = stack.back();
    stack.pop_back();
    // Boxes no nearer than the best pair cannot improve it (ties pruned: across a uniform
    // gap every facing pair ties).
    if (best.found ? entry.dist2 >= best.dist2 : entry.dist2 > best.dist2) continue;
    const Node& x = ta.nodes[entry.na];
    const Node& y = tb.nodes[entry.nb];
    if (node_count(x) > 0 && node_count(y) > 0) {
      for (uint32_t i = x.first; i < x.first + node_count(x); ++i) {
        const uint32_t ka = item_a(i);
        Box ba;
        Vec3 c[3];
        corners_a(ka, c);
        for (int k = 0; k < arity_; ++k) ba.extend(c[k]);
        for (uint32_t j = y.first; j < y.first + node_count(y); ++j) {
          // The simplices' own boxes first: no nearer than the best pair, no exact test.
          Box bb;
          load_corners(item_b(j), c);
          for (int k = 0; k < arity_; ++k) bb.extend(c[k]);
          if (best.found && box_gap2(ba, bb) >= best.dist2) continue;
          const double d2 = pair_distance(ka, item_b(j));
          if (d2 < best.dist2 || (!best.found && d2 <= best.dist2)) {
            best.dist2 = d2;
            pair_witness(ka, item_b(j), best.on_a, best.on_b);
            best.found = true;
          }
        }
      }
      continue;
    }
    // Open the inner node with the larger box (a leaf against an inner node: the inner one).
    auto extent = [](const Box& bx) { return norm2(bx.hi - bx.lo); };
    const bool open_a =
        node_count(y) > 0 || (node_count(x) == 0 && extent(node_box(x)) >= extent(node_box(y)));
    Entry children[2];
    if (open_a) {
      children[0] = {entry.na + 1, entry.nb, 0};
      children[1] = {x.first, entry.nb, 0};
    } else {
      children[0] = {entry.na, entry.nb + 1, 0};
      children[1] = {entry.na, y.first, 0};
    }
    for (Entry& c : children) c.dist2 = box_gap2(box_a(c.na), node_box(tb.nodes[c.nb]));
    if (children[0].dist2 < children[1].dist2) std::swap(children[0], children[1]);
    for (const Entry& c : children)  // the nearer one last: searched first
      if (best.found ? c.dist2 < best.dist2 : c.dist2 <= best.dist2) stack.push_back(c);
  }
  return best;
}

int objects_in_reach(const SimplexBvh& bvh, std::span<const uint32_t> object_of, Vec3 c, double r,
                     int max, uint32_t* objects, double* dist) {
  auto widen = [](double d) { return d * (1 + 1e-9) + 1e-15; };
  int n = 0;
  double reach2 = std::numeric_limits<double>::infinity();
  for (;;) {
    const ClosestHit hit = n == 0 ? bvh.nearest(c) : bvh.nearest_excluding(c, objects, n, reach2);
    if (!hit.found()) return n;
    if (n == max) return -1;
    objects[n] = object_of[hit.simplex];
    dist[n] = std::sqrt(hit.dist2);
    if (n == 0) reach2 = widen(dist[0] + 2 * r) * widen(dist[0] + 2 * r);
    ++n;
  }
}

}  // namespace gvd
