#include "gvd/geometry/simplex_bvh.h"

#include <algorithm>
#include <exception>
#include <numeric>
#include <string>
#include <thread>

#include "gvd/common/cancel.h"
#include "gvd/common/error.h"
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

constexpr uint32_t kLeafSize = 4;
/// Items a build handles between two reads of the cancel flag (about 1 ms of work).
constexpr uint32_t kCancelGrain = 1u << 14;

// The number of nodes build_tree makes for n items (median splits down to kLeafSize), so the
// arrays are allocated once at their size.
size_t tree_nodes(uint32_t n) {
  if (n <= kLeafSize) return 1;
  return 1 + tree_nodes(n / 2) + tree_nodes(n - n / 2);
}

// Top-down median split along the largest axis of the centre bounds, in depth-first layout: a
// left child directly follows its parent, the parent stores the index of its right child.
// Leaf ranges index `items[begin, end)` (positions in that array). Appends to `nodes`. Reads
// `cancel` after every kCancelGrain items partitioned (`work` carries the count between calls).
template <class BoxOf, class CenterOf>
void build_tree(std::vector<uint32_t>& items, uint32_t begin, uint32_t end, BoxOf&& box_of,
                CenterOf&& center_of, std::vector<SimplexBvh::Node>& nodes,
                const std::atomic<bool>* cancel, uint32_t& work) {
  struct Frame {
    uint32_t begin, end, parent;  // parent: node whose `first` (right child) to set, or ~0
  };
  std::vector<Frame> stack;
  stack.push_back({begin, end, ~0u});
  while (!stack.empty()) {
    const Frame f = stack.back();
    stack.pop_back();
    work += f.end - f.begin;
    if (work >= kCancelGrain) {
      work = 0;
      throw_if_cancelled(cancel, "indexing the scene");
    }
    const uint32_t self = static_cast<uint32_t>(nodes.size());
    if (f.parent != ~0u) nodes[f.parent].first = self;
    nodes.push_back({});
    SimplexBvh::Node& node = nodes[self];
    Box box, cbox;
    for (uint32_t k = f.begin; k < f.end; ++k) {
      box.extend(box_of(items[k]));
      cbox.extend(center_of(items[k]));
    }
    for (int a = 0; a < 3; ++a) {
      node.lo[a] = box.lo[a];
      node.hi[a] = box.hi[a];
    }
    // Objects are not known here: mixed until the constructor fills them in.
    const bool leaf = f.end - f.begin <= kLeafSize;
    node.tag = item::gvd_node_tag(leaf ? f.end - f.begin : 0, SimplexBvh::kMixed);
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
    // Right subtree is pushed first so the left one (popped next) directly follows `self`.
    stack.push_back({mid, f.end, self});
    stack.push_back({f.begin, mid, ~0u});
  }
}

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
    if (i % kCancelGrain == 0) throw_if_cancelled(cancel, "indexing the scene");
    for (int k = 0; k < arity; ++k) boxes[i].extend(points[simplices[i].v[k]]);
    centers[i] = boxes[i].center();
  }
  // One tree per object (with object_of), for nearest_in_object: it never visits another
  // object's simplices. Built over simplex ids on a second thread while this one builds the
  // shared tree; its items become positions k in `order_` afterwards.
  uint32_t objects = 0;
  std::vector<uint32_t> start;
  std::exception_ptr object_error;
  std::thread object_builder;
  // Joins the second thread however this constructor is left.
  struct Joiner {
    std::thread& t;
    ~Joiner() {
      if (t.joinable()) t.join();
    }
  } joiner{object_builder};
  if (object_of.size() == m) {
    for (uint32_t o : object_of) objects = std::max(objects, o + 1);
    if (objects > kMaxObjects) {
      throw Error(ErrorCode::kLimitExceeded, "the scene has " + std::to_string(objects) +
                                                 " objects; the BVH indexes at most " +
                                                 std::to_string(kMaxObjects));
    }
    start.assign(objects + 1, 0);
    for (uint32_t s : object_of) ++start[s + 1];
    for (uint32_t o = 0; o < objects; ++o) start[o + 1] += start[o];
    object_items_.resize(m);
    {
      std::vector<uint32_t> fill(start.begin(), start.end() - 1);
      for (uint32_t s = 0; s < m; ++s) object_items_[fill[object_of[s]]++] = s;
    }
    object_root_.assign(objects, kNoRoot);
    size_t object_tree_nodes = 0;
    for (uint32_t o = 0; o < objects; ++o)
      if (start[o] < start[o + 1]) object_tree_nodes += tree_nodes(start[o + 1] - start[o]);
    object_nodes_.reserve(object_tree_nodes);
    auto build_objects = [&] {
      uint32_t work = 0;
      for (uint32_t o = 0; o < objects; ++o) {
        if (start[o] == start[o + 1]) continue;
        object_root_[o] = static_cast<uint32_t>(object_nodes_.size());
        build_tree(
            object_items_, start[o], start[o + 1],
            [&](uint32_t s) -> const Box& { return boxes[s]; },
            [&](uint32_t s) -> const Vec3& { return centers[s]; }, object_nodes_, cancel, work);
      }
    };
    if (m >= 4096) {
      object_builder = std::thread([build_objects, &object_error] {
        try {
          build_objects();
        } catch (...) {
          object_error = std::current_exception();
        }
      });
    } else {
      build_objects();
    }
  }
  order_.resize(m);
  std::iota(order_.begin(), order_.end(), 0u);
  nodes_.reserve(tree_nodes(m));
  uint32_t work = 0;
  build_tree(
      order_, 0, m, [&](uint32_t s) -> const Box& { return boxes[s]; },
      [&](uint32_t s) -> const Vec3& { return centers[s]; }, nodes_, cancel, work);
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
  if (object_of.size() == m) {
    object_in_order_.resize(m);
    for (uint32_t k = 0; k < m; ++k) object_in_order_[k] = object_of[order_[k]];
    // Children follow their parents in the array: one backward pass fills every node.
    for (size_t i = nodes_.size(); i-- > 0;) {
      Node& n = nodes_[i];
      const uint32_t count = node_count(n);
      uint32_t object;
      if (count > 0) {
        object = object_in_order_[n.first];
        for (uint32_t k = n.first + 1; k < n.first + count; ++k)
          if (object_in_order_[k] != object) object = kMixed;
      } else {
        const uint32_t l = node_object(nodes_[i + 1]), r = node_object(nodes_[n.first]);
        object = l == r ? l : kMixed;
      }
      n.tag = item::gvd_node_tag(count, object);
    }
    if (object_builder.joinable()) object_builder.join();
    if (object_error) std::rethrow_exception(object_error);
    std::vector<uint32_t> position(m);
    for (uint32_t k = 0; k < m; ++k) position[order_[k]] = k;
    for (uint32_t& item : object_items_) item = position[item];
  }
}

ClosestHit SimplexBvh::nearest_in_object(Vec3 p, uint32_t object, double max_dist2) const {
  GVD_CHECK(!object_in_order_.empty() || nodes_.empty(),
            "nearest_in_object needs the objects of the simplices at construction");
  if (object >= object_root_.size() || object_root_[object] == kNoRoot) return ClosestHit{};
  return to_closest_hit(item::gvd_bvh_nearest(
      dimension_, static_cast<uint32_t>(object_nodes_.size()), object_nodes_.data(),
      object_root_[object], object_items_.data(), order_.data(), corner_.data(), points_.data(),
      item::gvd_pt(p.x, p.y, p.z), max_dist2, item::GvdAcceptAll{0}));
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
  return closest_to_simplex_in_tree(q, nodes_, 0, nullptr, skip_object, max_dist2);
}

ClosestHit SimplexBvh::closest_to_simplex_in_object(const Vec3* q, uint32_t object,
                                                    double max_dist2) const {
  GVD_CHECK(!object_in_order_.empty() || nodes_.empty(),
            "closest_to_simplex_in_object needs the objects of the simplices at construction");
  ClosestHit none;
  none.dist2 = max_dist2;
  if (object >= object_root_.size() || object_root_[object] == kNoRoot) return none;
  return closest_to_simplex_in_tree(q, object_nodes_, object_root_[object], object_items_.data(),
                                    kMixed, max_dist2);
}

ClosestHit SimplexBvh::closest_to_simplex_in_tree(const Vec3* q, const std::vector<Node>& nodes,
                                                  uint32_t root, const uint32_t* items,
                                                  uint32_t skip_object, double max_dist2) const {
  ClosestHit best;
  best.dist2 = max_dist2;
  if (nodes.empty()) return best;
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

SimplexBvh::ObjectPair SimplexBvh::object_distance(uint32_t a, uint32_t b, double max_dist2) const {
  GVD_CHECK(!object_in_order_.empty() || nodes_.empty(),
            "object_distance needs the objects of the simplices at construction");
  ObjectPair best;
  best.dist2 = max_dist2;
  if (a >= object_root_.size() || b >= object_root_.size() || object_root_[a] == kNoRoot ||
      object_root_[b] == kNoRoot)
    return best;
  auto box_gap2 = [](const Box& x, const Box& y) {
    double d2 = 0;
    for (int i = 0; i < 3; ++i) {
      const double gap = std::max({x.lo[i] - y.hi[i], y.lo[i] - x.hi[i], 0.0});
      d2 += gap * gap;
    }
    return d2;
  };
  // The exact distance of two simplices (0 when they cross) and a closest pair.
  auto pair_distance = [&](uint32_t ka, uint32_t kb, Vec3& pa, Vec3& pb) {
    Vec3 p[3], q[3];
    load_corners(ka, p);
    load_corners(kb, q);
    if (arity_ == 2) {
      const double d2 = segment_segment_dist2_2d(p[0], p[1], q[0], q[1]);
      segment_segment_closest(Vec3{p[0].x, p[0].y, 0}, Vec3{p[1].x, p[1].y, 0},
                              Vec3{q[0].x, q[0].y, 0}, Vec3{q[1].x, q[1].y, 0}, pa, pb);
      return d2;
    }
    double d2 = 1e300;
    for (int e = 0; e < 3; ++e) {
      d2 = std::min(d2, segment_triangle_dist2(p[e], p[(e + 1) % 3], q[0], q[1], q[2]));
      d2 = std::min(d2, segment_triangle_dist2(q[e], q[(e + 1) % 3], p[0], p[1], p[2]));
    }
    simplex_simplex_closest(3, p, q, pa);
    pb = closest_point_on_triangle(pa, q[0], q[1], q[2]);
    return d2;
  };
  struct Entry {
    uint32_t na, nb;
    double dist2;
  };
  std::vector<Entry> stack;
  const uint32_t ra = object_root_[a], rb = object_root_[b];
  stack.push_back({ra, rb, box_gap2(node_box(object_nodes_[ra]), node_box(object_nodes_[rb]))});
  while (!stack.empty() && best.dist2 > 0) {
    const Entry entry = stack.back();
    stack.pop_back();
    // Boxes no nearer than the best pair cannot improve it (ties pruned: across a uniform
    // gap every facing pair ties).
    if (best.found ? entry.dist2 >= best.dist2 : entry.dist2 > best.dist2) continue;
    const Node& x = object_nodes_[entry.na];
    const Node& y = object_nodes_[entry.nb];
    if (node_count(x) > 0 && node_count(y) > 0) {
      for (uint32_t i = x.first; i < x.first + node_count(x); ++i) {
        const uint32_t ka = object_items_[i];
        Box ba;
        Vec3 c[3];
        load_corners(ka, c);
        for (int k = 0; k < arity_; ++k) ba.extend(c[k]);
        for (uint32_t j = y.first; j < y.first + node_count(y); ++j) {
          // The simplices' own boxes first: no nearer than the best pair, no exact test.
          Box bb;
          load_corners(object_items_[j], c);
          for (int k = 0; k < arity_; ++k) bb.extend(c[k]);
          if (best.found && box_gap2(ba, bb) >= best.dist2) continue;
          Vec3 pa, pb;
          const double d2 = pair_distance(object_items_[i], object_items_[j], pa, pb);
          if (d2 < best.dist2 || (!best.found && d2 <= best.dist2)) {
            best.dist2 = d2;
            best.on_a = pa;
            best.on_b = pb;
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
    for (Entry& c : children)
      c.dist2 = box_gap2(node_box(object_nodes_[c.na]), node_box(object_nodes_[c.nb]));
    if (children[0].dist2 < children[1].dist2) std::swap(children[0], children[1]);
    for (const Entry& c : children)  // the nearer one last: searched first
      if (best.found ? c.dist2 < best.dist2 : c.dist2 <= best.dist2) stack.push_back(c);
  }
  return best;
}

}  // namespace gvd
