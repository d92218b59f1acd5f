// GvdIndex: point queries on the distance field (paper §4), k-rings on the dual graph (§7.3),
// roadmap paths on the GVD (§7.2), exploded views (§7.4) and the clearance report.
#include "gvd/query/gvd_index.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <mutex>
#include <numeric>
#include <queue>
#include <tuple>
#include <unordered_map>
#include <utility>

#include "gvd/common/error.h"
#include "gvd/common/parallel.h"
#include "gvd/geometry/primitives.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/octree/lattice.h"
#include "gvd/octree/vertices.h"
#include "gvd/query/explode_motion.h"

namespace gvd::query {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::distance;
using namespace gvd::surface;
using namespace gvd::graph;
using namespace gvd::result;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string format_point(Vec3 p, int dimension) {
  char buffer[128];
  if (dimension == 2) {
    std::snprintf(buffer, sizeof buffer, "(%.17g, %.17g)", p.x, p.y);
  } else {
    std::snprintf(buffer, sizeof buffer, "(%.17g, %.17g, %.17g)", p.x, p.y, p.z);
  }
  return buffer;
}

/// Compressed adjacency: neighbours of node i are target[begin[i] .. begin[i + 1]).
struct Csr {
  std::vector<uint32_t> begin;
  std::vector<uint32_t> target;
  std::vector<double> weight;  ///< per entry (edge length or area)
  std::vector<uint32_t> edge;  ///< per entry: index of the undirected edge (dual graph)
};

/// Orders lexicographically by coordinates (for merging identical GVD vertex copies).
bool position_less(Vec3 a, Vec3 b) {
  if (a.x != b.x) return a.x < b.x;
  if (a.y != b.y) return a.y < b.y;
  return a.z < b.z;
}

}  // namespace

struct GvdIndex::Impl {
  std::shared_ptr<const GvdResult> result;
  int dimension = 3;
  SimplexBvh bvh;
  std::vector<uint8_t> closed;  ///< per object: is_closed_object

  // Nearest: the exact closest point of every octree vertex (`closest`, shared, with its
  // object), and per leaf the distinct closest points of its boundary vertices.
  std::vector<Vec3> closest;
  std::vector<ObjectId> point_object;
  std::vector<uint32_t> vertex_point;
  std::vector<uint32_t> leaf_begin;
  std::vector<uint32_t> leaf_point;
  /// Per leaf and corner (2^D each): the exact distance of the corner vertex rounded down
  /// (-1 for a vertex no object reached).
  std::vector<float> corner_exact;
  /// Point location: the leaf holding the lower corner of every cell of level `table_level`
  /// (Morton order), so a query binary-searches only the leaves of one such cell.
  int table_level = 0;
  int table_shift = 0;
  std::vector<uint32_t> table;

  uint32_t locate(Vec3 u) const;

  // Dual graph adjacency (entry weight = interface area, edge = index into graph.edges) and,
  // per edge, the summed area-weighted normals of its interface pointing into a and into b.
  Csr dual;
  std::vector<Vec3> normal_into_a, normal_into_b;

  // Roadmap: the GVD's distinct vertices (user units) with clearance, its edges (weight =
  // length), and per object the roadmap vertices on its cell boundary.
  std::vector<Vec3> road_position;
  std::vector<double> road_clearance;
  Csr road;
  Csr object_road;  // node = object, target = roadmap vertex
  double max_clearance = 0;

  void build_nearest();
  void build_dual();
  void build_roadmap();
  // The nearest-point tables and the roadmap are built by the first query that needs them
  // (once, whichever thread asks): neighbours, explode and tight need neither, and on a
  // saved result of 1.2M leaves building them took ~2 s of every such CLI query.
  std::once_flag nearest_once, roadmap_once;
  void need_nearest() {
    std::call_once(nearest_once, [this] { build_nearest(); });
  }
  void need_roadmap() {
    std::call_once(roadmap_once, [this] { build_roadmap(); });
  }

  Vec3 to_unit(Vec3 p) const { return result->domain.to_unit(p); }
  /// Clearances up to this (user units) count as touching: rounding in the distance tests.
  double touching() const { return 1e-12 * result->domain.side; }
  void check_inside(Vec3 p, const char* what) const;
  /// Exact least distance (user units) from segment [a, b] (user units) to any object,
  /// or `stop` when it is at least `stop`.
  double segment_clearance(Vec3 a, Vec3 b, double stop = kInf) const;
  /// Whether the point (unit coordinates) is inside the closed object: the parity of the
  /// object's crossings with the ray from u towards -x (row_crosses_*: symbolically perturbed,
  /// so edges and vertices on the ray count consistently).
  bool inside_closed(Vec3 u, ObjectId object) const;
  /// Exact distance (user units) and nearest object of a point (user units), by the BVH.
  std::pair<double, ObjectId> exact_nearest(Vec3 p) const;
  /// Roadmap vertices joined to point p by a segment with clearance >= min_clearance, with
  /// that segment's clearance; at most `want` of the nearest ones of object `object`'s cell.
  std::vector<std::pair<uint32_t, double>> connect(Vec3 p, ObjectId object,
                                                   double min_clearance) const;
};

void GvdIndex::Impl::check_inside(Vec3 p, const char* what) const {
  const Domain& domain = result->domain;
  const int dim = dimension;
  for (int a = 0; a < dim; ++a) {
    if (!std::isfinite(p[a])) {
      throw Error(ErrorCode::kInvalidArgument, std::string(what) + " has a non-finite coordinate");
    }
  }
  if (domain.aligned()) {
    const Box box = domain.box();
    for (int a = 0; a < dim; ++a) {
      if (p[a] < box.lo[a] || p[a] > box.hi[a]) {
        throw Error(ErrorCode::kOutsideDomain,
                    std::string(what) + " " + format_point(p, dim) + " is outside the domain " +
                        format_point(box.lo, dim) + " .. " + format_point(box.hi, dim));
      }
    }
  } else if (!domain.contains(p)) {
    char side[32];
    std::snprintf(side, sizeof side, "%.17g", domain.side);
    throw Error(
        ErrorCode::kOutsideDomain,
        std::string(what) + " " + format_point(p, dim) + " is outside the domain, a cube of side " +
            side + " from " + format_point(domain.origin, dim) +
            " along the octree's axes (the scene's faces) " + format_point(domain.axis[0], dim) +
            ", " + format_point(domain.axis[1], dim) + ", " + format_point(domain.axis[2], dim));
  }
}

void GvdIndex::Impl::build_nearest() {
  const Octree& octree = result->octree;
  const DistanceField& field = result->field;
  const size_t leaves = octree.leaf_count();
  // About one table cell per two leaves (at most level 8 in 3D, 12 in 2D: 16M entries).
  const int dim = octree.dimension;
  table_level = 0;
  while (table_level < (dim == 3 ? 8 : 12) &&
         (uint64_t{1} << (dim * (table_level + 1))) <= std::max<size_t>(leaves / 2, 1)) {
    ++table_level;
  }
  table_shift = dim * (lattice_bits(dim) - table_level);
  const uint64_t cells = uint64_t{1} << (dim * table_level);
  table.resize(cells + 1);
  for (uint64_t c = 0; c < cells; ++c) {
    const auto it = std::upper_bound(octree.code.begin(), octree.code.end(), c << table_shift);
    table[c] = static_cast<uint32_t>(it - octree.code.begin() - 1);
  }
  table[cells] = static_cast<uint32_t>(leaves - 1);
  // Every vertex gets its exact closest point (the distance transform made only the vertices
  // near objects and near the GVD exact): better candidates, and exact corner distances for
  // the 3/2 certificate of `nearest`.
  const size_t nv = field.size();
  std::vector<ClosestHit> hits(nv);
  const int threads = resolve_threads(0);
  parallel_for(nv, threads, [&](size_t b, size_t e, int) {
    for (size_t v = b; v < e; ++v) {
      if (field.exact[v] || field.point[v] == kNoVertex) continue;
      const double d = field.distance(static_cast<uint32_t>(v));
      hits[v] = bvh.nearest(field.vertices.position(static_cast<uint32_t>(v)), d * d);
    }
  });
  closest = field.closest;
  point_object.assign(closest.size(), kNoObject);
  vertex_point.assign(field.point.begin(), field.point.end());
  for (size_t v = 0; v < nv; ++v) {
    if (field.point[v] != kNoVertex) point_object[field.point[v]] = field.label[v];
  }
  for (size_t v = 0; v < nv; ++v) {
    if (!hits[v].found()) continue;
    vertex_point[v] = static_cast<uint32_t>(closest.size());
    closest.push_back(hits[v].point);
    point_object.push_back(result->geometry.object_of[hits[v].simplex]);
  }
  hits = {};
  leaf_begin.assign(leaves + 1, 0);
  const int corners = 1 << octree.dimension;
  corner_exact.assign(leaves * static_cast<size_t>(corners), -1.0f);
  // The distinct closest points of a leaf's boundary vertices; returns their count.
  auto gather = [&](uint32_t leaf, uint32_t(&found)[27]) {
    const LeafGrid grid = field.grid(octree, leaf);
    uint32_t count = 0;
    for (uint32_t v : grid) {
      if (v == kNoVertex || vertex_point[v] == kNoVertex) continue;
      const uint32_t p = vertex_point[v];
      if (std::find(found, found + count, p) == found + count) found[count++] = p;
    }
    return std::pair{count, grid};
  };
  parallel_for(leaves, threads, [&](size_t b, size_t e, int) {
    uint32_t found[27];
    for (size_t leaf = b; leaf < e; ++leaf) {
      const auto [count, grid] = gather(static_cast<uint32_t>(leaf), found);
      leaf_begin[leaf + 1] = count;
      for (int k = 0; k < corners; ++k) {
        // Corner k (bit a = upper side along axis a) is grid entry 2 (x) + 6 (y) + 18 (z).
        const uint32_t v = grid[2 * (k & 1) + 6 * ((k >> 1) & 1) + 18 * ((k >> 2) & 1)];
        if (v == kNoVertex || vertex_point[v] == kNoVertex) continue;
        const double exact = dist(field.vertices.position(v), closest[vertex_point[v]]);
        const auto d = static_cast<float>(exact);
        corner_exact[leaf * static_cast<size_t>(corners) + k] =
            static_cast<double>(d) > exact ? std::nextafter(d, 0.0f) : d;
      }
    }
  });
  std::partial_sum(leaf_begin.begin(), leaf_begin.end(), leaf_begin.begin());
  leaf_point.resize(leaf_begin[leaves]);
  parallel_for(leaves, threads, [&](size_t b, size_t e, int) {
    uint32_t found[27];
    for (size_t leaf = b; leaf < e; ++leaf) {
      const uint32_t count = gather(static_cast<uint32_t>(leaf), found).first;
      std::copy(found, found + count, leaf_point.begin() + leaf_begin[leaf]);
    }
  });
}

uint32_t GvdIndex::Impl::locate(Vec3 u) const {
  const Octree& octree = result->octree;
  const uint64_t m = lattice::morton(dimension, lattice::from_unit(dimension, u));
  const uint64_t cell = m >> table_shift;
  const auto first = octree.code.begin() + table[cell];
  const auto last = octree.code.begin() + table[cell + 1] + 1;
  return static_cast<uint32_t>(std::upper_bound(first, last, m) - octree.code.begin() - 1);
}

void GvdIndex::Impl::build_dual() {
  const DualGraph& graph = result->graph;
  const uint32_t n = graph.node_count;
  dual.begin.assign(n + 1, 0);
  for (const DualEdge& e : graph.edges) {
    ++dual.begin[e.a + 1];
    ++dual.begin[e.b + 1];
  }
  std::partial_sum(dual.begin.begin(), dual.begin.end(), dual.begin.begin());
  dual.target.resize(dual.begin[n]);
  dual.weight.resize(dual.begin[n]);
  dual.edge.resize(dual.begin[n]);
  std::vector<uint32_t> fill(dual.begin.begin(), dual.begin.end() - 1);
  for (uint32_t i = 0; i < graph.edges.size(); ++i) {
    const DualEdge& e = graph.edges[i];
    for (const auto& [from, to] : {std::pair{e.a, e.b}, std::pair{e.b, e.a}}) {
      const uint32_t slot = fill[from]++;
      dual.target[slot] = to;
      dual.weight[slot] = e.area;
      dual.edge[slot] = i;
    }
  }
  // Interface normals: a simplex of cell D facing C has its normal pointing into D.
  normal_into_a.assign(graph.edges.size(), Vec3{});
  normal_into_b.assign(graph.edges.size(), Vec3{});
  const int arity = dimension == 2 ? 2 : 3;
  for (const GvdCell& cell : result->gvd.cells) {
    const ObjectId d = cell.object;
    for (size_t s = 0; s + arity <= cell.indices.size(); s += arity) {
      const ObjectId c = cell.other[cell.indices[s]];
      if (c == kNoObject || c == d) continue;
      const Vec3 p0 = cell.positions[cell.indices[s]];
      const Vec3 p1 = cell.positions[cell.indices[s + 1]];
      // n_t * A_t: half the cross product in 3D; the left normal times the length in 2D.
      const Vec3 weighted = arity == 3
                                ? cross(p1 - p0, cell.positions[cell.indices[s + 2]] - p0) * 0.5
                                : Vec3{-(p1.y - p0.y), p1.x - p0.x, 0};
      const ObjectId lo = std::min(c, d), hi = std::max(c, d);
      const auto it = std::lower_bound(graph.edges.begin(), graph.edges.end(), std::pair{lo, hi},
                                       [](const DualEdge& e, std::pair<ObjectId, ObjectId> key) {
                                         return std::pair{e.a, e.b} < key;
                                       });
      if (it == graph.edges.end() || it->a != lo || it->b != hi) continue;
      const size_t edge = static_cast<size_t>(it - graph.edges.begin());
      Vec3& into = d == lo ? normal_into_a[edge] : normal_into_b[edge];
      into = into + weighted;
    }
  }
}

void GvdIndex::Impl::build_roadmap() {
  const Gvd& gvd = result->gvd;
  const int arity = dimension == 2 ? 2 : 3;
  // Every vertex copy, merged by identical position (copies of one GVD vertex are identical).
  struct Copy {
    Vec3 p;
    uint32_t cell, vertex;
  };
  std::vector<Copy> copies;
  std::vector<uint32_t> cell_offset(gvd.cells.size() + 1, 0);
  for (size_t c = 0; c < gvd.cells.size(); ++c) {
    cell_offset[c + 1] = cell_offset[c] + static_cast<uint32_t>(gvd.cells[c].positions.size());
  }
  copies.reserve(cell_offset.back());
  for (uint32_t c = 0; c < gvd.cells.size(); ++c) {
    const GvdCell& cell = gvd.cells[c];
    for (uint32_t v = 0; v < cell.positions.size(); ++v)
      copies.push_back({cell.positions[v], c, v});
  }
  std::sort(copies.begin(), copies.end(),
            [](const Copy& a, const Copy& b) { return position_less(a.p, b.p); });
  std::vector<uint32_t> id_of(copies.size());
  for (size_t i = 0; i < copies.size(); ++i) {
    if (i == 0 || position_less(copies[i - 1].p, copies[i].p)) {
      road_position.push_back(copies[i].p);
      road_clearance.push_back(kInf);
    }
    const uint32_t id = static_cast<uint32_t>(road_position.size() - 1);
    const Copy& k = copies[i];
    id_of[cell_offset[k.cell] + k.vertex] = id;
    road_clearance[id] = std::min(road_clearance[id], gvd.cells[k.cell].clearance[k.vertex]);
  }
  copies = {};
  for (double c : road_clearance) max_clearance = std::max(max_clearance, c);

  // Edges of every simplex, deduplicated.
  std::vector<uint64_t> pairs;
  std::vector<uint64_t> object_vertex;  // (object << 32) | roadmap vertex
  for (uint32_t c = 0; c < gvd.cells.size(); ++c) {
    const GvdCell& cell = gvd.cells[c];
    const uint32_t base = cell_offset[c];
    for (size_t s = 0; s + arity <= cell.indices.size(); s += arity) {
      for (int k = 0; k < (arity == 2 ? 1 : 3); ++k) {
        uint32_t u = id_of[base + cell.indices[s + k]];
        uint32_t v = id_of[base + cell.indices[s + (k + 1) % arity]];
        if (u == v) continue;
        if (u > v) std::swap(u, v);
        pairs.push_back((static_cast<uint64_t>(u) << 32) | v);
      }
    }
    for (uint32_t v = 0; v < cell.positions.size(); ++v) {
      object_vertex.push_back((static_cast<uint64_t>(cell.object) << 32) | id_of[base + v]);
    }
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  const size_t n = road_position.size();
  road.begin.assign(n + 1, 0);
  for (uint64_t p : pairs) {
    ++road.begin[(p >> 32) + 1];
    ++road.begin[(p & 0xFFFFFFFFu) + 1];
  }
  std::partial_sum(road.begin.begin(), road.begin.end(), road.begin.begin());
  road.target.resize(road.begin[n]);
  road.weight.resize(road.begin[n]);
  std::vector<uint32_t> fill(road.begin.begin(), road.begin.end() - 1);
  for (uint64_t p : pairs) {
    const uint32_t u = static_cast<uint32_t>(p >> 32), v = static_cast<uint32_t>(p);
    const double length = dist(road_position[u], road_position[v]);
    road.target[fill[u]] = v;
    road.weight[fill[u]++] = length;
    road.target[fill[v]] = u;
    road.weight[fill[v]++] = length;
  }

  std::sort(object_vertex.begin(), object_vertex.end());
  object_vertex.erase(std::unique(object_vertex.begin(), object_vertex.end()), object_vertex.end());
  const size_t objects = result->scene.objects.size();
  object_road.begin.assign(objects + 1, 0);
  object_road.target.reserve(object_vertex.size());
  for (uint64_t ov : object_vertex) {
    ++object_road.begin[(ov >> 32) + 1];
    object_road.target.push_back(static_cast<uint32_t>(ov));
  }
  std::partial_sum(object_road.begin.begin(), object_road.begin.end(), object_road.begin.begin());
}

double GvdIndex::Impl::segment_clearance(Vec3 a, Vec3 b, double stop) const {
  const double side = result->domain.side;
  const double stop_unit = std::isfinite(stop) ? stop / side : 1e150;
  const double d2 = bvh.segment_distance2(to_unit(a), to_unit(b), stop_unit * stop_unit);
  return std::sqrt(d2) * side;
}

bool GvdIndex::Impl::inside_closed(Vec3 u, ObjectId object) const {
  const UnitGeometry& g = result->geometry;
  Box ray;
  ray.lo = {-1e300, u.y, u.z};
  ray.hi = u;
  bool odd = false;
  bvh.for_each_overlapping_in_object(object, ray, [&](uint32_t s) {
    const Simplex& t = g.simplices[s];
    double x = 0;
    const bool crosses = dimension == 2
                             ? row_crosses_segment(g.points[t.v[0]], g.points[t.v[1]], u.y, x)
                             : row_crosses_triangle(g.points[t.v[0]], g.points[t.v[1]],
                                                    g.points[t.v[2]], u.y, u.z, x);
    if (crosses && x < u.x) odd = !odd;
  });
  return odd;
}

std::pair<double, ObjectId> GvdIndex::Impl::exact_nearest(Vec3 p) const {
  const ClosestHit hit = bvh.nearest(to_unit(p));
  if (!hit.found()) return {kInf, kNoObject};
  return {std::sqrt(hit.dist2) * result->domain.side, result->geometry.object_of[hit.simplex]};
}

std::vector<std::pair<uint32_t, double>> GvdIndex::Impl::connect(Vec3 p, ObjectId object,
                                                                 double min_clearance) const {
  constexpr size_t kWant = 4;     // connections kept
  constexpr size_t kTries = 256;  // segments tested at most
  std::vector<std::pair<double, uint32_t>> order;
  auto add_cell = [&](ObjectId o) {
    for (uint32_t k = object_road.begin[o]; k < object_road.begin[o + 1]; ++k) {
      const uint32_t v = object_road.target[k];
      if (road_clearance[v] < min_clearance) continue;
      order.emplace_back(dist2(p, road_position[v]), v);
    }
  };
  add_cell(object);
  const size_t keep = std::min(order.size(), kTries);
  std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(keep), order.end());
  order.resize(keep);
  std::vector<std::pair<uint32_t, double>> out;
  const double need = std::max(min_clearance, touching());
  for (const auto& [d2, v] : order) {
    const double c = segment_clearance(p, road_position[v]);
    if (c > need || (c == need && need > touching())) out.emplace_back(v, c);
    if (out.size() == kWant) break;
  }
  return out;
}

GvdIndex::GvdIndex(std::shared_ptr<const GvdResult> result) : impl_(std::make_unique<Impl>()) {
  GVD_CHECK(result != nullptr, "GvdIndex needs a result");
  impl_->result = std::move(result);
  const GvdResult& r = *impl_->result;
  impl_->dimension = r.scene.dimension;
  impl_->bvh = SimplexBvh(r.geometry.dimension, r.geometry.points, r.geometry.simplices,
                          r.geometry.object_of);
  impl_->closed.resize(r.scene.objects.size());
  for (size_t o = 0; o < r.scene.objects.size(); ++o)
    impl_->closed[o] = is_closed_object(r.scene.objects[o], r.scene.dimension);
  impl_->build_dual();
}

GvdIndex::~GvdIndex() = default;
GvdIndex::GvdIndex(GvdIndex&&) noexcept = default;
GvdIndex& GvdIndex::operator=(GvdIndex&&) noexcept = default;

const GvdResult& GvdIndex::result() const { return *impl_->result; }
int GvdIndex::dimension() const { return impl_->dimension; }

ObjectId GvdIndex::object(std::string_view label) const {
  const std::optional<ObjectId> found = impl_->result->scene.find(std::string(label));
  if (!found) {
    throw Error(ErrorCode::kNotFound, "no object labelled '" + std::string(label) + "'",
                {.label = std::string(label)});
  }
  return *found;
}

bool GvdIndex::is_closed(ObjectId object) const {
  return object < impl_->closed.size() && impl_->closed[object] != 0;
}

int8_t GvdIndex::inside(Vec3 point, ObjectId object) const {
  if (!is_closed(object)) return -1;
  if (impl_->dimension == 2) point.z = 0;
  return impl_->inside_closed(impl_->to_unit(point), object) ? 1 : 0;
}

const SimplexBvh& GvdIndex::bvh() const { return impl_->bvh; }

NearestAnswer GvdIndex::nearest(Vec3 point, bool approximate) const {
  const Impl& m = *impl_;
  m.check_inside(point, "point");
  Vec3 p = point;
  if (m.dimension == 2) p.z = 0;
  const Vec3 u = m.to_unit(p);
  const double side = m.result->domain.side;
  NearestAnswer answer;
  answer.point = point;
  // The answer on `object` at `at` (unit coordinates), `d2` away (squared, unit).
  auto answer_at = [&](ObjectId object, Vec3 at, double d2, bool exact) {
    answer.object = object;
    answer.distance = std::sqrt(d2) * side;
    answer.closest = m.result->domain.from_unit(at);
    answer.exact = exact;
    if (m.closed[object]) answer.inside = m.inside_closed(u, object) ? 1 : 0;
    return answer;
  };
  if (!approximate) {
    // Exact: the BVH alone. Bounding it by the leaf's candidates (the fast path's tables)
    // measured no faster, and the tables cost ~1.2 us per leaf to build.
    const ClosestHit hit = m.bvh.nearest(u);
    GVD_CHECK(hit.found(), "a scene has at least one simplex");
    return answer_at(m.result->geometry.object_of[hit.simplex], hit.point, hit.dist2, true);
  }
  impl_->need_nearest();
  const uint32_t leaf = m.locate(u);
  const std::vector<Vec3>& closest = m.closest;
  double best = kInf;
  uint32_t best_point = kNoVertex;
  // Per object among the candidates: the nearest candidate (at most a few objects per leaf).
  constexpr int kMaxObjects = 4;
  ObjectId objects[kMaxObjects];
  double object_best[kMaxObjects];
  int object_count = 0;
  bool more_objects = false;  // candidates of more objects than kMaxObjects
  for (uint32_t k = m.leaf_begin[leaf]; k < m.leaf_begin[leaf + 1]; ++k) {
    const uint32_t c = m.leaf_point[k];
    const double d2 = dist2(u, closest[c]);
    if (d2 < best) {
      best = d2;
      best_point = c;
    }
    const ObjectId o = m.point_object[c];
    int i = 0;
    while (i < object_count && objects[i] != o) ++i;
    if (i == object_count && object_count < kMaxObjects) {
      objects[object_count] = o;
      object_best[object_count++] = d2;
    } else if (i == object_count) {
      more_objects = true;
    } else {
      object_best[i] = std::min(object_best[i], d2);
    }
  }
  const bool have = best_point != kNoVertex;
  ObjectId best_object = have ? m.point_object[best_point] : kNoObject;
  Vec3 best_at = have ? closest[best_point] : Vec3{};
  // The GVD crosses this leaf (its corners are nearest to different objects) and the point is
  // close to it: the exact query below decides, so answers do not flip sides of the Voronoi
  // boundary by the corners' approximation. Beside a junction of four or more objects too
  // (and always when there are more than the tracked ones).
  bool close_call = more_objects;
  if (object_count >= 2 && !close_call) {
    double first = kInf, second = kInf;
    for (int i = 0; i < object_count; ++i) {
      if (object_best[i] < first) {
        second = first;
        first = object_best[i];
      } else {
        second = std::min(second, object_best[i]);
      }
    }
    // Candidates of two objects within 2 % of each other: the point is near the boundary
    // between them, where the corners' approximation could pick the wrong side.
    constexpr double kClose = 0.02;
    close_call = std::sqrt(second) - std::sqrt(first) < kClose * std::sqrt(first);
  }
  // A lower bound of the true distance certifies the answer when 1.5 x bound >= answer: an
  // empty leaf holds no object, so the objects are at least as far as the leaf's boundary;
  // and an exact corner distance less the way to that corner. Tried cheapest first, the
  // nearest corner before the others, stopping at the first that certifies.
  const int dim = m.dimension;
  const double answer_distance = have ? std::sqrt(best) : 1e300;
  const double need = answer_distance / 1.5;
  const Octree& octree = m.result->octree;
  bool certified = have && octree.object[leaf] == kNoObject;
  if (have && !close_call && !certified) {
    const double size = std::ldexp(1.0, -octree.level[leaf]);
    const Vec3 lo = lattice::to_unit(dim, octree.corner(leaf));
    int nearest_corner = 0;
    double wall = 1e300;
    for (int a = 0; a < dim; ++a) {
      const double below = u[a] - lo[a], above = lo[a] + size - u[a];
      wall = std::min({wall, below, above});
      if (above < below) nearest_corner |= 1 << a;
    }
    certified = octree.object[leaf] == kNoObject && wall >= need;
    const int corners = 1 << dim;
    const float* exact = &m.corner_exact[leaf * static_cast<size_t>(corners)];
    for (int i = 0; i < corners && !certified; ++i) {
      const int k = i ^ nearest_corner;  // i = 0: the nearest corner
      if (exact[k] < 0) continue;
      Vec3 c = lo;
      for (int a = 0; a < dim; ++a) c[a] += ((k >> a) & 1) ? size : 0.0;
      certified = static_cast<double>(exact[k]) - dist(u, c) >= need;
    }
  }
  // Unless the answer is provably within 3/2 of the truth, ask the BVH for the exact nearest
  // point, searching only nearer than the answer so far.
  if (!certified) {
    const ClosestHit hit = m.bvh.nearest(u, have ? best * (1 + 1e-12) : 1e300);
    if (hit.found())
      return answer_at(m.result->geometry.object_of[hit.simplex], hit.point, hit.dist2, true);
    GVD_CHECK(have, "a scene has at least one simplex");
    // Nothing nearer than the answer so far: it is exact.
  }
  return answer_at(best_object, best_at, best, !certified);
}

std::vector<RingNeighbor> GvdIndex::neighbors(ObjectId object, int ring) const {
  const Impl& m = *impl_;
  const uint32_t n = m.result->graph.node_count;
  if (object >= n) {
    throw Error(ErrorCode::kNotFound, "no object with index " + std::to_string(object),
                {.object = static_cast<int64_t>(object)});
  }
  if (ring < 1) {
    throw Error(ErrorCode::kInvalidArgument,
                "ring must be at least 1 (got " + std::to_string(ring) + ")");
  }
  std::vector<int> depth(n, -1);
  std::vector<RingNeighbor> out;
  std::vector<uint32_t> frontier{object}, next;
  depth[object] = 0;
  for (int r = 1; r <= ring && !frontier.empty(); ++r) {
    next.clear();
    for (uint32_t from : frontier) {
      for (uint32_t k = m.dual.begin[from]; k < m.dual.begin[from + 1]; ++k) {
        const uint32_t to = m.dual.target[k];
        if (depth[to] >= 0) continue;
        depth[to] = r;
        next.push_back(to);
        const DualEdge& e = m.result->graph.edges[m.dual.edge[k]];
        out.push_back({to, r, from, e.area, e.min_clearance, e.tightest_point, e.gap, e.touching});
      }
    }
    std::swap(frontier, next);
  }
  std::sort(out.begin(), out.end(), [](const RingNeighbor& a, const RingNeighbor& b) {
    return std::pair{a.ring, a.object} < std::pair{b.ring, b.object};
  });
  return out;
}

int GvdIndex::max_ring(ObjectId object) const {
  const std::vector<RingNeighbor> all =
      neighbors(object, static_cast<int>(impl_->result->graph.node_count) + 1);
  return all.empty() ? 0 : all.back().ring;
}

PathAnswer GvdIndex::path(const PathQuery& query) const {
  impl_->need_roadmap();
  const Impl& m = *impl_;
  m.check_inside(query.from, "start");
  m.check_inside(query.to, "goal");
  if (!(query.min_clearance >= 0) || !std::isfinite(query.min_clearance)) {
    throw Error(ErrorCode::kInvalidArgument, "min_clearance must be a finite number >= 0");
  }
  Vec3 from = query.from, to = query.to;
  if (m.dimension == 2) from.z = to.z = 0;
  const Scene& scene = m.result->scene;
  PathAnswer answer;
  const double need = query.min_clearance;
  const auto [start_distance, start_object] = m.exact_nearest(from);
  const auto [goal_distance, goal_object] = m.exact_nearest(to);
  auto too_close = [&](double d, ObjectId o, const char* which) {
    if (d > m.touching() && d >= need) return false;
    answer.reason =
        std::string(which) +
        (d <= m.touching() ? " lies on object '" : " is closer than min_clearance to object '") +
        scene.objects[o].label + "'";
    return true;
  };
  if (too_close(start_distance, start_object, "start") ||
      too_close(goal_distance, goal_object, "goal")) {
    return answer;
  }
  const bool shortest = query.cost == PathCost::kShortest;
  auto weight = [&](double length, double clearance) {
    return shortest ? length : length / std::max(clearance, 1e-300);
  };
  const std::vector<std::pair<uint32_t, double>> start_links = m.connect(from, start_object, need);
  const std::vector<std::pair<uint32_t, double>> goal_links = m.connect(to, goal_object, need);

  // A* over the roadmap plus the start (node n) and the goal (node n + 1).
  const uint32_t n = static_cast<uint32_t>(m.road_position.size());
  const uint32_t start = n, goal = n + 1;
  const double c_max = std::max({m.max_clearance, start_distance, goal_distance});
  auto heuristic = [&](Vec3 p) { return shortest ? dist(p, to) : dist(p, to) / c_max; };
  auto position = [&](uint32_t v) {
    return v == start ? from : (v == goal ? to : m.road_position[v]);
  };
  // Per-thread search state reused across queries; a generation stamp marks the entries this
  // query wrote, so nothing is cleared per query (the roadmap can have millions of vertices).
  struct Search {
    std::vector<double> cost;
    std::vector<uint32_t> from;
    std::vector<uint32_t> stamp;
    uint32_t generation = 0;
  };
  thread_local Search search;
  if (search.stamp.size() < n + 2) {
    search.cost.resize(n + 2);
    search.from.resize(n + 2);
    search.stamp.assign(n + 2, 0);
    search.generation = 0;
  }
  if (++search.generation == 0) {
    std::fill(search.stamp.begin(), search.stamp.end(), 0);
    search.generation = 1;
  }
  const uint32_t generation = search.generation;
  auto touch = [&](uint32_t v) {
    if (search.stamp[v] != generation) {
      search.stamp[v] = generation;
      search.cost[v] = kInf;
      search.from[v] = kNoVertex;
    }
  };
  auto g_of = [&](uint32_t v) { return search.stamp[v] == generation ? search.cost[v] : kInf; };
  auto parent_of = [&](uint32_t v) {
    return search.stamp[v] == generation ? search.from[v] : kNoVertex;
  };
  std::unordered_map<uint32_t, double> goal_weight;  // roadmap vertex -> weight of its link
  for (const auto& [v, c] : goal_links) goal_weight[v] = weight(dist(to, m.road_position[v]), c);
  using Entry = std::pair<double, uint32_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
  auto relax = [&](uint32_t u, uint32_t v, double w) {
    const double through = g_of(u) + w;
    if (through < g_of(v)) {
      touch(v);
      search.cost[v] = through;
      search.from[v] = u;
      open.emplace(through + heuristic(position(v)), v);
    }
  };
  touch(start);
  search.cost[start] = 0;
  const double direct = m.segment_clearance(from, to);
  if (direct > m.touching() && direct >= need) relax(start, goal, weight(dist(from, to), direct));
  for (const auto& [v, c] : start_links) relax(start, v, weight(dist(from, m.road_position[v]), c));
  while (!open.empty()) {
    const auto [f, u] = open.top();
    open.pop();
    if (u == goal) break;
    if (f > g_of(u) + heuristic(position(u)) + 1e-12 * std::abs(f)) continue;  // stale entry
    if (const auto it = goal_weight.find(u); it != goal_weight.end()) relax(u, goal, it->second);
    for (uint32_t k = m.road.begin[u]; k < m.road.begin[u + 1]; ++k) {
      const uint32_t v = m.road.target[k];
      const double cv = m.road_clearance[v];
      if (cv < need) continue;
      const double c = std::min(m.road_clearance[u], cv);
      if (need > 0 && g_of(u) + m.road.weight[k] < g_of(v) &&
          m.segment_clearance(m.road_position[u], m.road_position[v], need) < need) {
        continue;  // the edge dips below the required clearance between its ends
      }
      relax(u, v, weight(m.road.weight[k], c));
    }
  }
  if (parent_of(goal) == kNoVertex) {
    if (start_links.empty()) {
      answer.reason = "start cannot reach the GVD without crossing an object (is it inside '" +
                      scene.objects[start_object].label + "'?)";
    } else if (goal_links.empty()) {
      answer.reason = "goal cannot reach the GVD without crossing an object (is it inside '" +
                      scene.objects[goal_object].label + "'?)";
    } else {
      answer.reason = need > 0 ? "no path joins start and goal with the required clearance"
                               : "no path joins start and goal (they are in separate regions)";
    }
    return answer;
  }
  for (uint32_t v = goal; v != kNoVertex; v = parent_of(v)) answer.points.push_back(position(v));
  std::reverse(answer.points.begin(), answer.points.end());
  answer.points.front() = query.from;
  answer.points.back() = query.to;
  answer.found = true;
  answer.min_clearance = kInf;
  for (size_t i = 0; i + 1 < answer.points.size(); ++i) {
    Vec3 a = answer.points[i], b = answer.points[i + 1];
    if (m.dimension == 2) a.z = b.z = 0;
    answer.length += dist(a, b);
    answer.min_clearance = std::min(answer.min_clearance, m.segment_clearance(a, b));
  }
  return answer;
}

ExplodedView GvdIndex::explode(ObjectId anchor, const ExplodeOptions& options) const {
  const Impl& m = *impl_;
  const DualGraph& graph = m.result->graph;
  const uint32_t n = graph.node_count;
  if (anchor >= n) {
    throw Error(ErrorCode::kNotFound, "no object with index " + std::to_string(anchor),
                {.object = static_cast<int64_t>(anchor)});
  }
  if (!std::isfinite(options.scale)) {
    throw Error(ErrorCode::kInvalidArgument, "scale must be a finite number");
  }
  ExplodedView view;
  view.anchor = anchor;
  view.scale = options.scale;
  if (view.scale <= 0) {  // a quarter of the mean object diagonal
    const Scene& scene = m.result->scene;
    double sum = 0;
    for (const SceneObject& o : scene.objects) {
      Box b;
      for (const Vec3& p : o.vertices) b.extend(p);
      if (!o.vertices.empty()) sum += dist(b.lo, b.hi);
    }
    view.scale = 0.25 * sum / static_cast<double>(std::max<size_t>(scene.objects.size(), 1));
  }
  view.objects.resize(n);
  for (uint32_t o = 0; o < n; ++o) view.objects[o].object = o;
  // Rings: breadth-first on the dual graph, each sorted by object.
  std::vector<std::vector<uint32_t>> rings{{anchor}};
  view.objects[anchor].ring = 0;
  for (;;) {
    std::vector<uint32_t> next;
    for (uint32_t from : rings.back()) {
      for (uint32_t k = m.dual.begin[from]; k < m.dual.begin[from + 1]; ++k) {
        const uint32_t to = m.dual.target[k];
        if (view.objects[to].ring >= 0) continue;
        view.objects[to].ring = static_cast<int>(rings.size());
        next.push_back(to);
      }
    }
    if (next.empty()) break;
    std::sort(next.begin(), next.end());
    rings.push_back(std::move(next));
  }
  // Ring by ring, object by object: pick a direction, keep the largest safe share of
  // scale * ring along it, and fix that motion for the objects after it (ExplodeMotion).
  ExplodeMotion motion(m.result->geometry, m.bvh, m.result->domain, graph, view.scale);
  auto unit_or_zero = [](Vec3 v) { return norm(v) > 1e-6 ? v * (1.0 / norm(v)) : Vec3{}; };
  for (size_t ring = 1; ring < rings.size(); ++ring) {
    const double length = view.scale * static_cast<double>(ring);
    for (uint32_t d : rings[ring]) {
      // The paper's D: the area-weighted mean over D's neighbours in ring - 1 of their
      // direction (D_i) or, for a neighbour that stays (the anchor: D_1), of the normal of
      // the shared interface pointing into D. `apart`: the area-weighted sum of the normals of
      // D's interfaces with its own ring (its ring-mates), pointing into D, away from them.
      Vec3 along, apart;
      double along_area = 0;
      std::vector<Vec3> mates;  // per neighbour in D's ring: unit normal pointing into D
      for (uint32_t k = m.dual.begin[d]; k < m.dual.begin[d + 1]; ++k) {
        const ExplodedObject& nb = view.objects[m.dual.target[k]];
        const uint32_t e = m.dual.edge[k];
        const double area = graph.edges[e].area;
        Vec3 into_d = graph.edges[e].a == d ? m.normal_into_a[e] : m.normal_into_b[e];
        if (m.dimension == 2) into_d.z = 0;
        if (nb.ring == static_cast<int>(ring) - 1) {
          along = along + (norm(nb.displacement) > 0 ? nb.direction * area : into_d);
          along_area += area;
        } else if (nb.ring == static_cast<int>(ring)) {
          apart = apart + into_d;
          if (norm(into_d) > 0) mates.push_back(unit_or_zero(into_d));
        }
      }
      if (along_area > 0) along = along * (1.0 / along_area);
      if (m.dimension == 2) along.z = 0;
      // Under an anchor that surrounds or carries the ring (balls in a box, gears in their
      // frame), D leans towards the ring's other objects. Drop, for each neighbour in the
      // ring, the part of a direction that points at it (twice over the neighbours) and keep
      // the rest as a unit direction (out through a box's opening: the mean normal's length
      // there only measures how much of the interface faced the walls); when less than a
      // tenth is left (a closed frame or shell), the direction says nothing.
      auto clear_of_mates = [&](Vec3 c) {
        const double before = norm(c);
        bool leaned = false;
        for (int pass = 0; pass < 2; ++pass) {
          for (const Vec3& n_k : mates) {
            if (const double lean = dot(c, n_k); lean < 0) {
              c = c - n_k * lean;
              leaned = true;
            }
          }
        }
        if (!leaned) return c;
        return norm(c) > 0.1 * before ? unit_or_zero(c) : Vec3{};
      };
      const Vec3 spread = clear_of_mates(unit_or_zero(apart));
      along = clear_of_mates(along);
      if (norm(along) <= 1e-6) along = Vec3{};
      // Candidates, in order: the paper's direction, it turned away from the ring-mates,
      // straight away from them. The paper's is kept unless another moves D at least twice
      // as far; between the others the farther wins, the earlier on a tie.
      const Vec3 candidates[] = {along, clear_of_mates(unit_or_zero(along + spread)), spread};
      ExplodedObject& e = view.objects[d];
      e.direction = Vec3{};
      e.factor = 1;  // nothing to move; held back (0, first candidate) until one is kept
      for (const Vec3& c : candidates) {
        if (norm(c) > 0) {
          e.direction = c;
          e.factor = 0;
          break;
        }
      }
      int best = -1;
      double best_kept = 0;  // kept share * |direction|
      for (int i = 0; i < 3; ++i) {
        const double bar = best == 0 ? 2 * best_kept : best_kept;
        if (!(norm(candidates[i]) > bar)) continue;  // cannot win even kept whole
        if (i > 0 && dist(candidates[i], candidates[i - 1]) < 1e-12) continue;  // tried
        const double share = motion.largest_share(d, candidates[i] * length);
        const double kept = share * norm(candidates[i]);
        if (kept > bar) {
          best = i;
          best_kept = kept;
          e.direction = candidates[i];
          e.factor = share;
        }
      }
      e.displacement = e.direction * (e.factor * length);
      motion.commit(d, e.displacement);
    }
  }
  return view;
}

std::vector<TightSpot> GvdIndex::tight(double below) const {
  if (!(below >= 0)) {
    throw Error(ErrorCode::kInvalidArgument, "the clearance bound must be a number >= 0");
  }
  std::vector<TightSpot> out;
  for (const DualEdge& e : impl_->result->graph.edges) {
    if (e.min_clearance < below) {
      out.push_back({e.a, e.b, e.min_clearance, e.tightest_point, e.gap, e.touching});
    }
  }
  std::sort(out.begin(), out.end(), [](const TightSpot& x, const TightSpot& y) {
    return std::tuple{x.min_clearance, x.a, x.b} < std::tuple{y.min_clearance, y.a, y.b};
  });
  return out;
}

}  // namespace gvd::query
