#include "gvd/surface/extract_gvd.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <tuple>

#include "cell_faces.h"
#include "gvd/common/error.h"
#include "gvd/common/parallel.h"
#include "gvd/common/radix_sort.h"

namespace gvd {
namespace {

// One oriented simplex of one object's cell boundary (2D uses p[0], p[1]).
struct Piece {
  Vec3 p[3];
  ObjectId object;
  ObjectId other;
  Vec3 witness;  // a point on an object near the piece: bounds the clearance search
};

// Where a cell's pieces go, with the witness for all of them.
struct Sink {
  std::vector<Piece>& out;
  Vec3 witness;
};

// A bisector point on a polygon edge and the labels / positions of the edge's ends, in the
// polygon's cyclic order.
struct Spoke {
  Vec3 p;
  ObjectId label_a, label_b;
  uint64_t edge;  // the octree edge (smaller vertex index << 32 | larger)
  int ring_edge;  // index i of the polygon edge (v[i], v[i+1]) it lies on
};

struct PolygonGvd {
  int n = 0;
  Spoke spokes[8];
  Vec3 centroid;
};

class CellSurfacer {
 public:
  CellSurfacer(const Octree& octree, const DistanceField& field, const UnitGeometry& geometry,
               const SimplexBvh& bvh)
      : octree_(octree), field_(field), geometry_(geometry), bvh_(bvh), dim_(octree.dimension) {}

  Vec3 bisector(uint32_t v0, uint32_t v1) const { return detail::bisector_point(field_, v0, v1); }

  // The closest point of a spoke's edge end: a point on an object right next to the spoke,
  // which bounds the clearance search at the pieces made from it.
  Vec3 witness(const Spoke& s) const {
    return field_.closest[field_.point[static_cast<uint32_t>(s.edge >> 32)]];
  }

  PolygonGvd polygon(const detail::FacePolygon& poly) const {
    PolygonGvd out;
    Vec3 sum;
    for (int i = 0; i < poly.n; ++i) {
      const uint32_t v = poly.v[i], w = poly.v[(i + 1) % poly.n];
      const ObjectId la = field_.label[v], lb = field_.label[w];
      if (la == lb) continue;
      Spoke& s = out.spokes[out.n++];
      s.p = bisector(v, w);
      s.label_a = la;
      s.label_b = lb;
      s.edge = v < w ? (uint64_t{v} << 32 | w) : (uint64_t{w} << 32 | v);
      s.ring_edge = i;
      sum = sum + s.p;
    }
    if (out.n > 0) out.centroid = sum / out.n;
    if (out.n >= 3) out.centroid = junction_point(poly, out);
    return out;
  }

  // Adds the distinct objects a polygon's spokes separate to labels[0..nl); nl becomes 4 (and
  // stays) once a fourth one is seen, which callers treat as "not a three-object junction".
  static void add_spoke_labels(const PolygonGvd& g, ObjectId (&labels)[3], int& nl) {
    for (int i = 0; i < g.n && nl <= 3; ++i) {
      for (ObjectId l : {g.spokes[i].label_a, g.spokes[i].label_b}) {
        if (std::find(labels, labels + std::min(nl, 3), l) != labels + std::min(nl, 3)) continue;
        if (nl >= 3) {
          nl = 4;
          return;
        }
        labels[nl++] = l;
      }
    }
  }

  // The cone apex of one spoke curve of a 3D cell: where the curve's spokes separate exactly
  // three objects, the point nearest the bisector centroid on the line equidistant from them
  // (refined once); else, or if it leaves the cell, the centroid (the paper's rule).
  Vec3 cell_junction_point(uint32_t leaf, const PolygonGvd* gvds, int np, const int* comp_of,
                           int component, Vec3 centroid) const {
    ObjectId labels[3];
    int nl = 0;
    for (int f = 0; f < np; ++f)
      if (comp_of[f] == component) add_spoke_labels(gvds[f], labels, nl);
    if (nl != 3) return centroid;
    const Box box = octree_.box(leaf);
    Vec3 x = centroid;
    for (int iteration = 0; iteration < 2; ++iteration) {
      Vec3 p[3];
      for (int k = 0; k < 3; ++k) {
        const ClosestHit hit =
            bvh_.nearest_if(x, [&](uint32_t s) { return geometry_.object_of[s] == labels[k]; });
        if (!hit.found()) return centroid;
        p[k] = hit.point;
      }
      // Nearest point to the centroid with x.n1 = k1, x.n2 = k2 (equidistant from p0, p1, p2):
      // x = c + a n1 + b n2.
      const Vec3 n1 = p[1] - p[0], n2 = p[2] - p[0];
      const double k1 = 0.5 * (norm2(p[1]) - norm2(p[0]));
      const double k2 = 0.5 * (norm2(p[2]) - norm2(p[0]));
      const double a11 = dot(n1, n1), a12 = dot(n1, n2), a22 = dot(n2, n2);
      const double det = a11 * a22 - a12 * a12;
      if (!(det > 1e-12 * a11 * a22)) return centroid;
      const double r1 = k1 - dot(centroid, n1), r2 = k2 - dot(centroid, n2);
      const double a = (r1 * a22 - r2 * a12) / det;
      const double b = (a11 * r2 - a12 * r1) / det;
      const Vec3 next = centroid + n1 * a + n2 * b;
      for (int i = 0; i < 3; ++i)
        if (!(next[i] >= box.lo[i] && next[i] <= box.hi[i])) return centroid;
      x = next;
    }
    return x;
  }

  // Where three objects' regions meet on a face, the paper joins the spokes at the centroid of
  // the bisectors, which can sit a good part of the cell away from the true junction. Instead:
  // the point of the face plane equidistant from the three objects' closest points, refined
  // once from there; kept only if it lies in the face, else the centroid. Computed from the
  // face's own data, so both cells of a face get the same point.
  Vec3 junction_point(const detail::FacePolygon& poly, const PolygonGvd& g) const {
    ObjectId labels[3];
    int nl = 0;
    add_spoke_labels(g, labels, nl);
    if (nl != 3) return g.centroid;  // two objects, or four or more: keep the centroid
    const int w = poly.axis;         // the face's normal axis (2 for 2D cells: z)
    const int u = (w + 1) % 3, v = (w + 2) % 3;
    Box face;
    for (int i = 0; i < poly.n; ++i) face.extend(field_.vertices.position(poly.v[i]));
    Vec3 r = g.centroid;
    for (int iteration = 0; iteration < 2; ++iteration) {
      Vec3 p[3];
      for (int k = 0; k < 3; ++k) {
        const ClosestHit hit =
            bvh_.nearest_if(r, [&](uint32_t s) { return geometry_.object_of[s] == labels[k]; });
        if (!hit.found()) return g.centroid;
        p[k] = hit.point;
      }
      // 2 x . (p1 - p0) = |p1|^2 - |p0|^2 and the same for p2, with x[w] = r[w] fixed.
      const Vec3 d1 = p[1] - p[0], d2 = p[2] - p[0];
      const double c1 = 0.5 * (norm2(p[1]) - norm2(p[0])) - r[w] * d1[w];
      const double c2 = 0.5 * (norm2(p[2]) - norm2(p[0])) - r[w] * d2[w];
      const double det = d1[u] * d2[v] - d1[v] * d2[u];
      const double scale = (norm2(d1) + norm2(d2)) + 1e-300;
      if (!(std::fabs(det) > 1e-12 * scale)) return g.centroid;
      Vec3 x = r;
      x[u] = (c1 * d2[v] - c2 * d1[v]) / det;
      x[v] = (d1[u] * c2 - d2[u] * c1) / det;
      if (!(x[u] >= face.lo[u] && x[u] <= face.hi[u] && x[v] >= face.lo[v] && x[v] <= face.hi[v]))
        return g.centroid;
      r = x;
    }
    return r;
  }

  void cell(uint32_t leaf, std::vector<Piece>& pieces) const {
    const LeafGrid grid = field_.grid(octree_, leaf);
    Sink out{pieces, field_.closest[field_.point[grid[0]]]};
    bool mixed = false;
    const ObjectId first = field_.label[grid[0]];
    for (uint32_t v : grid)
      if (v != kNoVertex && field_.label[v] != first) mixed = true;
    if (dim_ == 2) {
      cell_2d(leaf, grid, mixed, out);
    } else {
      cell_3d(leaf, grid, mixed, out);
    }
  }

 private:
  static void emit(Sink& out, Vec3 a, Vec3 b, Vec3 c, ObjectId obj, ObjectId other) {
    if (obj == kNoObject || obj == kManyObjects) return;
    if (a == b || b == c || a == c) return;  // collapsed: removing it keeps the surface closed
    out.out.push_back({{a, b, c}, obj, other, out.witness});
  }
  static void emit(Sink& out, Vec3 a, Vec3 b, ObjectId obj, ObjectId other) {
    if (obj == kNoObject || obj == kManyObjects) return;
    if (a == b) return;
    out.out.push_back({{a, b, Vec3{}}, obj, other, out.witness});
  }

  void cell_2d(uint32_t leaf, const LeafGrid& grid, bool mixed, Sink& out) const {
    detail::FacePolygon poly;
    detail::for_each_face_polygon(octree_, grid, leaf,
                                  [&](const detail::FacePolygon& p) { poly = p; });
    const PolygonGvd g = mixed ? polygon(poly) : PolygonGvd{};
    // The ring runs counter-clockwise, so label_a lies to the left of bisector -> centroid.
    // Two spokes through their midpoint are one straight segment: emit it whole.
    if (g.n == 2) {
      out.witness = witness(g.spokes[0]);
      emit(out, g.spokes[0].p, g.spokes[1].p, g.spokes[0].label_a, g.spokes[0].label_b);
      emit(out, g.spokes[1].p, g.spokes[0].p, g.spokes[0].label_b, g.spokes[0].label_a);
    } else {
      for (int i = 0; i < g.n; ++i) {
        const Spoke& s = g.spokes[i];
        out.witness = witness(s);
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
      gvds[np] = mixed ? polygon(p) : PolygonGvd{};
      any_domain |= p.on_domain;
      ++np;
    });
    if (!mixed && !any_domain) return;
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
            if (gvds[f].spokes[i].edge == gvds[h].spokes[j].edge) comp[find(f)] = find(h);
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
      if (g.n == 2) {
        // Two spokes meet at their midpoint in a straight line: one triangle per side instead
        // of two, with the same edges as the cell across (which merges the same face).
        const Spoke& s0 = g.spokes[0];
        out.witness = witness(s0);
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
        out.witness = witness(s);
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

  // The part of a domain face nearer to each object closes that object's cell: a fan from the
  // face's bisector centroid (or its centre) over the polygon edges, split at bisectors,
  // oriented into the domain.
  void domain_face(const detail::FacePolygon& poly, const PolygonGvd& g, Sink& out) const {
    const bool flip = poly.side == 2;  // the ring runs counter-clockwise around +axis
    if (g.n == 2) {
      // The straight GVD segment p0 -> p1 splits the face into two convex parts; fan each
      // from its first point so that the segment itself is an edge (as in the GVD triangles).
      const Spoke& s0 = g.spokes[0];
      out.witness = witness(s0);
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

  const Octree& octree_;
  const DistanceField& field_;
  const UnitGeometry& geometry_;
  const SimplexBvh& bvh_;
  int dim_;
};

struct Corner {
  Vec3 p;
  ObjectId object, other;
  uint32_t piece;
  uint8_t k;
};

uint64_t position_hash(Vec3 p) {
  uint64_t h = 0x9e3779b97f4a7c15ull;
  for (double d : {p.x, p.y, p.z}) {
    if (d == 0) d = 0.0;  // -0 and +0 are the same point
    uint64_t bits;
    std::memcpy(&bits, &d, sizeof bits);
    h ^= bits + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
  }
  return h;
}

// Within a run of equal hashes: by position, so every distinct point is one run (its clearance
// is computed once) and, within it, one vertex per (object, other object).
bool corner_less(const Corner& a, const Corner& b) {
  return std::tie(a.p.x, a.p.y, a.p.z, a.object, a.other) <
         std::tie(b.p.x, b.p.y, b.p.z, b.object, b.other);
}

}  // namespace

Gvd extract_gvd(const Octree& octree, const DistanceField& field, const UnitGeometry& geometry,
                const SimplexBvh& bvh, const Domain& domain, const SurfaceOptions& options) {
  const int dim = octree.dimension;
  const int threads = resolve_threads(options.threads);
  const size_t n = octree.leaf_count();
  const size_t grain = 512;
  std::vector<std::vector<Piece>> chunks((n + grain - 1) / grain + 1);
  CellSurfacer surfacer(octree, field, geometry, bvh);
  parallel_for(
      n, threads,
      [&](size_t b, size_t e, int) {
        if (options.cancel != nullptr && options.cancel->load(std::memory_order_relaxed)) {
          throw Error(ErrorCode::kCancelled, "surfacing cancelled");
        }
        std::vector<Piece>& out = chunks[b / grain];
        for (size_t i = b; i < e; ++i) surfacer.cell(static_cast<uint32_t>(i), out);
      },
      grain);
  std::vector<Piece> pieces;
  {
    size_t total = 0;
    for (const auto& c : chunks) total += c.size();
    pieces.reserve(total);
    for (auto& c : chunks) {
      pieces.insert(pieces.end(), c.begin(), c.end());
      std::vector<Piece>().swap(c);
    }
  }

  // Vertices: one per (object, other object, exact position).
  const int arity = dim == 2 ? 2 : 3;
  std::vector<Corner> corners;
  corners.reserve(pieces.size() * arity);
  for (uint32_t i = 0; i < pieces.size(); ++i) {
    for (int k = 0; k < arity; ++k) {
      corners.push_back(
          {pieces[i].p[k], pieces[i].object, pieces[i].other, i, static_cast<uint8_t>(k)});
    }
  }
  {
    // Make identical points contiguous: radix sort by a hash of the position, then order each
    // (tiny) run of equal hashes exactly — much cheaper than sorting the corners themselves.
    std::vector<std::pair<uint64_t, uint32_t>> keyed(corners.size());
    parallel_for(corners.size(), threads, [&](size_t b, size_t e, int) {
      for (size_t i = b; i < e; ++i)
        keyed[i] = {position_hash(corners[i].p), static_cast<uint32_t>(i)};
    });
    radix_sort(keyed, [](const std::pair<uint64_t, uint32_t>& x) { return x.first; });
    for (size_t i = 0; i < keyed.size();) {
      size_t j = i + 1;
      while (j < keyed.size() && keyed[j].first == keyed[i].first) ++j;
      if (j - i > 1) {
        std::sort(keyed.begin() + i, keyed.begin() + j, [&](const auto& a, const auto& b) {
          return corner_less(corners[a.second], corners[b.second]);
        });
      }
      i = j;
    }
    std::vector<Corner> ordered(corners.size());
    for (size_t i = 0; i < keyed.size(); ++i) ordered[i] = corners[keyed[i].second];
    corners = std::move(ordered);
  }

  // Exact clearance once per distinct point; the pieces' witnesses bound the search.
  std::vector<size_t> run_start;
  for (size_t i = 0; i < corners.size(); ++i) {
    if (i == 0 || corners[i].p != corners[i - 1].p) run_start.push_back(i);
  }
  run_start.push_back(corners.size());
  const size_t runs = run_start.size() - 1;
  std::vector<double> run_clearance(runs);
  parallel_for(
      runs, threads,
      [&](size_t b, size_t e, int) {
        for (size_t r = b; r < e; ++r) {
          const Vec3 p = corners[run_start[r]].p;
          double bound2 = 1e300;
          for (size_t i = run_start[r]; i < run_start[r + 1]; ++i)
            bound2 = std::min(bound2, dist2(p, pieces[corners[i].piece].witness));
          const ClosestHit hit = bvh.nearest(p, bound2);
          run_clearance[r] = std::sqrt(hit.found() ? hit.dist2 : bound2) * domain.side;
        }
      },
      1024);

  Gvd gvd;
  gvd.dimension = dim;
  gvd.cells.resize(geometry.object_count);
  for (uint32_t o = 0; o < geometry.object_count; ++o) gvd.cells[o].object = o;
  std::vector<uint32_t> index_of(pieces.size() * arity);
  for (size_t r = 0; r < runs; ++r) {
    const Vec3 user = domain.from_unit(corners[run_start[r]].p);
    for (size_t i = run_start[r]; i < run_start[r + 1]; ++i) {
      const Corner& c = corners[i];
      GvdCell& cell = gvd.cells[c.object];
      if (i == run_start[r] || c.object != corners[i - 1].object ||
          c.other != corners[i - 1].other) {
        cell.positions.push_back(user);
        cell.other.push_back(c.other);
        cell.clearance.push_back(run_clearance[r]);
      }
      index_of[c.piece * arity + c.k] = static_cast<uint32_t>(cell.positions.size() - 1);
    }
  }
  for (uint32_t i = 0; i < pieces.size(); ++i) {
    GvdCell& cell = gvd.cells[pieces[i].object];
    for (int k = 0; k < arity; ++k) cell.indices.push_back(index_of[i * arity + k]);
  }
  return gvd;
}

}  // namespace gvd
