// Surfacing (paper §6): each leaf's pieces of the cell boundaries, from the field alone.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <tuple>
#include <unordered_map>

#include "cell_faces.h"
#include "gvd/common/error.h"
#include "gvd/common/flat_hash.h"
#include "gvd/common/parallel.h"
#include "gvd/common/radix_sort.h"
#include "gvd/geometry/symmetric_eigen.h"
#include "gvd/surface/extract_gvd.h"
#include "leaf_pieces.h"

namespace gvd::surface {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::distance;

namespace {

using detail::Piece;
using detail::SurfaceChunk;

// Where a cell's pieces go.
struct Sink {
  std::vector<Piece>& out;
};

// A bisector point on a polygon edge and the labels / positions of the edge's ends, in the
// polygon's cyclic order.
struct Spoke {
  Vec3 p;
  ObjectId label_a, label_b;
  uint64_t edge;  // the octree edge (smaller vertex index << 32 | larger)
  /// The spoke's identity: `edge`, with the top bit set for the second of two crossings on
  /// one edge (kSecondCrossing; vertex indices stay below 2^31).
  uint64_t id;
  int ring_edge;  // index i of the polygon edge (v[i], v[i+1]) it lies on
};
constexpr uint64_t kSecondCrossing = uint64_t{1} << 63;

// Where an octree edge whose ends carry one label crosses a bisector twice.
struct DoubleCrossing {
  Vec3 p[2];       // from the edge's smaller vertex index to the larger
  ObjectId inner;  // the object nearer between them
};

struct PolygonGvd {
  static constexpr int kMaxSpokes = 16;  // 8 polygon edges, at most two crossings each
  int n = 0;
  Spoke spokes[kMaxSpokes];
  Vec3 centroid;
  /// On a face perpendicular to the axis of an extruded pair cell (either side of it), with
  /// two spokes: the bisector curve traced between them, its points after spokes[0] and
  /// before spokes[1] (empty where the curve is straight).
  std::vector<Vec3> curve;
  /// Four or more spokes of two objects whose bisector is a graph over one axis of the face
  /// (a cone cell's roof, CellSurfacer::pair_spokes): the pieces of the bisector on the face,
  /// each between two spokes (in order along that axis; either end may come first, the
  /// emitters orient each piece by its spokes' labels), with their traced curves on traced
  /// faces. Empty otherwise.
  std::vector<std::array<int, 2>> pairs;
  std::vector<std::vector<Vec3>> pair_curves;
  /// On a face square to the axis of a junction cell on either side of it: the plane GVD of
  /// the face (SurfaceOptions::junction_face), its ends on the face's border moved onto the
  /// spokes. Segments between `jpoints`, `jleft` of each on its left seen from +axis.
  bool junction = false;
  std::vector<Vec3> jpoints;
  std::vector<std::array<uint32_t, 2>> jsegments;
  std::vector<std::array<ObjectId, 2>> jleft_right;
};

class CellSurfacer {
 public:
  /// Junction points (face and cell) are moved toward equidistance from at most this many
  /// objects (a regular array of equal parts ties eight at a corner); more keep the centroid.
  static constexpr int kMaxJunction = 8;

  /// `rows` (optional): the field's leaf vertices, read instead of key lookups.
  CellSurfacer(const Octree& octree, const DistanceField& field, const LeafVertices* rows,
               const UnitGeometry& geometry, const SimplexBvh& bvh, const SurfaceOptions& options)
      : octree_(octree),
        field_(field),
        rows_(rows != nullptr && rows->covers(octree.leaf_count()) ? rows : nullptr),
        geometry_(geometry),
        bvh_(bvh),
        dim_(octree.dimension),
        skew_direction_(options.skew_direction),
        junction_face_(options.junction_face) {
    for (size_t i = 0; i < octree.certified.size(); ++i) {
      any_extruded_ |= octree.certified[i] >= 2 && octree.certified[i] < kJunctionMark;
      any_cone_ |= cone_leaf(static_cast<uint32_t>(i));
      any_junction_ |= octree.certified[i] >= kJunctionMark && static_cast<bool>(junction_face_);
    }
  }

  /// The LeafGrid of a leaf: from its row of the field's leaf vertices where there is one.
  LeafGrid grid_of(uint32_t leaf) const {
    return rows_ != nullptr ? rows_->grid(octree_, field_.vertices, leaf)
                            : field_.grid(octree_, leaf);
  }

  // Eq. (1) places the bisector between the closest points of the edge's two ends, as if those
  // points stayed the closest ones all along the edge. Where the edge is long next to the
  // distance, they slide (on a cube's face, around a sphere) and the point can miss the true
  // bisector by a good part of the edge. There the point is refined (refine_bisector), once
  // per edge before surfacing (prepare); both cells of a face look up the same point.
  Vec3 bisector(uint32_t v0, uint32_t v1) const {
    if (v0 > v1) std::swap(v0, v1);
    const uint32_t i = refined_index_.find(uint64_t{v0} << 32 | v1);
    if (i != FlatMap64::kMissing) return refined_[i];
    const Vec3 p = detail::bisector_point(field_, v0, v1);
    return coarse(v0, v1, p) ? refine_bisector(v0, v1, p) : p;
  }

  // One parallel scan before surfacing: refines the bisector points of every coarse edge the
  // GVD crosses, so that surfacing looks them up instead of refining each edge once per face
  // using it, and lists the leaves that will emit pieces (active_leaves).
  void prepare(int threads) {
    if (any_cone_) find_double_crossings(threads);
    const size_t n = octree_.leaf_count();
    const size_t grain = 256;
    // One list per chunk, filled locally and moved in once (no shared vector written by
    // both threads); a small table of recent edges drops most repeats (an edge is seen from
    // up to four leaves, two faces each).
    std::vector<std::vector<uint64_t>> found((n + grain - 1) / grain);
    std::vector<std::vector<uint32_t>> active((n + grain - 1) / grain);
    const uint64_t limit = lattice::side_units(dim_);
    parallel_for(
        n, threads,
        [&](size_t b, size_t e, int) {
          std::vector<uint64_t> mine;
          std::vector<uint32_t> my_active;
          uint64_t recent[256];
          std::fill(std::begin(recent), std::end(recent), ~0ull);
          for (size_t leaf = b; leaf < e; ++leaf) {
            bool mixed = false;
            if (rows_ != nullptr) {  // from the leaf's row: no grid to build
              const std::span<const uint32_t> row = rows_->of(static_cast<uint32_t>(leaf));
              const uint32_t* vb = row.data();
              const uint32_t* ve = vb + row.size();
              for (const uint32_t* v = vb; v != ve; ++v)
                mixed |= field_.label[*v] != field_.label[*vb];
            } else {
              const LeafGrid grid = grid_of(static_cast<uint32_t>(leaf));
              for (uint32_t v : grid)
                mixed |= v != kNoVertex && field_.label[v] != field_.label[grid[0]];
            }
            if (!mixed && !doubles_.empty())
              mixed =
                  touches_double(static_cast<uint32_t>(leaf), grid_of(static_cast<uint32_t>(leaf)));
            bool on_domain = false;
            if (!mixed) {
              const lattice::Coord c = octree_.corner(static_cast<uint32_t>(leaf));
              const uint64_t size = lattice::cell_size(dim_, octree_.level[leaf]);
              for (int a = 0; a < dim_; ++a) on_domain |= c.c[a] == 0 || c.c[a] + size == limit;
            }
            if (mixed || on_domain) my_active.push_back(static_cast<uint32_t>(leaf));
            if (!mixed) continue;
            const bool certified = octree_.is_certified(static_cast<uint32_t>(leaf));
            const LeafGrid grid = grid_of(static_cast<uint32_t>(leaf));
            detail::for_each_face_polygon(
                octree_, grid, static_cast<uint32_t>(leaf), [&](const detail::FacePolygon& poly) {
                  for (int i = 0; i < poly.n; ++i) {
                    uint32_t v = poly.v[i], w = poly.v[(i + 1) % poly.n];
                    if (field_.label[v] == field_.label[w]) continue;
                    if (v > w) std::swap(v, w);
                    const uint64_t key = uint64_t{v} << 32 | w;
                    uint64_t& slot = recent[(key * 0x9e3779b97f4a7c15ull) >> 56];
                    if (slot == key) continue;
                    slot = key;
                    // In a certified pair cell the ends' closest points can lie on other
                    // parts of the pair (rims, mirror images) than the bisector's: refine.
                    if (certified || coarse(v, w, detail::bisector_point(field_, v, w)))
                      mine.push_back(key);
                  }
                });
          }
          found[b / grain] = std::move(mine);
          active[b / grain] = std::move(my_active);
        },
        grain);
    active_.clear();
    for (const auto& a : active) active_.insert(active_.end(), a.begin(), a.end());
    std::vector<uint64_t> keys;
    for (auto& f : found) keys.insert(keys.end(), f.begin(), f.end());
    radix_sort(
        keys, [](uint64_t k) { return k; }, threads);
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    refined_.resize(keys.size());
    parallel_for(
        keys.size(), threads,
        [&](size_t b, size_t e, int) {
          for (size_t i = b; i < e; ++i) {
            const auto v = static_cast<uint32_t>(keys[i] >> 32), w = static_cast<uint32_t>(keys[i]);
            refined_[i] = refine_bisector(v, w, detail::bisector_point(field_, v, w));
          }
        },
        64);
    refined_index_ = FlatMap64(keys.size());
    for (size_t i = 0; i < keys.size(); ++i)
      refined_index_.insert(keys[i], static_cast<uint32_t>(i));
    refined_count_ = keys.size();
    if (any_extruded_) trace_curves(threads);
  }

  // The curves of all traced faces, each once: from the extruded leaf below the face (side 2),
  // or from the one above when the leaf below does not trace it.
  void trace_curves(int threads) {
    const size_t n = octree_.leaf_count();
    const size_t grain = 256;
    std::vector<std::vector<Curve>> found((n + grain - 1) / grain);
    parallel_for(
        n, threads,
        [&](size_t b, size_t e, int) {
          std::vector<Curve> mine;
          for (size_t i = b; i < e; ++i) {
            const uint32_t leaf = static_cast<uint32_t>(i);
            if (!extruded_leaf(leaf)) continue;
            const LeafGrid grid = grid_of(leaf);
            detail::for_each_face_polygon(octree_, grid, leaf, [&](const detail::FacePolygon& p) {
              if (!traces(leaf, p.axis)) return;
              const PolygonGvd g = paired_polygon(leaf, p);
              if (g.n != 2 && g.pairs.empty()) return;
              if (p.side == 0 && !p.on_domain && leaf_across_traces(p)) return;
              auto add = [&](const Spoke& s0, const Spoke& s1) {
                const bool forward = s0.id < s1.id;
                const Spoke& lo = forward ? s0 : s1;
                const Spoke& hi = forward ? s1 : s0;
                mine.push_back({lo.id, hi.id, trace_curve(p, lo, hi)});
              };
              if (g.n == 2) add(g.spokes[0], g.spokes[1]);
              for (const auto& [k0, k1] : g.pairs) add(g.spokes[k0], g.spokes[k1]);
            });
          }
          found[b / grain] = std::move(mine);
        },
        grain);
    for (auto& f : found)
      for (Curve& c : f) {
        const uint64_t h = curve_hash(c.lo, c.hi);
        if (curve_index_.count(h) == 0) {
          curve_index_.emplace(h, curves_.size());
          curves_.push_back(std::move(c));
        }
      }
  }
  // A cone cell (pair_certificate.h: an extruded pair whose gradients straddle an axis m of
  // the cross-section): its bisector C is a graph over m, and a line along m beside the apex
  // of C's roof meets C twice. Where that line is an octree edge, its ends carry the same
  // label and the labels alone show no crossing. Such edges of cone cells are found here,
  // once and exactly, before surfacing; every cell with the edge (cone or not) then gets both
  // spokes (polygon).
  bool cone_leaf(uint32_t leaf) const { return octree_.cone_axis(leaf) >= 0; }

  // Whether junction leaf `leaf` sweeps as it stands (cell_3d would take junction_cell).
  bool junction_sweeps_as_it_stands(uint32_t leaf) const {
    const LeafGrid grid = grid_of(leaf);
    bool mixed = false;
    for (uint32_t v : grid)
      if (v != kNoVertex && field_.label[v] != field_.label[grid[0]]) mixed = true;
    if (!mixed) return true;
    detail::FacePolygon polys[24];
    PolygonGvd gvds[24];
    int np = 0;
    detail::for_each_face_polygon(octree_, grid, leaf, [&](const detail::FacePolygon& p) {
      polys[np] = p;
      gvds[np] = polygon(leaf, p);
      ++np;
    });
    std::vector<Piece> scratch;
    Sink sink{scratch};
    return junction_cell(leaf, polys, gvds, np, sink);
  }
  // An extruded pair cell of any kind (along an axis, slanted or skew; cones included), whose
  // curves on its traced faces are traced and whose sheet is a ladder between them. Skew
  // cells only when the caller can give their direction.
  bool extruded_leaf(uint32_t leaf) const {
    return octree_.extruded_axis(leaf) >= 0 || octree_.slanted_axis(leaf) >= 0 ||
           (octree_.is_skew(leaf) && static_cast<bool>(skew_direction_));
  }

  void find_double_crossings(int threads) {
    const size_t n = octree_.leaf_count();
    const size_t grain = 256;
    // (edge, the object nearer between its crossings) from every cone leaf.
    std::vector<std::vector<std::pair<uint64_t, ObjectId>>> found((n + grain - 1) / grain);
    parallel_for(
        n, threads,
        [&](size_t b, size_t e, int) {
          std::vector<std::pair<uint64_t, ObjectId>> mine;
          for (size_t i = b; i < e; ++i) {
            const uint32_t leaf = static_cast<uint32_t>(i);
            bool twice = false;
            const unsigned axes = octree_.straddled_axes(leaf, &twice);
            if (axes == 0 || !twice) continue;
            const LeafGrid grid = grid_of(leaf);
            ObjectId pair[2] = {kNoObject, kNoObject};
            bool many = false;
            for (uint32_t v : grid) {
              if (v == kNoVertex) continue;
              const ObjectId l = field_.label[v];
              if (pair[0] == kNoObject || pair[0] == l) {
                pair[0] = l;
              } else if (pair[1] == kNoObject || pair[1] == l) {
                pair[1] = l;
              } else {
                many = true;
              }
            }
            if (many || pair[0] == kNoObject || pair[0] == kManyObjects) continue;
            if (pair[1] == kNoObject) {
              // One label at every vertex: the cell's other object is the nearest one besides.
              const uint32_t excluded = pair[0];
              const ClosestHit h = bvh_.nearest_excluding(octree_.box(leaf).center(), &excluded, 1);
              if (!h.found()) continue;
              pair[1] = geometry_.object_of[h.simplex];
            }
            detail::for_each_face_polygon(octree_, grid, leaf, [&](const detail::FacePolygon& p) {
              for (int k = 0; k < p.n; ++k) {
                uint32_t v = p.v[k], w = p.v[(k + 1) % p.n];
                if (field_.label[v] != field_.label[w]) continue;
                // Only along the straddled axes m: along the cell's axis C x e meets an edge
                // nowhere or all along, and along the others d_a - d_b is monotone.
                const Vec3 pv = field_.vertices.position(v), pw = field_.vertices.position(w);
                int m = 0;
                while (m < 2 && pv[m] == pw[m]) ++m;
                if ((axes >> m & 1u) == 0) continue;
                if (v > w) std::swap(v, w);
                mine.push_back(
                    {uint64_t{v} << 32 | w, field_.label[v] == pair[0] ? pair[1] : pair[0]});
              }
            });
          }
          found[b / grain] = std::move(mine);
        },
        grain);
    std::vector<std::pair<uint64_t, ObjectId>> edges;
    for (auto& f : found) edges.insert(edges.end(), f.begin(), f.end());
    std::sort(edges.begin(), edges.end());
    edges.erase(std::unique(edges.begin(), edges.end(),
                            [](const auto& x, const auto& y) { return x.first == y.first; }),
                edges.end());
    std::vector<DoubleCrossing> crossing(edges.size());
    std::vector<uint8_t> twice(edges.size(), 0);
    parallel_for(
        edges.size(), threads,
        [&](size_t b, size_t e, int) {
          for (size_t i = b; i < e; ++i)
            twice[i] = two_crossings(edges[i].first, edges[i].second, crossing[i]);
        },
        64);
    doubles_.clear();
    std::vector<uint64_t> keys;
    for (size_t i = 0; i < edges.size(); ++i) {
      if (!twice[i]) continue;
      doubles_.push_back(crossing[i]);
      keys.push_back(edges[i].first);
    }
    double_index_ = FlatMap64(keys.size());
    for (size_t i = 0; i < keys.size(); ++i)
      double_index_.insert(keys[i], static_cast<uint32_t>(i));
  }

  // Whether edge v0 < v1 (both labelled `outer`) meets the bisector of outer and `inner`
  // twice; then the two points, from v0. f = d_inner - d_outer (exact, by the BVH) is positive
  // at both ends; next to a roof's apex it falls and rises once along the edge (the cone's
  // graph over m). Unless the ends' slopes rule a dip out, a negative value is sought by
  // branch and bound on the 2-Lipschitz bound, and the crossings are the roots on either side
  // of it. Edges where f stays positive, or whose dip is narrower than 1e-12 of the edge or
  // not found within 512 evaluations, are left alone (their labels stand).
  bool two_crossings(uint64_t edge, ObjectId inner, DoubleCrossing& out) const {
    const auto v0 = static_cast<uint32_t>(edge >> 32), v1 = static_cast<uint32_t>(edge);
    const ObjectId outer = field_.label[v0];
    const Vec3 x0 = field_.vertices.position(v0), x1 = field_.vertices.position(v1);
    const Vec3 d = x1 - x0;
    const double length = norm(d);
    double scale = 0;  // the larger distance seen, for the roots' tolerance
    auto eval = [&](double t, double& slope) {
      const Vec3 x = x0 + d * t;
      const ClosestHit hi = bvh_.nearest_in_object(x, inner);
      const ClosestHit ho = bvh_.nearest_in_object(x, outer);
      slope = 0;
      if (!hi.found() || !ho.found()) return std::numeric_limits<double>::quiet_NaN();
      const double di = std::sqrt(hi.dist2), dout = std::sqrt(ho.dist2);
      scale = std::max({scale, di, dout});
      if (di > 0 && dout > 0) slope = dot((x - hi.point) / di - (x - ho.point) / dout, d);
      return di - dout;
    };
    double s_lo = 0, s_hi = 0;
    const double f0 = eval(0, s_lo), f1 = eval(1, s_hi);
    if (!(f0 > 0 && f1 > 0)) return false;
    // Slopes that keep one sign at both ends (f rises or falls all along, the cone's graph
    // over m), or that show a peak, leave no dip below zero: only an edge whose ends' slopes
    // fall then rise (or vanish, where f is flat along the edge) is searched.
    const double flat = 1e-9 * length;
    if ((s_lo > flat && s_hi > flat) || (s_lo < -flat && s_hi < -flat) ||
        (s_lo > flat && s_hi < -flat))
      return false;
    // A negative value of f, branch and bound: f is 2-Lipschitz, so on a piece [a, b] it
    // stays above (f_a + f_b) / 2 - (b - a) |d|; the piece with the lowest bound is split.
    struct Span {
      double a, b, fa, fb;
      double bound(double len) const { return 0.5 * (fa + fb) - (b - a) * len; }
    };
    std::vector<Span> open{{0, 1, f0, f1}};
    double t_neg = -1, f_neg = 0;
    constexpr int kMaxEvaluations = 512;
    for (int it = 0; it < kMaxEvaluations && !open.empty(); ++it) {
      size_t lowest = 0;
      for (size_t k = 1; k < open.size(); ++k)
        if (open[k].bound(length) < open[lowest].bound(length)) lowest = k;
      const Span piece = open[lowest];
      open[lowest] = open.back();
      open.pop_back();
      if (piece.bound(length) > 0) break;  // the lowest bound: f > 0 all along
      const double t = 0.5 * (piece.a + piece.b);
      double slope = 0;
      const double f = eval(t, slope);
      if (!(f == f)) return false;
      if (f < 0) {
        t_neg = t;
        f_neg = f;
        break;
      }
      if (piece.b - piece.a < 1e-12) continue;  // a dip narrower than this: left alone
      open.push_back({piece.a, t, piece.fa, f});
      open.push_back({t, piece.b, f, piece.fb});
    }
    if (t_neg < 0) return false;
    auto value = [&](double t) {
      double slope = 0;
      return eval(t, slope);
    };
    auto done = [&](double, double f, double width) {
      return std::abs(f) <= 1e-12 * scale || width <= 1e-15;
    };
    constexpr double kHair = 1e-9;  // off the edge's ends, far below any clearance
    const double r0 =
        std::clamp(detail::bracketed_root(0, f0, t_neg, f_neg, 200, value, done), kHair, t_neg);
    const double r1 =
        std::clamp(detail::bracketed_root(t_neg, f_neg, 1, f1, 200, value, done), t_neg, 1 - kHair);
    out.p[0] = x0 + d * r0;
    out.p[1] = x0 + d * r1;
    out.inner = inner;
    return r0 < r1;
  }

  bool touches_double(uint32_t leaf, const LeafGrid& grid) const {
    bool found = false;
    detail::for_each_face_polygon(octree_, grid, leaf, [&](const detail::FacePolygon& p) {
      for (int k = 0; k < p.n && !found; ++k) {
        const uint32_t v = p.v[k], w = p.v[(k + 1) % p.n];
        if (field_.label[v] != field_.label[w]) continue;
        const uint64_t key = v < w ? (uint64_t{v} << 32 | w) : (uint64_t{w} << 32 | v);
        found = double_index_.find(key) != FlatMap64::kMissing;
      }
    });
    return found;
  }

  size_t refined_count() const { return refined_count_; }
  /// The leaves that emit pieces (listed by prepare): those the GVD crosses and those
  /// on the domain box, in leaf order.
  const std::vector<uint32_t>& active_leaves() const { return active_; }

  // The closest point of a spoke's edge end: a point on an object right next to the spoke,
  // which bounds the clearance search at the pieces made from it.
  Vec3 witness(const Spoke& s) const {
    return field_.closest[field_.point[static_cast<uint32_t>(s.edge >> 32)]];
  }

  PolygonGvd polygon(const detail::FacePolygon& poly) const {
    PolygonGvd out;
    Vec3 sum;
    bool twice = false;
    for (int i = 0; i < poly.n; ++i) {
      const uint32_t v = poly.v[i], w = poly.v[(i + 1) % poly.n];
      const ObjectId la = field_.label[v], lb = field_.label[w];
      const uint64_t edge = v < w ? (uint64_t{v} << 32 | w) : (uint64_t{w} << 32 | v);
      if (la == lb) {
        // Two crossings of an edge whose ends carry one label (find_double_crossings).
        if (doubles_.empty()) continue;
        const uint32_t k = double_index_.find(edge);
        if (k == FlatMap64::kMissing) continue;
        const DoubleCrossing& d = doubles_[k];
        const bool from_lower = v < w;  // p[0] lies next to the smaller vertex index
        for (int j = 0; j < 2; ++j) {
          const int which = from_lower ? j : 1 - j;
          Spoke& s = out.spokes[out.n++];
          s.p = d.p[which];
          s.label_a = j == 0 ? la : d.inner;
          s.label_b = j == 0 ? d.inner : lb;
          s.edge = edge;
          s.id = which == 0 ? edge : edge | kSecondCrossing;
          s.ring_edge = i;
          sum = sum + s.p;
        }
        twice = true;
        continue;
      }
      Spoke& s = out.spokes[out.n++];
      s.p = bisector(v, w);
      s.label_a = la;
      s.label_b = lb;
      s.edge = edge;
      s.id = edge;
      s.ring_edge = i;
      sum = sum + s.p;
    }
    if (out.n > 0) out.centroid = sum / out.n;
    if (out.n >= 4 && twice) pair_spokes(poly, out);
    if (out.n >= 3 && out.pairs.empty()) out.centroid = junction_point(poly, out);
    return out;
  }

  // The pieces of a face's bisector where some of its edges cross it twice (a cone cell's
  // roof): the bisector of the two objects is a graph over one axis m of the face (the
  // cone's gradients all point one way along the other axis), so its pieces on the face are
  // intervals along m, and the spokes sorted along m pair up in turn. m is the face's axis
  // along which the gradients of d_a - d_b at the spokes take both signs (along the other,
  // and along an extruded cell's axis where they vanish, they keep one). On a wedge's faces
  // square to its monotone axis, which hold its direction e, the gradients take both signs
  // along both axes but all lie along one line in the face (d_a - d_b is invariant along e):
  // the pieces are straight along e and the spokes are sorted across it, along the
  // gradients. A skew wedge's e crosses those faces: the pieces there are C sheared along e,
  // and the spokes are sorted across the middle of their gradients' span. A function of the
  // face alone, so both cells of the face pair the same spokes; left unpaired (the junction
  // point then) where the spokes do not show that structure.
  void pair_spokes(const detail::FacePolygon& poly, PolygonGvd& g) const {
    if (g.n % 2 != 0) return;
    const ObjectId a = std::min(g.spokes[0].label_a, g.spokes[0].label_b);
    const ObjectId b = std::max(g.spokes[0].label_a, g.spokes[0].label_b);
    for (int i = 0; i < g.n; ++i)
      if (std::min(g.spokes[i].label_a, g.spokes[i].label_b) != a ||
          std::max(g.spokes[i].label_a, g.spokes[i].label_b) != b)
        return;
    const int u = (poly.axis + 1) % 3, w = (poly.axis + 2) % 3;
    bool up[2] = {false, false}, down[2] = {false, false};
    std::array<double, 2> in_face[PolygonGvd::kMaxSpokes];
    int first = 0;  // the spoke of the lowest id, the same from both cells of the face
    for (int i = 0; i < g.n; ++i) {
      Probe last;
      bisector_gap(g.spokes[i].p, a, b, last);
      const double len = norm(last.grad);
      if (!(len > 0)) return;
      for (int k = 0; k < 2; ++k) {
        const double c = last.grad[k == 0 ? u : w] / len;
        in_face[i][k] = c;
        up[k] |= c > 1e-9;
        down[k] |= c < -1e-9;
      }
      if (g.spokes[i].id < g.spokes[first].id) first = i;
    }
    const bool mixed_u = up[0] && down[0], mixed_w = up[1] && down[1];
    if (!mixed_u && !mixed_w) return;
    // The direction the spokes are sorted along: the mixed axis, or (both mixed) the line
    // every gradient lies along.
    Vec3 along;
    if (mixed_u != mixed_w) {
      along[mixed_u ? u : w] = 1;
    } else {
      const std::array<double, 2> d = in_face[first];
      const double d_len = std::hypot(d[0], d[1]);
      if (!(d_len > 0.01)) return;
      constexpr double kParallel = 1e-6;
      bool parallel = true;
      for (int i = 0; i < g.n; ++i) {
        const double c = in_face[i][0] * d[1] - in_face[i][1] * d[0];
        parallel &= std::abs(c) <= kParallel * d_len * std::hypot(in_face[i][0], in_face[i][1]);
      }
      if (parallel) {
        along[u] = d[0];
        along[w] = d[1];
      } else {
        // A skew wedge's face square to its monotone axis, which e crosses: the bisector there
        // is C sheared along e, a curve that turns one way by less than a half turn (by
        // nearly one where e lies nearly in the face), so it is a graph across the middle of
        // its gradients' span, and its pieces are intervals square to that. The span from the
        // spokes' gradients: the curve's gradients between two spokes lie between theirs. The
        // certifier admits wedges up to PairCertifier::kMaxFaceSpan (175 degrees); the rest is
        // room for rounding.
        constexpr double kPi = 3.14159265358979323846;
        const double ref = std::atan2(d[1], d[0]);
        double lo = 0, hi = 0;
        for (int i = 0; i < g.n; ++i) {
          if (!(std::hypot(in_face[i][0], in_face[i][1]) > 0.01)) return;
          double t = std::atan2(in_face[i][1], in_face[i][0]) - ref;
          if (t > kPi) t -= 2 * kPi;
          if (t < -kPi) t += 2 * kPi;
          lo = std::min(lo, t);
          hi = std::max(hi, t);
        }
        constexpr double kMaxSpan = 179.0 * kPi / 180.0;
        if (!(hi - lo <= kMaxSpan)) return;
        const double middle = ref + 0.5 * (lo + hi);
        along[u] = -std::sin(middle);
        along[w] = std::cos(middle);
      }
    }
    int order[PolygonGvd::kMaxSpokes];
    for (int i = 0; i < g.n; ++i) order[i] = i;
    std::sort(order, order + g.n,
              [&](int i, int j) { return dot(g.spokes[i].p, along) < dot(g.spokes[j].p, along); });
    std::vector<std::array<int, 2>> pairs;
    for (int i = 0; i < g.n; i += 2) {
      const Spoke& s0 = g.spokes[order[i]];
      const Spoke& s1 = g.spokes[order[i + 1]];
      // A piece enters label_b's side at one end and leaves it at the other.
      if (s0.label_a != s1.label_b || s0.label_b != s1.label_a) return;
      pairs.push_back({order[i], order[i + 1]});
    }
    g.pairs = std::move(pairs);
    g.pair_curves.assign(g.pairs.size(), {});
  }

  // The polygon's spokes, paired (pair_spokes) also where four or more of them come from
  // single crossings on a face of a cone leaf whose lines may cross C twice (a hanging vertex
  // splits such an edge), or on a wedge's face square to its monotone axis (two straight
  // pieces along e there can cut opposite corners of the face, each edge crossed once):
  // decided from the leaves on both sides, so both pair alike.
  PolygonGvd paired_polygon(uint32_t leaf, const detail::FacePolygon& poly) const {
    PolygonGvd out = polygon(poly);
    if (out.n >= 4 && out.pairs.empty() && any_cone_ &&
        (pieces_may_pair(leaf, poly.axis) ||
         (!poly.on_domain && pieces_may_pair(leaf_across(poly), poly.axis))))
      pair_spokes(poly, out);
    return out;
  }

  // Whether a face square to `face_axis` of `leaf` may hold two pieces of the leaf's pair.
  bool pieces_may_pair(uint32_t leaf, int face_axis) const {
    bool twice = false;
    const unsigned axes = octree_.straddled_axes(leaf, &twice);
    const bool wedge = axes != 0 && (axes & (axes - 1)) != 0;
    return twice || (wedge && (axes >> face_axis & 1u) == 0);
  }

  // A polygon's bisector with the curves traced where the face is perpendicular to the axis
  // of an extruded pair cell on either side of it (the same answer from both cells).
  PolygonGvd polygon(uint32_t leaf, const detail::FacePolygon& poly) const {
    PolygonGvd out = paired_polygon(leaf, poly);
    if (any_junction_ && junction_polygon(leaf, poly, out)) return out;
    if (!any_extruded_ || (out.n != 2 && out.pairs.empty()) || !traced_face(leaf, poly)) return out;
    if (out.n == 2) out.curve = curve_between(poly, out.spokes[0], out.spokes[1]);
    for (size_t k = 0; k < out.pairs.size(); ++k)
      out.pair_curves[k] =
          curve_between(poly, out.spokes[out.pairs[k][0]], out.spokes[out.pairs[k][1]]);
    return out;
  }

  // The traced curve of a face from spoke s0 to spoke s1, its points strictly between them:
  // as trace_curves stored it (from the smaller spoke id to the larger), or traced now.
  std::vector<Vec3> curve_between(const detail::FacePolygon& poly, const Spoke& s0,
                                  const Spoke& s1) const {
    const uint64_t lo = std::min(s0.id, s1.id), hi = std::max(s0.id, s1.id);
    const auto it = curve_index_.find(curve_hash(lo, hi));
    if (it == curve_index_.end() || curves_[it->second].lo != lo || curves_[it->second].hi != hi)
      return trace_curve(poly, s0, s1);
    const Curve& c = curves_[it->second];
    if (s0.id == lo) return c.points;
    return {c.points.rbegin(), c.points.rend()};
  }

  // For each of labels[0..nl), the closest point of a spoke end carrying it (a point on that
  // object near the spokes), taken from the first polygons that have one.
  void spoke_hints(const PolygonGvd& g, const ObjectId* labels, int nl, Vec3* hints,
                   bool* found) const {
    for (int i = 0; i < g.n; ++i) {
      for (const uint32_t v : {static_cast<uint32_t>(g.spokes[i].edge >> 32),
                               static_cast<uint32_t>(g.spokes[i].edge)}) {
        for (int k = 0; k < nl; ++k) {
          if (!found[k] && field_.label[v] == labels[k]) {
            hints[k] = field_.closest[field_.point[v]];
            found[k] = true;
          }
        }
      }
    }
  }

  // Adds the distinct objects a polygon's spokes separate to labels[0..nl); nl becomes
  // kMaxJunction + 1 (and stays) once more than kMaxJunction are seen, which callers treat as
  // "keep the centroid".
  static void add_spoke_labels(const PolygonGvd& g, ObjectId (&labels)[kMaxJunction], int& nl) {
    for (int i = 0; i < g.n && nl <= kMaxJunction; ++i) {
      for (ObjectId l : {g.spokes[i].label_a, g.spokes[i].label_b}) {
        const int known = std::min(nl, kMaxJunction);
        if (std::find(labels, labels + known, l) != labels + known) continue;
        if (nl >= kMaxJunction) {
          nl = kMaxJunction + 1;
          return;
        }
        labels[nl++] = l;
      }
    }
  }

  // The cone apex of one spoke curve of a 3D cell: the bisector centroid (the paper's rule)
  // moved toward the points equidistant from the objects the curve separates (two: the
  // bisector surface; three: the junction line; four or more: a Voronoi vertex, or the line
  // where they tie, as in a regular array of equal parts), staying inside the cell.
  Vec3 cell_junction_point(uint32_t leaf, const PolygonGvd* gvds, int np, const int* comp_of,
                           int component, Vec3 centroid) const {
    ObjectId labels[kMaxJunction];
    int nl = 0;
    for (int f = 0; f < np; ++f)
      if (comp_of[f] == component) add_spoke_labels(gvds[f], labels, nl);
    if (nl < 2 || nl > kMaxJunction) return centroid;
    double near2 = 1e300;
    for (int f = 0; f < np; ++f) {
      if (comp_of[f] != component) continue;
      for (int i = 0; i < gvds[f].n; ++i)
        near2 = std::min(near2, dist2(centroid, witness(gvds[f].spokes[i])));
    }
    const Box box = octree_.box(leaf);
    if (nl == 2 && !coarse_region(box, near2)) return centroid;
    Vec3 hints[kMaxJunction];
    bool found[kMaxJunction] = {};
    for (int f = 0; f < np; ++f)
      if (comp_of[f] == component) spoke_hints(gvds[f], labels, nl, hints, found);
    for (int k = 0; k < nl; ++k)
      if (!found[k]) return centroid;
    return toward_equidistant(centroid, labels, hints, nl, box, -1);
  }

  // Newton steps from x toward the points equidistant from `nl` (2 ... kMaxJunction)
  // objects: with the exact closest points p_k of x on each, the least change of x that
  // satisfies the linearised conditions |x - p_0| = |x - p_k|, i.e.
  // 2 x.(p_k - p_0) = |p_k|^2 - |p_0|^2 (two or three objects: exactly; more: in the least
  // squares sense, the least such change, as where four objects tie along a line). With
  // fixed_axis >= 0 x moves only in that axis' plane (a face). hints[k] is a point on object
  // labels[k] (it bounds the first search). A step that would leave `box` (shrunk by a hair,
  // so that the point stays off the faces and edges where other pieces end) is shortened at
  // its boundary, and a coordinate left on it is held there in the next step. Two rounds (one
  // when the first step is below 1e-6 of the distance); deterministic in its inputs.
  Vec3 toward_equidistant(Vec3 x, const ObjectId* labels, const Vec3* hints, int nl,
                          const Box& cell_box, int fixed_axis) const {
    Box box = cell_box;
    for (int i = 0; i < 3; ++i) {
      if (i == fixed_axis) continue;
      const double hair = 1e-6 * (cell_box.hi[i] - cell_box.lo[i]);
      box.lo[i] += hair;
      box.hi[i] -= hair;
    }
    Vec3 p[kMaxJunction];
    for (int k = 0; k < nl; ++k) p[k] = hints[k];
    for (int round = 0; round < 2; ++round) {
      for (int k = 0; k < nl; ++k) {
        // The previous point on object k bounds the search; nothing nearer: it is the closest.
        const ClosestHit hit = bvh_.nearest_in_object(x, labels[k], dist2(x, p[k]));
        if (hit.found()) p[k] = hit.point;
      }
      Vec3 n0[kMaxJunction - 1];
      double r[kMaxJunction - 1];
      for (int k = 1; k < nl; ++k) {
        n0[k - 1] = p[k] - p[0];
        // (|p_k|^2 - |p_0|^2) / 2 - x.(p_k - p_0). In 2D as (p_k - p_0).(mid - x): the
        // squares are ~1 beside differences ~g, and their rounding (~1e-16) divided by g
        // moved a junction of four squares 1e-7 apart by 3e-10, 0.5 % of its distance to
        // them. 3D gaps stay above ~1e-6, where that is below 1e-10 of the distance, and
        // there the exact form moved junctions of coarse cells onto spots whose fans cut a
        // rim (2 of 96 audited scenes): kept as it was.
        r[k - 1] = dim_ == 2 ? dot(n0[k - 1], (p[k] + p[0]) * 0.5 - x)
                             : 0.5 * (norm2(p[k]) - norm2(p[0])) - dot(x, n0[k - 1]);
      }
      // The step with the axes in `held` (bits) kept still.
      auto solve = [&](int held, Vec3& step) {
        Vec3 n[kMaxJunction - 1];
        for (int k = 0; k + 1 < nl; ++k) {
          n[k] = n0[k];
          for (int i = 0; i < 3; ++i)
            if (held >> i & 1) n[k][i] = 0;
        }
        const double a11 = dot(n[0], n[0]);
        if (nl == 2) {
          if (!(a11 > 0)) return false;
          step = n[0] * (r[0] / a11);
        } else if (nl == 3) {
          const double a12 = dot(n[0], n[1]), a22 = dot(n[1], n[1]);
          const double det = a11 * a22 - a12 * a12;
          // Singular where a held coordinate leaves one free in 2D (a junction on the cell's
          // side): the two conditions are then solved in the least squares sense. Kept off in
          // 3D, where such steps moved coarse junctions onto rims (see r above).
          if (!(det > 1e-12 * a11 * a22)) return dim_ == 2 && least_change(n, r, 2, step);
          step =
              n[0] * ((r[0] * a22 - r[1] * a12) / det) + n[1] * ((a11 * r[1] - a12 * r[0]) / det);
        } else if (!least_change(n, r, nl - 1, step)) {
          return false;
        }
        return true;
      };
      int held = fixed_axis >= 0 ? 1 << fixed_axis : 0;
      Vec3 step;
      if (!solve(held, step)) return x;
      // A coordinate already on the box's boundary (a step before was shortened there) that
      // the step would push out is held on it, and the step is solved again in the others:
      // else the next step would be shortened to nothing, and a point one hair from a face
      // whose other coordinates are still a good part of the cell off the junction (four
      // objects tying along a line on the cell's face) would stay there.
      for (int pass = 0; pass < 2; ++pass) {
        int pushed = 0;
        for (int i = 0; i < 3; ++i) {
          if (held >> i & 1) continue;
          const double near = 1e-9 * (cell_box.hi[i] - cell_box.lo[i]);
          if ((step[i] > 0 && x[i] >= box.hi[i] - near) ||
              (step[i] < 0 && x[i] <= box.lo[i] + near))
            pushed |= 1 << i;
        }
        if (pushed == 0) break;
        held |= pushed;
        if (held == 7 || !solve(held, step)) return x;
      }
      double t = 1;
      for (int i = 0; i < 3; ++i) {
        if (step[i] > 0 && x[i] + step[i] > box.hi[i])
          t = std::min(t, (box.hi[i] - x[i]) / step[i]);
        if (step[i] < 0 && x[i] + step[i] < box.lo[i])
          t = std::min(t, (box.lo[i] - x[i]) / step[i]);
      }
      if (!(t > 0)) return x;
      const Vec3 next = x + step * t;
      for (int i = 0; i < 3; ++i)
        if (!(next[i] >= box.lo[i] && next[i] <= box.hi[i])) return x;
      // A step below a millionth of the distance: the next one would be smaller still.
      const bool small = norm2(next - x) <= 1e-12 * dist2(x, p[0]);
      x = next;
      if (small) break;
    }
    return x;
  }

  // The least `step` that minimises sum_k (n_k . step - r_k)^2 over m conditions (the
  // pseudo-inverse solution): the normal equations' 3 x 3 matrix split into its eigenvectors
  // (Jacobi rotations), directions whose eigenvalue is below 1e-4 of the largest left out: a
  // face's fixed axis, and the line along which four or more objects (nearly) tie, where the
  // meshes' small asymmetries would otherwise send the step along the line, out of the cell,
  // and the shortened step would stop short of the line. False when all are.
  static bool least_change(const Vec3* n, const double* r, int m, Vec3& step) {
    double a[3][3] = {}, b[3] = {};
    for (int k = 0; k < m; ++k) {
      for (int i = 0; i < 3; ++i) {
        b[i] += n[k][i] * r[k];
        for (int j = 0; j < 3; ++j) a[i][j] += n[k][i] * n[k][j];
      }
    }
    double v[3][3];  // columns: the eigenvectors
    symmetric_eigen(a, v);
    const double largest = std::max({a[0][0], a[1][1], a[2][2]});
    if (!(largest > 0)) return false;
    step = Vec3{};
    for (int e = 0; e < 3; ++e) {
      if (!(a[e][e] > 1e-4 * largest)) continue;
      const Vec3 u{v[0][e], v[1][e], v[2][e]};
      step = step + u * ((u.x * b[0] + u.y * b[1] + u.z * b[2]) / a[e][e]);
    }
    return true;
  }

  // Where three or more spokes meet on a face, the paper joins them at the centroid of the
  // bisectors, which can sit a good part of the cell away from the true junction (three
  // objects) or off a curved bisector (two). Instead the centroid is moved, within the face,
  // toward the points equidistant from the objects (toward_equidistant). Computed from the
  // face's own data, so both cells of a face get the same point.
  Vec3 junction_point(const detail::FacePolygon& poly, const PolygonGvd& g) const {
    ObjectId labels[kMaxJunction];
    int nl = 0;
    add_spoke_labels(g, labels, nl);
    if (nl < 2 || nl > kMaxJunction) return g.centroid;  // more objects: keep the centroid
    Box face;
    for (int i = 0; i < poly.n; ++i) face.extend(field_.vertices.position(poly.v[i]));
    double near2 = 1e300;
    for (int i = 0; i < g.n; ++i) near2 = std::min(near2, dist2(g.centroid, witness(g.spokes[i])));
    if (nl == 2 && !coarse_region(face, near2)) return g.centroid;
    Vec3 hints[kMaxJunction];
    bool found[kMaxJunction] = {};
    spoke_hints(g, labels, nl, hints, found);
    for (int k = 0; k < nl; ++k)
      if (!found[k]) return g.centroid;
    return toward_equidistant(g.centroid, labels, hints, nl, face, poly.axis);
  }

  void cell(uint32_t leaf, std::vector<Piece>& pieces) const {
    const LeafGrid grid = grid_of(leaf);
    Sink out{pieces};
    bool mixed = false;
    const ObjectId first = field_.label[grid[0]];
    for (uint32_t v : grid)
      if (v != kNoVertex && field_.label[v] != first) mixed = true;
    if (!mixed && !doubles_.empty()) mixed = touches_double(leaf, grid);
    if (dim_ == 2) {
      cell_2d(leaf, grid, mixed, out);
    } else {
      cell_3d(leaf, grid, mixed, out);
    }
  }

 private:
  bool coarse(uint32_t v0, uint32_t v1, Vec3 p) const {
    return detail::coarse_edge(field_, v0, v1, p);
  }

  // Whether a cell or face is large next to the squared distance `near2` to the objects (as
  // in `coarse`): there a centroid can sit visibly off a curved bisector.
  static bool coarse_region(const Box& box, double near2) {
    constexpr double kCoarse = 0.05;
    return norm2(box.hi - box.lo) > kCoarse * kCoarse * near2;
  }

  Vec3 refine_bisector(uint32_t v0, uint32_t v1, Vec3 p) const {
    return detail::refine_bisector(field_, bvh_, v0, v1, p);
  }

  // Whether an extruded pair cell traces the bisector's curve on its faces perpendicular to
  // `face_axis`: along an axis, its two faces across it; slanted, the four faces its
  // direction crosses (not the two it runs along, where the bisector is straight).
  bool traces(uint32_t leaf, int face_axis) const {
    if (octree_.is_skew(leaf)) return static_cast<bool>(skew_direction_);  // every face
    const int axis = octree_.extruded_axis(leaf);
    if (axis >= 0) return face_axis == axis;
    const int slanted = octree_.slanted_axis(leaf);
    return slanted >= 0 && face_axis != slanted;
  }

  // Whether face polygon `poly` of `leaf` is traced by an extruded pair cell on one of its
  // sides: this leaf or the leaf across the polygon (both then use the same curve).
  bool traced_face(uint32_t leaf, const detail::FacePolygon& poly) const {
    if (traces(leaf, poly.axis)) return true;
    return !poly.on_domain && leaf_across_traces(poly);
  }

  // The leaf across polygon `poly` (not on the domain box).
  uint32_t leaf_across(const detail::FacePolygon& poly) const {
    lattice::Coord lo = lattice::vertex_coord(3, field_.vertices.key[poly.v[0]]);
    for (int i = 1; i < poly.n; ++i) {
      const lattice::Coord c = lattice::vertex_coord(3, field_.vertices.key[poly.v[i]]);
      for (int a = 0; a < 3; ++a) lo.c[a] = std::min(lo.c[a], c.c[a]);
    }
    if (poly.side == 0) lo.c[poly.axis] -= 1;  // the finest cell just below the face
    return octree_.locate_lattice(lo);
  }

  // Whether the leaf across polygon `poly` (not on the domain box) traces it.
  bool leaf_across_traces(const detail::FacePolygon& poly) const {
    return traces(leaf_across(poly), poly.axis);
  }

  // The last point where the tracer measured both distances: distance is 1-Lipschitz, so
  // d(x) <= d(last) + |x - last| bounds the next searches (the answers stay exact).
  struct Probe {
    Vec3 x;
    double da = 0, db = 0;
    bool valid = false;
    Vec3 grad;  ///< the gradient of d_a - d_b at x (from the closest points)
  };

  // d_a - d_b at x (exact, by the BVH), and d_a.
  double bisector_gap(Vec3 x, ObjectId a, ObjectId b, Probe& last, double* da = nullptr) const {
    auto distance = [&](ObjectId o, double before) {
      double bound2 = 1e300;
      if (last.valid) {
        const double bound = before + dist(x, last.x);
        bound2 = bound * bound * (1 + 1e-9) + 1e-300;
      }
      ClosestHit h = bvh_.nearest_in_object(x, o, bound2);
      if (!h.found()) h = bvh_.nearest_in_object(x, o);
      return h;
    };
    const ClosestHit ha = distance(a, last.da), hb = distance(b, last.db);
    const double a_dist = std::sqrt(ha.dist2), b_dist = std::sqrt(hb.dist2);
    last = {x, a_dist, b_dist, true, Vec3{}};
    if (a_dist > 0 && b_dist > 0) last.grad = (x - ha.point) / a_dist - (x - hb.point) / b_dist;
    if (da != nullptr) *da = a_dist;
    return a_dist - b_dist;
  }

  // The bisector curve of objects a and b on a face (axis `axis`, bounds `face`) between two of
  // its points p and q, as the points strictly between them: each chord is split where a line
  // through its midpoint meets the bisector, until the curve stays within kCurveTolerance of
  // the local clearance of the chord. The line runs along the middle of the gradients of
  // d_a - d_b at the chord's ends (in the face): where the curve turns one way between them, as
  // over a shaft's corner, every gradient on it lies within half its turn of that direction,
  // so the curve is a graph across it and the line meets it once, between p and q, for any
  // turn below a half turn (an extruded pair cell's cone, pair_certificate.h). The chord's own
  // normal, used where the ends' gradients are nearly opposite, is one of those gradients and
  // can be as far as the whole turn from another: beyond a quarter turn its line may meet the
  // curve twice. A function of the face and the two points alone, so both cells of the face
  // get the same curve.
  static constexpr double kCurveTolerance = 1e-3;
  /// An end of a search line counts as on the bisector where d_a - d_b is within this (unit
  /// lengths) of 0, however small the clearance: the lattice's rounding of the objects (2^-48
  /// per coordinate, a face flat to the certificates' 1e-12) moves the bisector that much. A
  /// gap's mid-plane on a lattice plane, turned with the scene, lies 4.7e-14 off the face's
  /// edge at a clearance of 5e-5 (inset plates at 1e-4 turned 0.7 rad): taken as off it, the
  /// curve from a rim's parabola to the edge found no root and its chord cut the rim's corner.
  static constexpr double kOnEdge = 1e-12;
  static constexpr int kCurveDepth = 48;
  std::vector<Vec3> trace_curve(const detail::FacePolygon& poly, const Spoke& s0,
                                const Spoke& s1) const {
    const bool flip = s1.id < s0.id;  // canonical order: from the smaller spoke id
    const Spoke& from = flip ? s1 : s0;
    const Spoke& to = flip ? s0 : s1;
    Box face;
    for (int i = 0; i < poly.n; ++i) face.extend(field_.vertices.position(poly.v[i]));
    const ObjectId a = std::min(from.label_a, from.label_b);
    const ObjectId b = std::max(from.label_a, from.label_b);
    std::vector<Vec3> out;
    double cp = 0, cq = 0;
    Probe last;
    bisector_gap(from.p, a, b, last, &cp);
    const Vec3 gp = last.grad;
    bisector_gap(to.p, a, b, last, &cq);
    const Vec3 gq = last.grad;
    subdivide_curve({from.p, cp, gp}, {to.p, cq, gq}, a, b, poly.axis, face, 0, last, out);
    if (flip) std::reverse(out.begin(), out.end());
    return out;
  }

  // A point of a traced curve: its position, d_a there and the gradient of d_a - d_b.
  struct CurvePoint {
    Vec3 x;
    double clearance = 0;
    Vec3 grad;
  };

  enum class Root { kFound, kNone, kWhole };

  // The root of d_a - d_b on the line m + t nu, t in [t_lo, t_hi] (inside the face): Newton
  // steps from the chord's midpoint (the slope along nu from the closest points) until the
  // root is bracketed, the line's ends bracketing it otherwise. kNone where the ends carry one
  // sign (no crossing, or two), kWhole where both lie on the bisector (to rounding).
  Root root_on_line(Vec3 m, Vec3 nu, double t_lo, double t_hi, ObjectId a, ObjectId b, double len,
                    Probe& last, double& t, double& da) const {
    t = 0;
    double f = bisector_gap(m, a, b, last, &da);
    bool bracketed = false, done = std::abs(f) <= 1e-12 * da;
    double f_lo = 0, f_hi = 0;
    for (int it = 0; it < 4 && !done && !bracketed; ++it) {
      const double slope = dot(last.grad, nu);
      if (!(std::abs(slope) > 0.1)) break;
      const double tn = std::clamp(t - f / slope, t_lo, t_hi);
      double dn = 0;
      const double fn = bisector_gap(m + nu * tn, a, b, last, &dn);
      if (fn * f < 0) {
        bracketed = true;
        if (tn < t) {
          t_lo = tn, f_lo = fn, t_hi = t, f_hi = f;
        } else {
          t_lo = t, f_lo = f, t_hi = tn, f_hi = fn;
        }
      }
      t = tn;
      f = fn;
      da = dn;
      done = std::abs(f) <= 1e-12 * da;
    }
    if (!done && !bracketed) {
      // An end of the line on the bisector (to rounding) is a root too: where the bisector
      // runs along the face's edge (a gap's mid-plane on a lattice plane), the curve reaches
      // that edge and follows it.
      double d_lo = 0, d_hi = 0;
      f_lo = bisector_gap(m + nu * t_lo, a, b, last, &d_lo);
      f_hi = bisector_gap(m + nu * t_hi, a, b, last, &d_hi);
      if (std::abs(f_lo) <= std::max(1e-12 * d_lo, kOnEdge)) f_lo = 0;
      if (std::abs(f_hi) <= std::max(1e-12 * d_hi, kOnEdge)) f_hi = 0;
      if (f_lo == 0 && f_hi == 0) return Root::kWhole;
      if (!(f_lo * f_hi <= 0)) return Root::kNone;
      if (f_lo == 0 || f_hi == 0) {
        t = f_lo == 0 ? t_lo : t_hi;
        da = f_lo == 0 ? d_lo : d_hi;
        return Root::kFound;
      }
    }
    // The bisector is one simple root on the line.
    if (!done) {
      t = detail::bracketed_root(
          t_lo, f_lo, t_hi, f_hi, 100,
          [&](double s) { return bisector_gap(m + nu * s, a, b, last, &da); },
          [&](double, double fs, double width) {
            return std::abs(fs) <= 1e-12 * da || width <= 1e-13 * len;
          });
    }
    return Root::kFound;
  }

  // The part [lo, hi] of the line m + t nu (m on the chord from p to q) inside the triangle of
  // the chord and the curve's tangents at p and q (in the face square to `axis`), widened by
  // `slack`: where an arc that turns one way by less than a half turn lies. False where the
  // tangents are within a degree of parallel (no such triangle to speak of).
  static bool arc_triangle(const CurvePoint& p, const CurvePoint& q, Vec3 m, Vec3 nu, int axis,
                           double slack, double& lo, double& hi) {
    const int u = (axis + 1) % 3, w = (axis + 2) % 3;
    using V2 = std::array<double, 2>;
    auto in_face = [&](Vec3 v) { return V2{v[u], v[w]}; };
    auto dot2 = [](V2 x, V2 y) { return x[0] * y[0] + x[1] * y[1]; };
    auto sub = [](V2 x, V2 y) { return V2{x[0] - y[0], x[1] - y[1]}; };
    const V2 gp = in_face(p.grad), gq = in_face(q.grad);
    const double lp = std::hypot(gp[0], gp[1]), lq = std::hypot(gq[0], gq[1]);
    if (!(lp > 0) || !(lq > 0)) return false;
    const double cross = (gp[0] * gq[1] - gp[1] * gq[0]) / (lp * lq);
    constexpr double kMinTurn = 0.0175;  // sin(1 degree)
    if (!(std::abs(cross) > kMinTurn)) return false;
    const V2 pp = in_face(p.x), qq = in_face(q.x);
    const double cp = dot2(gp, pp), cq = dot2(gq, qq);
    const double det = gp[0] * gq[1] - gp[1] * gq[0];
    const V2 tt{(cp * gq[1] - gp[1] * cq) / det, (gp[0] * cq - cp * gq[0]) / det};
    const V2 corner[3] = {pp, qq, tt};
    const V2 mm = in_face(m), dir = in_face(nu);
    lo = -1e300;
    hi = 1e300;
    for (int k = 0; k < 3; ++k) {
      const V2 a0 = corner[k], a1 = corner[(k + 1) % 3], opposite = corner[(k + 2) % 3];
      const V2 edge = sub(a1, a0);
      const double el = std::hypot(edge[0], edge[1]);
      if (!(el > 0)) return false;
      V2 n{-edge[1] / el, edge[0] / el};
      const double side = dot2(n, sub(opposite, a0));
      if (!(std::abs(side) > 0)) return false;
      if (side < 0) n = {-n[0], -n[1]};
      // n . (mm + t dir - a0) >= -slack
      const double c0 = dot2(n, sub(mm, a0)) + slack, c1 = dot2(n, dir);
      if (c1 == 0) {
        if (c0 < 0) return false;
        continue;
      }
      const double bound = -c0 / c1;
      if (c1 > 0) {
        lo = std::max(lo, bound);
      } else {
        hi = std::min(hi, bound);
      }
    }
    return lo < hi;
  }

  void subdivide_curve(const CurvePoint& p, const CurvePoint& q, ObjectId a, ObjectId b, int axis,
                       const Box& face, int depth, Probe& last, std::vector<Vec3>& out) const {
    if (depth >= kCurveDepth) return;
    const Vec3 m = (p.x + q.x) * 0.5;
    Vec3 nu = q.x - p.x;
    nu[axis] = 0;
    std::swap(nu[(axis + 1) % 3], nu[(axis + 2) % 3]);
    nu[(axis + 1) % 3] = -nu[(axis + 1) % 3];
    const double len = norm(nu);
    if (!(len > 0)) return;
    nu = nu / len;
    // The middle of the ends' gradients in the face, turned to the chord normal's side; the
    // chord normal where they nearly cancel (a turn near half a turn) or the middle would run
    // within 20 degrees of the chord.
    Vec3 mid_grad;
    for (const Vec3& g : {p.grad, q.grad}) {
      Vec3 in = g;
      in[axis] = 0;
      const double n = norm(in);
      if (n > 0) mid_grad = mid_grad + in / n;
    }
    const double mid_len = norm(mid_grad);
    if (mid_len > 0.1) {
      Vec3 dir = mid_grad / mid_len;
      if (dot(dir, nu) < 0) dir = dir * -1.0;
      if (dot(dir, nu) > std::sin(20 * 3.14159265358979323846 / 180)) nu = dir;
    }
    // The line m + t nu inside the face.
    double t_lo = -1e300, t_hi = 1e300;
    for (int i = 0; i < 3; ++i) {
      if (i == axis || nu[i] == 0) continue;
      double t0 = (face.lo[i] - m[i]) / nu[i], t1 = (face.hi[i] - m[i]) / nu[i];
      if (t0 > t1) std::swap(t0, t1);
      t_lo = std::max(t_lo, t0);
      t_hi = std::min(t_hi, t1);
    }
    if (!(t_lo < t_hi)) return;
    double t = 0, da = 0;
    Root found = root_on_line(m, nu, t_lo, t_hi, a, b, len, last, t, da);
    // The line can meet the rest of the curve too, where it turns by nearly a half turn in the
    // face (a hairpin: a wedge's bisector seen on a face that e runs nearly along): both of
    // the hairpin's legs cross it, their signs cancel at its ends, and the chord would cut
    // across the hairpin's tip. An arc that turns one way by less than a half turn lies in the
    // triangle of its chord and its tangents at p and q, and the rest of the curve outside it:
    // where the whole line shows no crossing, the search again on its part inside that
    // triangle. (Only there: on the inset plates' faces a crossing the whole line found
    // outside the triangle is the right one; the triangle's premise fails there, an arc that
    // turns one way with its tangents given by the gradients at its ends.)
    double in_lo = 0, in_hi = 0;
    if (found == Root::kNone && arc_triangle(p, q, m, nu, axis, 1e-9 * len, in_lo, in_hi)) {
      const double lo = std::max(t_lo, in_lo), hi = std::min(t_hi, in_hi);
      if (lo < hi) found = root_on_line(m, nu, lo, hi, a, b, len, last, t, da);
    }
    if (found != Root::kFound) return;
    const Vec3 x = m + nu * t;
    const double clearance = std::min({p.clearance, q.clearance, da});
    if (std::abs(t) <= kCurveTolerance * clearance &&
        (depth > 0 || std::abs(t) <= 1e-9 * clearance))
      return;
    if (!(last.valid && last.x == x)) bisector_gap(x, a, b, last);
    const CurvePoint at{x, da, last.grad};
    subdivide_curve(p, at, a, b, axis, face, depth + 1, last, out);
    out.push_back(x);
    subdivide_curve(at, q, a, b, axis, face, depth + 1, last, out);
  }

  static void emit(Sink& out, Vec3 a, Vec3 b, Vec3 c, ObjectId obj, ObjectId other) {
    if (obj == kNoObject || obj == kManyObjects) return;
    if (a == b || b == c || a == c) return;  // collapsed: removing it keeps the surface closed
    out.out.push_back({{a, b, c}, obj, other});
  }
  static void emit(Sink& out, Vec3 a, Vec3 b, ObjectId obj, ObjectId other) {
    if (obj == kNoObject || obj == kManyObjects) return;
    if (a == b) return;
    out.out.push_back({{a, b, Vec3{}}, obj, other});
  }

  void cell_2d(uint32_t leaf, const LeafGrid& grid, bool mixed, Sink& out) const {
    detail::FacePolygon poly;
    detail::for_each_face_polygon(octree_, grid, leaf,
                                  [&](const detail::FacePolygon& p) { poly = p; });
    const PolygonGvd g = mixed ? polygon(poly) : PolygonGvd{};
    // The ring runs counter-clockwise, so label_a lies to the left of bisector -> centroid.
    // Two spokes through their midpoint are one straight segment: emit it whole.
    if (g.n == 2) {
      emit(out, g.spokes[0].p, g.spokes[1].p, g.spokes[0].label_a, g.spokes[0].label_b);
      emit(out, g.spokes[1].p, g.spokes[0].p, g.spokes[0].label_b, g.spokes[0].label_a);
    } else {
      for (int i = 0; i < g.n; ++i) {
        const Spoke& s = g.spokes[i];
        emit(out, s.p, g.centroid, s.label_a, s.label_b);
        emit(out, g.centroid, s.p, s.label_b, s.label_a);
      }
    }
    // Domain box: polygon edges on the boundary, split at their bisector. The polygon runs
    // counter-clockwise, so the cell interior stays on the left.
    const uint32_t limit = static_cast<uint32_t>(lattice::side_units(2));
    for (int i = 0; i < poly.n; ++i) {
      const uint32_t v = poly.v[i], w = poly.v[(i + 1) % poly.n];
      const lattice::Coord cv = lattice::vertex_coord(2, field_.vertices.key[v]);
      const lattice::Coord cw = lattice::vertex_coord(2, field_.vertices.key[w]);
      bool boundary = false;
      for (int a = 0; a < 2; ++a) {
        if (cv.c[a] == cw.c[a] && (cv.c[a] == 0 || cv.c[a] == limit)) boundary = true;
      }
      if (!boundary) continue;
      const Vec3 pv = field_.vertices.position(v), pw = field_.vertices.position(w);
      const ObjectId lv = field_.label[v], lw = field_.label[w];
      if (lv == lw) {
        emit(out, pv, pw, lv, kNoObject);
      } else {
        const Vec3 m = bisector(v, w);
        emit(out, pv, m, lv, kNoObject);
        emit(out, m, pw, lw, kNoObject);
      }
    }
  }

  void cell_3d(uint32_t leaf, const LeafGrid& grid, bool mixed, Sink& out) const {
    detail::FacePolygon polys[24];
    PolygonGvd gvds[24];
    int np = 0;
    bool any_domain = false;
    detail::for_each_face_polygon(octree_, grid, leaf, [&](const detail::FacePolygon& p) {
      if (!mixed && !p.on_domain) return;
      polys[np] = p;
      gvds[np] = mixed ? polygon(leaf, p) : PolygonGvd{};
      any_domain |= p.on_domain;
      ++np;
    });
    if (!mixed && !any_domain) return;
    if (mixed && !any_domain && extruded_leaf(leaf) && extruded_cell(leaf, polys, gvds, np, out))
      return;
    if (mixed && !any_domain && any_junction_ && octree_.junction_axis(leaf) >= 0) {
      std::vector<Piece> own;
      Sink mine{own};
      if (junction_cell(leaf, polys, gvds, np, mine)) {
        out.out.insert(out.out.end(), own.begin(), own.end());
        return;
      }
    }
    // The spokes form closed curves on the cell surface; faces sharing a bisector belong to
    // the same curve. Each connected curve is coned to the centroid of its own bisectors
    // (the paper's cell centroid when there is one curve), so two sheets crossing one cell
    // stay two sheets instead of being pinched together.
    int comp[24];
    for (int f = 0; f < np; ++f) comp[f] = f;
    auto find = [&](int x) {
      while (comp[x] != x) x = comp[x] = comp[comp[x]];
      return x;
    };
    for (int f = 0; f < np; ++f)
      for (int i = 0; i < gvds[f].n; ++i)
        for (int h = 0; h < f; ++h)
          for (int j = 0; j < gvds[h].n; ++j)
            if (gvds[f].spokes[i].id == gvds[h].spokes[j].id) comp[find(f)] = find(h);
    Vec3 sum[24];
    int count[24] = {};
    Vec3 centre[24];
    bool placed[24] = {};
    int comp_of[24];
    for (int f = 0; f < np; ++f) comp_of[f] = find(f);
    for (int f = 0; f < np; ++f) {
      const int c = find(f);
      for (int i = 0; i < gvds[f].n; ++i) {
        sum[c] = sum[c] + gvds[f].spokes[i].p;
        ++count[c];
      }
    }
    for (int f = 0; f < np; ++f) {
      const PolygonGvd& g = gvds[f];
      // Orientation is decided combinatorially, not from (possibly degenerate) geometry:
      // seen from +axis, label_a lies left of bisector -> face centroid (the ring runs
      // counter-clockwise). Walking the boundary of label_a's region on the cell surface with
      // the region on the left as seen from outside, and coning to the cell centroid, gives
      // triangles whose normals point into label_a's side; the cell across the face sees the
      // face from the other side and so produces the opposite edge.
      const bool outward_plus = polys[f].side == 2;
      const int c = find(f);
      if (count[c] > 0 && !placed[c]) {
        centre[c] = cell_junction_point(leaf, gvds, np, comp_of, c, sum[c] / count[c]);
        placed[c] = true;
      }
      const Vec3 rc = count[c] > 0 ? centre[c] : Vec3{};
      // A traced curve from s0 to s1: a fan from the apex over its chords. Either spoke may
      // come first: the ring's arc from either one to the other lies on the side of its
      // label_b, to the right of the curve seen from +axis.
      auto fan = [&](const Spoke& s0, const Spoke& s1, const std::vector<Vec3>& curve) {
        Vec3 prev = s0.p;
        for (size_t k = 0; k <= curve.size(); ++k) {
          const Vec3 next = k < curve.size() ? curve[k] : s1.p;
          if (outward_plus) {
            emit(out, prev, next, rc, s0.label_a, s0.label_b);
            emit(out, next, prev, rc, s0.label_b, s0.label_a);
          } else {
            emit(out, next, prev, rc, s0.label_a, s0.label_b);
            emit(out, prev, next, rc, s0.label_b, s0.label_a);
          }
          prev = next;
        }
      };
      if (g.junction) {
        // The plane GVD of a junction cell's face: each segment fanned from the apex, its
        // left object (seen from +axis) on the side a spoke's label_a takes.
        for (size_t k = 0; k < g.jsegments.size(); ++k) {
          const Vec3 p = g.jpoints[g.jsegments[k][0]], q = g.jpoints[g.jsegments[k][1]];
          const ObjectId l = g.jleft_right[k][0], r = g.jleft_right[k][1];
          if (outward_plus) {
            emit(out, p, q, rc, l, r);
            emit(out, q, p, rc, r, l);
          } else {
            emit(out, q, p, rc, l, r);
            emit(out, p, q, rc, r, l);
          }
        }
        continue;
      }
      if (g.n == 2 && !g.curve.empty()) {
        fan(g.spokes[0], g.spokes[1], g.curve);
        continue;
      }
      if (!g.pairs.empty()) {
        // The pieces of a roof's bisector on the face (pair_spokes).
        for (size_t k = 0; k < g.pairs.size(); ++k)
          fan(g.spokes[g.pairs[k][0]], g.spokes[g.pairs[k][1]], g.pair_curves[k]);
        if (polys[f].on_domain) domain_face(polys[f], g, out);
        continue;
      }
      if (g.n == 2) {
        // Two spokes meet at their midpoint in a straight line: one triangle per side instead
        // of two, with the same edges as the cell across (which merges the same face).
        const Spoke& s0 = g.spokes[0];
        const Spoke& s1 = g.spokes[1];
        if (outward_plus) {
          emit(out, s0.p, s1.p, rc, s0.label_a, s0.label_b);
          emit(out, s1.p, s0.p, rc, s0.label_b, s0.label_a);
        } else {
          emit(out, s1.p, s0.p, rc, s0.label_a, s0.label_b);
          emit(out, s0.p, s1.p, rc, s0.label_b, s0.label_a);
        }
        if (polys[f].on_domain) domain_face(polys[f], g, out);
        continue;
      }
      for (int i = 0; i < g.n; ++i) {
        const Spoke& s = g.spokes[i];
        if (outward_plus) {
          emit(out, s.p, g.centroid, rc, s.label_a, s.label_b);
          emit(out, g.centroid, s.p, rc, s.label_b, s.label_a);
        } else {
          emit(out, g.centroid, s.p, rc, s.label_a, s.label_b);
          emit(out, s.p, g.centroid, rc, s.label_b, s.label_a);
        }
      }
      if (polys[f].on_domain) domain_face(polys[f], g, out);
    }
  }

  // The direction of a slanted extruded cell (perpendicular to axis `slanted`): perpendicular
  // to the normals of the simplices of x and y nearest to its centre and corners (all of them
  // are perpendicular to it, pair_certificate.h), the first with a part in the plane of the
  // other two axes; when none has (the bisector is then invariant along every direction of
  // that plane), the diagonal of the mark's quadrant.
  Vec3 slanted_direction(uint32_t leaf, int slanted, bool opposite, ObjectId x, ObjectId y) const {
    const Box box = octree_.box(leaf);
    Vec3 axis;
    axis[slanted] = 1;
    for (int k = 0; k <= 8; ++k) {
      Vec3 p = box.center();
      if (k < 8)
        for (int i = 0; i < 3; ++i) p[i] = (k >> i & 1) ? box.hi[i] : box.lo[i];
      for (ObjectId o : {x, y}) {
        const ClosestHit h = bvh_.nearest_in_object(p, o);
        if (!h.found()) continue;
        const Simplex& t = geometry_.simplices[h.simplex];
        const Vec3 a = geometry_.points[t.v[0]];
        Vec3 n = cross(geometry_.points[t.v[1]] - a, geometry_.points[t.v[2]] - a);
        if (!(norm(n) > 0)) continue;
        n = n / norm(n);
        n[slanted] = 0;
        if (!(norm(n) > 0.1)) continue;
        const Vec3 e = cross(n, axis);
        return e / norm(e);
      }
    }
    Vec3 e;
    e[(slanted + 1) % 3] = 1;
    e[(slanted + 2) % 3] = opposite ? -1 : 1;
    return e / norm(e);
  }

  // An extruded pair cell (pair_certificate.h): the bisector is the curve C of the
  // cross-section swept along e (an axis, or slanted). Its boundary on the cell is C traced on
  // the faces e enters by (P) and on those it leaves by (Q) — for an axis the two faces
  // across it, each possibly over quarter faces; slanted, two adjacent faces each, joined
  // where C crosses their common edge — and at most two rungs along e on the faces parallel
  // to e (straight, possibly through a midpoint where a side face is split); slanted, where C
  // leaves the cell's shadow across an edge between an entry and an exit face, P and Q end
  // at one point there. The sheet is the ruled ladder between P and Q, merged by position
  // along C's chord; the rungs' midpoints split the first and last triangles. False (and
  // nothing emitted) when the faces do not show that structure; the cone is used then.
  // Whether `leaf` is a junction cell that sweeps along `face_axis`.
  bool junction_sweeps(uint32_t leaf, int face_axis) const {
    return octree_.junction_axis(leaf) == face_axis;
  }

  // On a face square to the axis of a junction cell on either side of it: the face's plane
  // GVD (from the face alone, so both cells get the same pieces), its ends on the border moved
  // onto the polygon's spokes (each spoke takes the one end on its ring edge with its pair).
  // False (g unchanged) where neither cell is a junction cell along the face's normal, or the
  // plane GVD's ends do not match the spokes one to one.
  bool junction_polygon(uint32_t leaf, const detail::FacePolygon& poly, PolygonGvd& g) const {
    // Between two junction cells along the face's normal only: an ordinary leaf across would
    // fan its apex over the plane GVD, which its own faces do not bound; the junction cell
    // takes that leaf's ordinary pieces on the face instead (junction_cell).
    if (poly.on_domain || !junction_sweeps(leaf, poly.axis) ||
        !junction_sweeps(leaf_across(poly), poly.axis))
      return false;
    Box face;
    for (int i = 0; i < poly.n; ++i) face.extend(field_.vertices.position(poly.v[i]));
    FaceGvd fg;
    if (!junction_face_(face, poly.axis, fg) || fg.segments.empty()) return g.n == 0;
    // The plane GVD against the octree's labels. Where a gap's mid-plane lies on a lattice
    // plane (a grid of parts at round coordinates), pieces run along the face's border and
    // a junction sits on it; the labels of the vertices there (ties, decided one way) show
    // those pieces on one side of the border only. So: a piece along the border stays where
    // a spoke of its pair lies on a ring edge at one of its ends (this side shows it), else it
    // goes; then every point left on the border (an end, or a junction on it) moves onto the
    // spoke on its ring edge whose pair it separates, each spoke taken once, all taken.
    const int u = (poly.axis + 1) % 3, w = (poly.axis + 2) % 3;
    const double side = std::max(face.hi[u] - face.lo[u], face.hi[w] - face.lo[w]);
    // The 2D pipeline, too, keeps a bisector along a lattice line a hair (1e-6 of an edge)
    // to the side its labels choose: within this of the border a point counts as on it.
    const double hair = 1e-5 * side;
    auto on_line = [&](Vec3 p, int a, double at) { return std::abs(p[a] - at) <= hair; };
    auto on_border = [&](Vec3 p) {
      return on_line(p, u, face.lo[u]) || on_line(p, u, face.hi[u]) || on_line(p, w, face.lo[w]) ||
             on_line(p, w, face.hi[w]);
    };
    auto along_border = [&](Vec3 p, Vec3 q) {
      for (const int a : {u, w})
        for (const double at : {face.lo[a], face.hi[a]})
          if (on_line(p, a, at) && on_line(q, a, at)) return true;
      return false;
    };
    // The spokes within `hair`-ish reach of a point on the border (on a ring edge through it).
    auto spoke_near = [&](Vec3 p, ObjectId x, ObjectId y, const bool* taken) {
      int best = -1;
      double best_d = 2 * hair;
      for (int i = 0; i < g.n; ++i) {
        const Spoke& sp = g.spokes[i];
        if ((taken != nullptr && taken[i]) ||
            std::minmax(sp.label_a, sp.label_b) != std::minmax(x, y))
          continue;
        const Vec3 a = field_.vertices.position(poly.v[sp.ring_edge]);
        const Vec3 b = field_.vertices.position(poly.v[(sp.ring_edge + 1) % poly.n]);
        const double d = norm(closest_point_on_segment(p, a, b) - p);
        if (d <= best_d) {
          best_d = d;
          best = i;
        }
      }
      return best;
    };
    // Points within the hair of each other are one (a junction next to a tiny piece the 2D
    // pipeline kept beside a lattice line); pieces between them go.
    {
      std::vector<uint32_t> rep(fg.points.size());
      std::iota(rep.begin(), rep.end(), 0u);
      for (size_t i = 0; i < fg.points.size(); ++i)
        for (size_t j = 0; j < i && rep[i] == i; ++j)
          if (rep[j] == j && norm(fg.points[i] - fg.points[j]) <= hair)
            rep[i] = static_cast<uint32_t>(j);
      // At the mean of its points: two three-way junctions the 2D pipeline found a hair apart
      // around a four-way one have it between them.
      std::vector<Vec3> sum(fg.points.size());
      std::vector<int> count(fg.points.size(), 0);
      for (size_t i = 0; i < fg.points.size(); ++i) {
        sum[rep[i]] = sum[rep[i]] + fg.points[i];
        ++count[rep[i]];
      }
      for (size_t i = 0; i < fg.points.size(); ++i)
        if (count[i] > 1) fg.points[i] = sum[i] / count[i];
      std::vector<std::pair<uint32_t, uint32_t>> segments;
      std::vector<std::pair<ObjectId, ObjectId>> pairs;
      for (size_t k = 0; k < fg.segments.size(); ++k) {
        const uint32_t a = rep[fg.segments[k].first], b = rep[fg.segments[k].second];
        if (a == b) continue;
        segments.emplace_back(a, b);
        pairs.push_back(fg.pairs[k]);
      }
      fg.segments = std::move(segments);
      fg.pairs = std::move(pairs);
    }
    // Pieces along the border, chained (through points where two pieces of one pair meet):
    // a chain stays when one of its ends has a spoke of its pair.
    const size_t ns = fg.segments.size();
    std::vector<uint8_t> keep(ns, 1), along(ns, 0);
    std::vector<int> uses(fg.points.size(), 0);
    for (size_t k = 0; k < ns; ++k) {
      along[k] = along_border(fg.points[fg.segments[k].first], fg.points[fg.segments[k].second]);
      ++uses[fg.segments[k].first];
      ++uses[fg.segments[k].second];
    }
    std::vector<size_t> chain(ns);
    std::iota(chain.begin(), chain.end(), size_t{0});
    auto root = [&](size_t x) {
      while (chain[x] != x) x = chain[x] = chain[chain[x]];
      return x;
    };
    for (size_t k = 0; k < ns; ++k)
      for (size_t l = k + 1; l < ns; ++l) {
        if (!along[k] || !along[l] || fg.pairs[k] != fg.pairs[l]) continue;
        for (const uint32_t v : {fg.segments[k].first, fg.segments[k].second})
          if (uses[v] == 2 && (fg.segments[l].first == v || fg.segments[l].second == v))
            chain[root(k)] = root(l);
      }
    std::vector<uint8_t> shown(ns, 0);
    for (size_t k = 0; k < ns; ++k) {
      if (!along[k]) continue;
      for (const uint32_t v : {fg.segments[k].first, fg.segments[k].second})
        if (spoke_near(fg.points[v], fg.pairs[k].first, fg.pairs[k].second, nullptr) >= 0)
          shown[root(k)] = 1;
    }
    for (size_t k = 0; k < ns; ++k)
      if (along[k]) keep[k] = shown[root(k)];
    std::vector<std::vector<size_t>> at(fg.points.size());
    for (size_t k = 0; k < fg.segments.size(); ++k) {
      if (!keep[k]) continue;
      at[fg.segments[k].first].push_back(k);
      at[fg.segments[k].second].push_back(k);
    }
    bool taken[PolygonGvd::kMaxSpokes] = {};
    int matched = 0;
    std::vector<Vec3> points = fg.points;
    std::vector<uint32_t> loose;  // junctions on the border without a spoke of their own
    for (size_t v = 0; v < fg.points.size(); ++v) {
      if (at[v].empty() || !on_border(fg.points[v])) continue;
      // Inside a chain along the border: no end.
      if (at[v].size() == 2 && along[at[v][0]] && along[at[v][1]] &&
          fg.pairs[at[v][0]] == fg.pairs[at[v][1]])
        continue;
      // The spoke of a pair of the objects that meet here.
      std::vector<ObjectId> objects;
      for (size_t k : at[v]) {
        objects.push_back(fg.pairs[k].first);
        objects.push_back(fg.pairs[k].second);
      }
      std::sort(objects.begin(), objects.end());
      objects.erase(std::unique(objects.begin(), objects.end()), objects.end());
      int best = -1;
      for (size_t x = 0; x < objects.size() && best < 0; ++x)
        for (size_t y = x + 1; y < objects.size() && best < 0; ++y)
          best = spoke_near(fg.points[v], objects[x], objects[y], taken);
      if (best < 0) {
        // A junction at a corner of the face where the labels give the corner to a fourth
        // object: its spokes join the junction below.
        if (at[v].size() < 2) return false;
        loose.push_back(static_cast<uint32_t>(v));
        continue;
      }
      taken[best] = true;
      points[v] = g.spokes[best].p;
      ++matched;
    }
    std::vector<std::pair<uint32_t, uint32_t>> segments;
    std::vector<std::pair<ObjectId, ObjectId>> pairs;
    for (size_t k = 0; k < fg.segments.size(); ++k) {
      if (!keep[k]) continue;
      segments.push_back(fg.segments[k]);
      pairs.push_back(fg.pairs[k]);
    }
    // Spokes left over next to a junction on the border: a piece of their pair from the spoke
    // to it (a spoke's label_a on its left seen from +axis, as cell_3d fans them).
    for (int i = 0; i < g.n && !loose.empty(); ++i) {
      if (taken[i]) continue;
      uint32_t nearest = 0;
      double best_d = 4 * hair;
      bool found = false;
      for (const uint32_t v : loose) {
        const double d = norm(points[v] - g.spokes[i].p);
        if (d <= best_d) {
          best_d = d;
          nearest = v;
          found = true;
        }
      }
      if (!found) continue;
      taken[i] = true;
      ++matched;
      points.push_back(g.spokes[i].p);
      segments.emplace_back(static_cast<uint32_t>(points.size() - 1), nearest);
      pairs.emplace_back(g.spokes[i].label_a, g.spokes[i].label_b);
    }
    if (matched != g.n) return false;
    fg.segments = std::move(segments);
    fg.pairs = std::move(pairs);
    g.junction = true;
    g.jpoints = std::move(points);
    g.jsegments.clear();
    g.jleft_right.clear();
    for (size_t k = 0; k < fg.segments.size(); ++k) {
      g.jsegments.push_back({fg.segments[k].first, fg.segments[k].second});
      g.jleft_right.push_back({fg.pairs[k].first, fg.pairs[k].second});
    }
    return true;
  }

  // A junction cell along axis e: the GVD is the plane GVD of its end faces swept along e.
  // Each end face's pieces are chained into paths between their ends (spokes on the border, or
  // junctions where three or more meet); each path on the lower face is matched with the path
  // on the upper face of the same pair whose ends match (spokes joined by the side faces'
  // pieces, junctions by position), and a ruled ladder joins them. False where anything fails
  // to match (the caller then surfaces the cell as an ordinary one).
  bool junction_cell(uint32_t leaf, const detail::FacePolygon* polys, const PolygonGvd* gvds,
                     int np, Sink& out) const {
    const int axis = octree_.junction_axis(leaf);
    if (axis < 0) return false;
    Vec3 dir;
    dir[axis] = 1;
    struct Run {
      uint64_t from, to;
      std::vector<Vec3> points;
    };
    std::vector<Run> sides;
    // Per end: the segments (positions), their left / right objects, and which positions are
    // spokes (their ids).
    struct End {
      std::vector<std::array<Vec3, 2>> seg;
      std::vector<std::array<ObjectId, 2>> lr;
      std::vector<std::pair<Vec3, uint64_t>> spokes;
      std::vector<std::array<ObjectId, 2>> spoke_pairs;
    };
    End ends[2];
    for (int f = 0; f < np; ++f) {
      const PolygonGvd& g = gvds[f];
      if (polys[f].axis == axis) {
        End& e = ends[polys[f].side == 2 ? 1 : 0];
        if (g.n == 0 && !g.junction) continue;
        // Between two junction cells the face must carry its plane GVD (else a junction lies
        // on the face's border, where the labels show another crossing).
        if (!g.junction && !polys[f].on_domain && junction_sweeps(leaf_across(polys[f]), axis)) {
          return false;
        }
        if (g.junction) {
          for (size_t k = 0; k < g.jsegments.size(); ++k) {
            e.seg.push_back({g.jpoints[g.jsegments[k][0]], g.jpoints[g.jsegments[k][1]]});
            e.lr.push_back(g.jleft_right[k]);
          }
        } else if (!g.pairs.empty()) {
          return false;
        } else if (g.n == 2) {
          // As cell_3d emits them: a spoke's label_a lies left of its piece seen from +axis.
          Vec3 prev = g.spokes[0].p;
          for (size_t k = 0; k <= g.curve.size(); ++k) {
            const Vec3 next = k < g.curve.size() ? g.curve[k] : g.spokes[1].p;
            e.seg.push_back({prev, next});
            e.lr.push_back({g.spokes[0].label_a, g.spokes[0].label_b});
            prev = next;
          }
        } else {
          for (int i = 0; i < g.n; ++i) {
            e.seg.push_back({g.spokes[i].p, g.centroid});
            e.lr.push_back({g.spokes[i].label_a, g.spokes[i].label_b});
          }
        }
        for (int i = 0; i < g.n; ++i) {
          e.spokes.emplace_back(g.spokes[i].p, g.spokes[i].id);
          e.spoke_pairs.push_back({std::min(g.spokes[i].label_a, g.spokes[i].label_b),
                                   std::max(g.spokes[i].label_a, g.spokes[i].label_b)});
        }
        continue;
      }
      if (g.n == 0) continue;
      if (g.n != 2 || g.junction) return false;
      sides.push_back({g.spokes[0].id, g.spokes[1].id, {g.spokes[0].p, g.spokes[1].p}});
    }
    // Paths: maximal chains of one pair through points where exactly two segments meet.
    struct Path {
      ObjectId left, right;
      Vec3 first, last;
      std::vector<Vec3> points;
    };
    // The spoke id at a position of an end where a side face's piece starts (a spoke on the
    // cell's border; those on lines inside a split end face join pieces of one path), or 0.
    auto spoke_at = [&](int e, Vec3 p) -> uint64_t {
      for (const auto& [q, id] : ends[e].spokes) {
        if (!(q == p)) continue;
        for (const Run& r : sides)
          if (r.from == id || r.to == id) return id;
      }
      return 0;
    };
    auto key = [](Vec3 p) { return std::tuple<double, double, double>(p.x, p.y, p.z); };
    std::vector<Path> paths[2];
    for (int e = 0; e < 2; ++e) {
      End& end = ends[e];
      // One direction per curve: the smaller object on the left (a piece walked the other way
      // has its objects on the other sides).
      for (size_t k = 0; k < end.seg.size(); ++k) {
        if (end.lr[k][0] > end.lr[k][1]) {
          std::swap(end.lr[k][0], end.lr[k][1]);
          std::swap(end.seg[k][0], end.seg[k][1]);
        }
      }
      std::map<std::tuple<double, double, double>, int> degree;
      for (const auto& s : end.seg) {
        ++degree[key(s[0])];
        ++degree[key(s[1])];
      }
      std::vector<uint8_t> used(end.seg.size(), 0);
      auto next_from = [&](Vec3 p, ObjectId l, ObjectId r) {
        for (size_t k = 0; k < end.seg.size(); ++k)
          if (!used[k] && end.seg[k][0] == p && end.lr[k][0] == l && end.lr[k][1] == r) return k;
        return end.seg.size();
      };
      for (size_t k = 0; k < end.seg.size(); ++k) {
        if (used[k] || (degree[key(end.seg[k][0])] == 2 && spoke_at(e, end.seg[k][0]) == 0))
          continue;
        Path path{end.lr[k][0], end.lr[k][1], end.seg[k][0], end.seg[k][1], {end.seg[k][0]}};
        size_t at = k;
        for (;;) {
          used[at] = 1;
          const Vec3 q = end.seg[at][1];
          path.points.push_back(q);
          path.last = q;
          if (degree[key(q)] != 2 || spoke_at(e, q) != 0) break;
          at = next_from(q, path.left, path.right);
          if (at == end.seg.size()) return false;
        }
        paths[e].push_back(std::move(path));
      }
      if (std::find(used.begin(), used.end(), 0) != used.end()) return false;  // a loop
    }
    // A junction on a border spoke (a gap's mid-plane on a lattice plane) whose spoke's pair
    // has no piece on this end: that pair's piece has no length here (the other end, or the
    // side face, may show it), a path from the junction to itself.
    for (int e = 0; e < 2; ++e) {
      std::map<std::tuple<double, double, double>, std::vector<std::array<ObjectId, 2>>> at;
      for (size_t k = 0; k < ends[e].seg.size(); ++k)
        for (const Vec3 x : ends[e].seg[k]) at[key(x)].push_back(ends[e].lr[k]);
      for (size_t i = 0; i < ends[e].spokes.size(); ++i) {
        const Vec3 p = ends[e].spokes[i].first;
        const auto it = at.find(key(p));
        if (it == at.end() || it->second.size() < 2 || spoke_at(e, p) == 0) continue;
        const std::array<ObjectId, 2> pair = ends[e].spoke_pairs[i];
        if (std::find(it->second.begin(), it->second.end(), pair) != it->second.end()) continue;
        paths[e].push_back({pair[0], pair[1], p, p, {p, p}});
      }
    }
    if (paths[0].size() != paths[1].size()) return false;
    // From a spoke id, along the side faces' pieces, to the spoke id on the other end (the
    // points passed on the way in `mid`); each start walked once (several paths may end at
    // one spoke where a junction lies on the border).
    std::vector<uint8_t> side_used(sides.size(), 0);
    std::map<uint64_t, std::pair<uint64_t, std::vector<Vec3>>> rungs;
    auto rung = [&](uint64_t from, std::vector<Vec3>& mid) {
      const auto found = rungs.find(from);
      if (found != rungs.end()) {
        mid = found->second.second;
        return found->second.first;
      }
      uint64_t at = from;
      for (size_t steps = 0; steps <= sides.size(); ++steps) {
        bool moved = false;
        for (size_t i = 0; i < sides.size() && !moved; ++i) {
          if (side_used[i]) continue;
          const Run& r = sides[i];
          if (r.from != at && r.to != at) continue;
          side_used[i] = 1;
          const bool fwd = r.from == at;
          if (at != from) mid.push_back(fwd ? r.points.front() : r.points.back());
          at = fwd ? r.to : r.from;
          moved = true;
        }
        if (!moved) break;
      }
      rungs.emplace(from, std::make_pair(at, mid));
      return at;
    };
    const Box box = octree_.box(leaf);
    const double tolerance = 1e-6 * (box.hi.x - box.lo.x);
    // The objects meeting at a junction of an end, sorted.
    auto objects_at = [&](int e, Vec3 p) {
      std::vector<ObjectId> o;
      for (size_t k = 0; k < ends[e].seg.size(); ++k)
        if (ends[e].seg[k][0] == p || ends[e].seg[k][1] == p) {
          o.push_back(ends[e].lr[k][0]);
          o.push_back(ends[e].lr[k][1]);
        }
      for (size_t i = 0; i < ends[e].spokes.size(); ++i)
        if (ends[e].spokes[i].first == p) {
          o.push_back(ends[e].spoke_pairs[i][0]);
          o.push_back(ends[e].spoke_pairs[i][1]);
        }
      std::sort(o.begin(), o.end());
      o.erase(std::unique(o.begin(), o.end()), o.end());
      return o;
    };
    // Junctions match by position (plane GVDs of both ends), else by the objects that meet
    // there when only one junction of each end has them (an ordinary face's centroid).
    auto same_junction = [&](Vec3 p, Vec3 q) {
      Vec3 d = p - q;
      d[axis] = 0;
      if (norm(d) <= tolerance) return true;
      const std::vector<ObjectId> op = objects_at(0, p), oq = objects_at(1, q);
      if (op != oq) return false;
      for (int e = 0; e < 2; ++e) {
        std::vector<Vec3> seen;
        for (const auto& s : ends[e].seg)
          for (const Vec3 x : s)
            if (std::find(seen.begin(), seen.end(), x) == seen.end() && objects_at(e, x) == op)
              seen.push_back(x);
        if (seen.size() != 1) return false;
      }
      return true;
    };
    // A path's end is a plain spoke (one piece ends there, on the border: joined to the other
    // end by a side face's rung) or a junction (several meet, maybe on a spoke).
    auto pieces_at = [&](int e, Vec3 p) {
      int n = 0;
      for (const auto& sg : ends[e].seg) n += (sg[0] == p) + (sg[1] == p);
      return n;
    };
    auto plain_spoke = [&](int e, Vec3 p) { return spoke_at(e, p) != 0 && pieces_at(e, p) == 1; };
    std::vector<Tri> tris;
    std::vector<uint8_t> matched(paths[1].size(), 0);
    for (const Path& lower : paths[0]) {
      std::vector<Vec3> rung_first, rung_last;
      const bool plain_first = plain_spoke(0, lower.first), plain_last = plain_spoke(0, lower.last);
      const uint64_t t_first = plain_first ? rung(spoke_at(0, lower.first), rung_first) : 0;
      const uint64_t t_last = plain_last ? rung(spoke_at(0, lower.last), rung_last) : 0;
      auto ends_match = [&](bool plain, uint64_t target, Vec3 p, Vec3 q) {
        if (plain) return spoke_at(1, q) == target;  // the rung leads there
        if (plain_spoke(1, q)) {
          std::vector<Vec3> unused;
          return spoke_at(0, p) != 0 && rung(spoke_at(0, p), unused) == spoke_at(1, q);
        }
        return same_junction(p, q);
      };
      size_t k = paths[1].size();
      for (size_t i = 0; i < paths[1].size() && k == paths[1].size(); ++i) {
        const Path& upper = paths[1][i];
        if (matched[i] || upper.left != lower.left || upper.right != lower.right) continue;
        if (ends_match(plain_first, t_first, lower.first, upper.first) &&
            ends_match(plain_last, t_last, lower.last, upper.last))
          k = i;
      }
      if (k == paths[1].size()) return false;
      matched[k] = 1;
      const Path& upper = paths[1][k];
      // A junction on spokes at both ends: its rung may pass a split side face's midpoints.
      if (!plain_first && spoke_at(0, lower.first) != 0 && spoke_at(1, upper.first) != 0)
        rung(spoke_at(0, lower.first), rung_first);
      if (!plain_last && spoke_at(0, lower.last) != 0 && spoke_at(1, upper.last) != 0)
        rung(spoke_at(0, lower.last), rung_last);
      if (!ladder_between(lower.points, upper.points, dir, rung_first, rung_last, tris))
        return false;
      for (Tri& t : tris) {
        emit(out, t.v[0], t.v[1], t.v[2], lower.left, lower.right);
        emit(out, t.v[1], t.v[0], t.v[2], lower.right, lower.left);
      }
      tris.clear();
    }
    return std::count(side_used.begin(), side_used.end(), 1) ==
           static_cast<std::ptrdiff_t>(sides.size());
  }

  bool extruded_cell(uint32_t leaf, const detail::FacePolygon* polys, const PolygonGvd* gvds,
                     int np, Sink& out) const {
    ObjectId x = kNoObject, y = kNoObject;
    for (int f = 0; f < np; ++f) {
      for (int i = 0; i < gvds[f].n; ++i) {
        const Spoke& s = gvds[f].spokes[i];
        const ObjectId lo = std::min(s.label_a, s.label_b), hi = std::max(s.label_a, s.label_b);
        if (x == kNoObject) {
          x = lo;
          y = hi;
        }
        if (lo != x || hi != y) return false;
      }
    }
    if (x == kNoObject) return false;
    const int axis = octree_.extruded_axis(leaf);
    bool opposite = false;
    const int slanted = octree_.slanted_axis(leaf, &opposite);
    Vec3 dir;
    if (axis >= 0) {
      dir[axis] = 1;
    } else if (slanted >= 0) {
      dir = slanted_direction(leaf, slanted, opposite, x, y);
    } else if (!skew_direction_ || !skew_direction_(octree_.box(leaf), dir)) {
      return false;
    }
    // One oriented piece per polygon with two spokes (per pair of spokes where an edge crosses
    // C twice, next to a roof's apex): from the spoke where the ring passes from x to y. The
    // rings run counter-clockwise seen from +axis, that is seen from outside on upper faces and
    // from inside on lower ones; reversed on the lower entry faces' and the upper exit faces'
    // opposites, the pieces on the entry faces and those on the exit faces follow C in the
    // same sense (for an axis: as the rings of both faces across it do).
    struct Run {
      uint64_t from, to;
      std::vector<Vec3> points;  // from .. to, ends included
    };
    std::vector<Run> ends[2], sides;
    for (int f = 0; f < np; ++f) {
      const PolygonGvd& g = gvds[f];
      if (g.n == 0) continue;
      if (g.n != 2 && g.pairs.empty()) return false;
      // Where e crosses the face: -1 in (entry), +1 out (exit), 0 along it.
      const double across = dir[polys[f].axis] * (polys[f].side == 2 ? 1.0 : -1.0);
      const int end = across < 0 ? 0 : (across > 0 ? 1 : -1);
      const bool flip = (end == 0 && polys[f].side == 2) || (end == 1 && polys[f].side == 0);
      auto add = [&](const Spoke& sa, const Spoke& sb, const std::vector<Vec3>& curve) {
        const bool forward = (sa.label_a == x) != flip;
        const Spoke& s0 = forward ? sa : sb;
        const Spoke& s1 = forward ? sb : sa;
        Run r{s0.id, s1.id, {s0.p}};
        if (forward) {
          r.points.insert(r.points.end(), curve.begin(), curve.end());
        } else {
          r.points.insert(r.points.end(), curve.rbegin(), curve.rend());
        }
        r.points.push_back(s1.p);
        (end >= 0 ? ends[end] : sides).push_back(std::move(r));
      };
      if (g.n == 2) {
        add(g.spokes[0], g.spokes[1], g.curve);
      } else {
        for (size_t k = 0; k < g.pairs.size(); ++k)
          add(g.spokes[g.pairs[k][0]], g.spokes[g.pairs[k][1]], g.pair_curves[k]);
      }
    }
    // Each end face's pieces chained into paths: one per piece of C in the cell (two where C
    // enters and leaves the cell twice beside a roof's apex).
    struct Path {
      uint64_t first = 0, last = 0;
      std::vector<Vec3> points;
    };
    std::vector<Path> paths[2];
    for (int e = 0; e < 2; ++e) {
      std::vector<Run>& runs = ends[e];
      if (runs.empty()) return false;
      std::vector<uint8_t> used(runs.size(), 0);
      size_t left = runs.size();
      while (left > 0) {
        size_t start = runs.size();
        for (size_t i = 0; i < runs.size() && start == runs.size(); ++i) {
          if (used[i]) continue;
          bool continues = false;
          for (size_t j = 0; j < runs.size(); ++j)
            continues |= !used[j] && runs[j].to == runs[i].from;
          if (!continues) start = i;
        }
        if (start == runs.size()) return false;  // a closed loop: not C
        Path path;
        size_t at = start;
        path.first = runs[at].from;
        path.points = runs[at].points;
        used[at] = 1;
        --left;
        for (;;) {
          size_t next = runs.size();
          for (size_t i = 0; i < runs.size(); ++i)
            if (!used[i] && runs[i].from == runs[at].to) next = i;
          if (next == runs.size()) break;
          path.points.insert(path.points.end(), runs[next].points.begin() + 1,
                             runs[next].points.end());
          used[next] = 1;
          --left;
          at = next;
        }
        path.last = runs[at].to;
        paths[e].push_back(std::move(path));
      }
    }
    if (paths[0].size() != paths[1].size()) return false;
    // The rungs: side-face pieces from an end of an entry path to the same end of an exit
    // path (either direction). Every side-face piece must belong to a rung (else C meets the
    // side faces elsewhere, and the ladder would leave a hole).
    std::vector<uint8_t> used(sides.size(), 0);
    auto rung = [&](uint64_t from, std::vector<Vec3>& mid) {
      uint64_t at = from;
      for (size_t steps = 0; steps <= sides.size(); ++steps) {
        bool moved = false;
        for (size_t i = 0; i < sides.size() && !moved; ++i) {
          if (used[i]) continue;
          const Run& r = sides[i];
          if (r.from != at && r.to != at) continue;
          used[i] = 1;
          const bool fwd = r.from == at;
          std::vector<Vec3> pts = r.points;
          if (!fwd) std::reverse(pts.begin(), pts.end());
          if (at != from) mid.push_back(pts.front());
          mid.insert(mid.end(), pts.begin() + 1, pts.end() - 1);
          at = fwd ? r.to : r.from;
          moved = true;
        }
        if (!moved) break;
      }
      return at;
    };
    std::vector<Tri> final_tris;
    std::vector<uint8_t> matched(paths[1].size(), 0);
    for (const Path& entry : paths[0]) {
      std::vector<Vec3> rung_first, rung_last;
      const uint64_t first_end = rung(entry.first, rung_first);
      size_t k = paths[1].size();
      for (size_t i = 0; i < paths[1].size(); ++i)
        if (!matched[i] && paths[1][i].first == first_end) k = i;
      if (k == paths[1].size()) return false;
      matched[k] = 1;
      if (rung(entry.last, rung_last) != paths[1][k].last) return false;
      if (!ladder(entry.points, paths[1][k].points, dir, rung_first, rung_last, final_tris))
        return false;
    }
    if (std::count(used.begin(), used.end(), 1) != static_cast<std::ptrdiff_t>(sides.size()))
      return false;
    for (const Tri& t : final_tris) {
      emit(out, t.v[0], t.v[1], t.v[2], x, y);
      emit(out, t.v[1], t.v[0], t.v[2], y, x);
    }
    return true;
  }

  struct Tri {
    Vec3 v[3];
  };

  // ladder, also where one of the two paths has no length (a junction on a spoke at one end,
  // its pair's piece only at the other): a fan from that point over the other path, the
  // rungs' midpoints fanned from it too.
  static bool ladder_between(const std::vector<Vec3>& p, const std::vector<Vec3>& q, Vec3 dir,
                             const std::vector<Vec3>& rung_first,
                             const std::vector<Vec3>& rung_last, std::vector<Tri>& tris) {
    const bool p_point = p.front() == p.back(), q_point = q.front() == q.back();
    if (p_point && q_point) return true;  // no piece at either end
    if (!p_point && !q_point) return ladder(p, q, dir, rung_first, rung_last, tris);
    if (!rung_first.empty() || !rung_last.empty()) return false;
    if (q_point) {
      for (size_t i = 0; i + 1 < p.size(); ++i) tris.push_back({{p[i + 1], p[i], q[0]}});
    } else {
      for (size_t j = 0; j + 1 < q.size(); ++j) tris.push_back({{q[j], q[j + 1], p[0]}});
    }
    return true;
  }

  // The ruled ladder between a path P on the entry faces and the path Q on the exit faces
  // (the same piece of C), merged by position along P's chord in the cross-section; the
  // rungs' midpoints split the first and last triangles. False where they do not fit.
  static bool ladder(const std::vector<Vec3>& p, const std::vector<Vec3>& q, Vec3 dir,
                     const std::vector<Vec3>& rung_first, const std::vector<Vec3>& rung_last,
                     std::vector<Tri>& final_tris) {
    Vec3 chord = p.back() - p.front();
    chord = chord - dir * dot(chord, dir);
    const double chord_len = norm(chord);
    if (!(chord_len > 0)) return false;
    chord = chord / chord_len;
    auto along = [&](Vec3 v) { return dot(v - p.front(), chord); };
    std::vector<Tri> tris;
    size_t i = 0, j = 0;
    const size_t m = p.size() - 1, n = q.size() - 1;
    while (i < m || j < n) {
      if (j == n || (i < m && along(p[i + 1]) <= along(q[j + 1]))) {
        tris.push_back({{p[i + 1], p[i], q[j]}});
        ++i;
      } else {
        tris.push_back({{q[j], q[j + 1], p[i]}});
        ++j;
      }
    }
    // Splits the triangle's edge between u and w (either direction) at the points `mid`
    // (ordered from u to w), fanning from the opposite vertex.
    auto split_edge = [](const Tri& t, Vec3 u, Vec3 w, const std::vector<Vec3>& mid,
                         std::vector<Tri>& into) {
      for (int k = 0; k < 3; ++k) {
        const Vec3 a = t.v[k], b = t.v[(k + 1) % 3], c = t.v[(k + 2) % 3];
        std::vector<Vec3> chain;
        if (a == u && b == w) {
          chain = mid;
        } else if (a == w && b == u) {
          chain.assign(mid.rbegin(), mid.rend());
        } else {
          continue;
        }
        Vec3 prev = a;
        for (const Vec3& r : chain) {
          into.push_back({{prev, r, c}});
          prev = r;
        }
        into.push_back({{prev, b, c}});
        return true;
      }
      return false;
    };
    for (size_t k = 0; k < tris.size(); ++k) {
      Tri t = tris[k];
      std::vector<Tri> parts{t};
      if (k == 0 && !rung_first.empty()) {
        parts.clear();
        if (!split_edge(t, p.front(), q.front(), rung_first, parts)) return false;
      }
      if (k + 1 == tris.size() && !rung_last.empty()) {
        std::vector<Tri> again;
        for (const Tri& u : parts)
          if (!split_edge(u, p.back(), q.back(), rung_last, again)) again.push_back(u);
        if (again.size() == parts.size()) return false;
        parts = std::move(again);
      }
      final_tris.insert(final_tris.end(), parts.begin(), parts.end());
    }
    return true;
  }

  // The part of a domain face nearer to each object closes that object's cell: a fan from the
  // face's bisector centroid (or its centre) over the polygon edges, split at bisectors,
  // oriented into the domain.
  void domain_face(const detail::FacePolygon& poly, const PolygonGvd& g, Sink& out) const {
    const bool flip = poly.side == 2;  // the ring runs counter-clockwise around +axis
    if (g.n == 2) {
      // The straight GVD segment p0 -> p1 splits the face into two convex parts; fan each
      // from its first point so that the segment itself is an edge (as in the GVD triangles).
      const Spoke& s0 = g.spokes[0];
      const Spoke& s1 = g.spokes[1];
      auto fan = [&](Vec3 from, int first, int last, Vec3 to, ObjectId obj) {
        Vec3 prev = field_.vertices.position(poly.v[first]);
        auto tri = [&](Vec3 b, Vec3 c) {
          if (flip) std::swap(b, c);
          emit(out, from, b, c, obj, kNoObject);
        };
        for (int k = (first + 1) % poly.n;; k = (k + 1) % poly.n) {
          if (k == (last + 1) % poly.n) break;
          const Vec3 cur = field_.vertices.position(poly.v[k]);
          tri(prev, cur);
          prev = cur;
        }
        tri(prev, to);
      };
      // Region after spoke 0 (label_b of s0): vertices ring_edge0 + 1 .. ring_edge1.
      fan(s0.p, (s0.ring_edge + 1) % poly.n, s1.ring_edge, s1.p, s0.label_b);
      fan(s1.p, (s1.ring_edge + 1) % poly.n, s0.ring_edge, s0.p, s1.label_b);
      return;
    }
    Vec3 centre;
    if (g.n > 0) {
      centre = g.centroid;
    } else {
      for (int i = 0; i < poly.n; ++i) centre = centre + field_.vertices.position(poly.v[i]);
      centre = centre / poly.n;
    }
    auto tri = [&](Vec3 a, Vec3 b, ObjectId obj) {
      if (flip) std::swap(a, b);
      emit(out, a, b, centre, obj, kNoObject);
    };
    for (int i = 0; i < poly.n; ++i) {
      const uint32_t v = poly.v[i], w = poly.v[(i + 1) % poly.n];
      const Vec3 pv = field_.vertices.position(v), pw = field_.vertices.position(w);
      const ObjectId lv = field_.label[v], lw = field_.label[w];
      if (lv == lw) {
        tri(pv, pw, lv);
      } else {
        const Vec3 m = bisector(v, w);
        tri(pv, m, lv);
        tri(m, pw, lw);
      }
    }
  }

  // A traced face's curve between its spokes on octree edges lo < hi, from lo to hi.
  struct Curve {
    uint64_t lo, hi;
    std::vector<Vec3> points;
  };
  static uint64_t curve_hash(uint64_t lo, uint64_t hi) {
    return lo * 0x9e3779b97f4a7c15ull ^ (hi + 0x632be59bd9b4e019ull + (lo << 6) + (lo >> 2));
  }

  const Octree& octree_;
  const DistanceField& field_;
  const LeafVertices* rows_;
  const UnitGeometry& geometry_;
  const SimplexBvh& bvh_;
  std::vector<Curve> curves_;
  std::unordered_map<uint64_t, size_t> curve_index_;
  std::vector<Vec3> refined_;
  FlatMap64 refined_index_;
  std::vector<uint32_t> active_;
  size_t refined_count_ = 0;
  int dim_;
  bool any_junction_ = false;
  bool any_extruded_ = false;
  std::function<bool(const Box&, Vec3&)> skew_direction_;
  std::function<bool(const Box& face, int axis, FaceGvd& out)> junction_face_;
  bool any_cone_ = false;
  std::vector<DoubleCrossing> doubles_;
  FlatMap64 double_index_;  // octree edge -> index in doubles_
};

}  // namespace

LeafPieces::LeafPieces() = default;
LeafPieces::~LeafPieces() = default;
LeafPieces::LeafPieces(LeafPieces&&) noexcept = default;
LeafPieces& LeafPieces::operator=(LeafPieces&&) noexcept = default;

namespace {

// surface_leaves, reading the leaves' vertices from `rows` (optional); with `release`, the
// rows go as soon as they are no longer read: the inactive leaves' once the active ones are
// known, the rest at the end.
std::vector<SurfaceChunk> surface_chunks(const Octree& octree, const DistanceField& field,
                                         LeafVertices* rows, bool release,
                                         const UnitGeometry& geometry, const SimplexBvh& bvh,
                                         const SurfaceOptions& options) {
  const int threads = resolve_threads(options.threads);
  const size_t grain = 512;
  const int arity = octree.dimension == 2 ? 2 : 3;
  // Each leaf's pieces share most of their corners (the cone apex, the spokes): they are
  // deduplicated per leaf first, so the global pass in weld_gvd sorts distinct (point,
  // object, other) records of each leaf rather than every corner.
  CellSurfacer surfacer(octree, field, rows, geometry, bvh, options);
  surfacer.prepare(threads);
  // Only the leaves that emit anything: those the GVD crosses and those on the domain box.
  const std::vector<uint32_t>& active = surfacer.active_leaves();
  // From here on only the active leaves' grids are read (cell() is called on them alone).
  if (release && rows != nullptr) rows->keep_only(active);
  std::vector<SurfaceChunk> chunks;
  chunks.resize((active.size() + grain - 1) / grain + 1);
  // In batches of whole grains when someone watches the progress (about a twentieth each).
  const size_t step =
      options.progress ? std::max<size_t>(grain, (active.size() / 20 + grain - 1) / grain * grain)
                       : std::max<size_t>(active.size(), 1);
  for (size_t start = 0; start < active.size(); start += step) {
    parallel_for(
        std::min(step, active.size() - start), threads,
        [&](size_t lo, size_t hi, int) {
          const size_t b = start + lo, e = start + hi;
          if (options.cancel != nullptr && options.cancel->load(std::memory_order_relaxed)) {
            throw Error(ErrorCode::kCancelled, "surfacing cancelled");
          }
          // Filled locally and moved in once: chunks next to each other in the array are
          // worked on by different threads (no false sharing on their vectors).
          SurfaceChunk chunk;
          std::vector<Piece> local;
          for (size_t i = b; i < e; ++i) {
            local.clear();
            surfacer.cell(active[i], local);
            chunk.add(local, arity);
          }
          // Kept until the weld, where memory peaks: without the growth's slack (a third on
          // average), at the cost of one copy of a chunk that is still in cache.
          chunk.corners.shrink_to_fit();
          chunk.sides.shrink_to_fit();
          chunk.simplices.shrink_to_fit();
          chunk.twin.shrink_to_fit();
          chunks[b / grain] = std::move(chunk);
        },
        grain);
    if (options.progress)
      options.progress(static_cast<double>(std::min(start + step, active.size())) / active.size());
  }
  if (release && rows != nullptr) rows->release();
  return chunks;
}

}  // namespace

LeafPieces surface_leaves(const Octree& octree, const DistanceField& field,
                          const UnitGeometry& geometry, const SimplexBvh& bvh,
                          const SurfaceOptions& options) {
  LeafPieces out;
  out.impl_ = std::make_unique<LeafPieces::Impl>();
  out.impl_->chunks = surface_chunks(octree, field, nullptr, false, geometry, bvh, options);
  return out;
}

LeafPieces surface_leaves_releasing_lists(const Octree& octree, const DistanceField& field,
                                          LeafVertices& leaf_vertices, const UnitGeometry& geometry,
                                          const SimplexBvh& bvh, const SurfaceOptions& options) {
  LeafPieces out;
  out.impl_ = std::make_unique<LeafPieces::Impl>();
  out.impl_->chunks = surface_chunks(octree, field, &leaf_vertices, true, geometry, bvh, options);
  return out;
}

Gvd extract_gvd(const Octree& octree, const DistanceField& field, const UnitGeometry& geometry,
                const SimplexBvh& bvh, const Domain& domain, const SurfaceOptions& options) {
  return weld_gvd(surface_leaves(octree, field, geometry, bvh, options), geometry, bvh, domain,
                  options);
}

}  // namespace gvd::surface

namespace gvd::surface {

std::vector<uint32_t> unswept_junction_leaves(const Octree& octree, const DistanceField& field,
                                              const LeafVertices* rows,
                                              const UnitGeometry& geometry, const SimplexBvh& bvh,
                                              const SurfaceOptions& options) {
  std::vector<uint32_t> junctions, out;
  for (size_t i = 0; i < octree.certified.size(); ++i)
    if (octree.junction_axis(static_cast<uint32_t>(i)) >= 0)
      junctions.push_back(static_cast<uint32_t>(i));
  if (junctions.empty() || !options.junction_face) return out;
  const CellSurfacer surfacer(octree, field, rows, geometry, bvh, options);
  std::vector<uint8_t> fails(junctions.size(), 0);
  parallel_for(
      junctions.size(), resolve_threads(options.threads),
      [&](size_t b, size_t e, int) {
        for (size_t i = b; i < e; ++i)
          fails[i] = !surfacer.junction_sweeps_as_it_stands(junctions[i]);
      },
      8);
  for (size_t i = 0; i < junctions.size(); ++i)
    if (fails[i]) out.push_back(junctions[i]);
  return out;
}

}  // namespace gvd::surface
