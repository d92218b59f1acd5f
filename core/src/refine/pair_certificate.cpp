#include "gvd/refine/pair_certificate.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <span>
#include <tuple>
#include <utility>

#include "gvd/common/cancel.h"
#include "gvd/geometry/primitives.h"

namespace gvd::refine {

using namespace gvd::scene;
using namespace gvd::octree;

namespace {

// A plane (2D: a line) n . x = offset with a unit normal.
struct Plane {
  Vec3 n;
  double offset = 0;
  double signed_distance(Vec3 x) const { return dot(n, x) - offset; }
};

// The plane of the patch, from its best-conditioned simplex (largest area / length).
bool fit_plane(const UnitGeometry& g, const std::vector<uint32_t>& patch, Plane& plane) {
  double best = 0;
  for (uint32_t s : patch) {
    const Simplex& t = g.simplices[s];
    const Vec3 a = g.points[t.v[0]], b = g.points[t.v[1]];
    if (g.dimension == 2) {
      const Vec3 d = b - a;
      const double l2 = norm2(d);
      if (l2 > best) {
        best = l2;
        const double l = std::sqrt(l2);
        plane.n = Vec3{-d.y / l, d.x / l, 0};
        plane.offset = dot(plane.n, a);
      }
    } else {
      const Vec3 m = cross(b - a, g.points[t.v[2]] - a);
      const double m2 = norm2(m);
      if (m2 > best) {
        best = m2;
        plane.n = m / std::sqrt(m2);
        plane.offset = dot(plane.n, a);
      }
    }
  }
  return best > 0;
}

// Does the line (3D: the planes' intersection; 2D: the lines' intersection point) of two
// planes meet the box (inflated by a hair)? Coincident planes count as meeting.
bool planes_meet_in(int dim, const Plane& p, const Plane& q, const Box& box, double flat) {
  const double hair = 1e-12;
  if (dim == 2) {
    const double det = p.n.x * q.n.y - p.n.y * q.n.x;
    if (std::abs(det) < 1e-12) {
      return std::abs(dot(q.n, p.n * p.offset) - q.offset) <= flat;
    }
    const double x = (p.offset * q.n.y - q.offset * p.n.y) / det;
    const double y = (p.n.x * q.offset - q.n.x * p.offset) / det;
    return x >= box.lo.x - hair && x <= box.hi.x + hair && y >= box.lo.y - hair &&
           y <= box.hi.y + hair;
  }
  const Vec3 m = cross(p.n, q.n);
  const double m2 = norm2(m);
  if (m2 < 1e-24) {
    return std::abs(dot(q.n, p.n * p.offset) - q.offset) <= flat;
  }
  const Vec3 x0 = (cross(q.n, m) * p.offset + cross(m, p.n) * q.offset) / m2;
  double t0 = -1e300, t1 = 1e300;
  for (int i = 0; i < 3; ++i) {
    const double lo = box.lo[i] - hair, hi = box.hi[i] + hair;
    if (std::abs(m[i]) < 1e-300) {
      if (x0[i] < lo || x0[i] > hi) return false;
      continue;
    }
    double a = (lo - x0[i]) / m[i], b = (hi - x0[i]) / m[i];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  }
  return t0 <= t1;
}

/// The angle the directions of `normals` seen in the plane square to axis m span (at most a
/// half turn apart from the first; 2 pi where one of them lies within ~1 degree of m, which
/// leaves it no direction in that plane).
double span_square_to(const std::vector<Vec3>& normals, int m) {
  constexpr double kPi = 3.14159265358979323846;
  const int u = (m + 1) % 3, w = (m + 2) % 3;
  const double first = std::atan2(normals[0][w], normals[0][u]);
  double lo = 0, hi = 0;
  for (Vec3 n : normals) {
    if (!(std::hypot(n[u], n[w]) > 0.02 * norm(n))) return 2 * kPi;
    double a = std::atan2(n[w], n[u]) - first;
    if (a > kPi) a -= 2 * kPi;
    if (a < -kPi) a += 2 * kPi;
    lo = std::min(lo, a);
    hi = std::max(hi, a);
  }
  return hi - lo;
}

// The plane (2D: line) of one simplex, its normal from the vertex order; false if degenerate.
bool simplex_plane(const UnitGeometry& g, uint32_t s, Plane& plane) {
  const Simplex& t = g.simplices[s];
  const Vec3 a = g.points[t.v[0]], b = g.points[t.v[1]];
  const Vec3 m =
      g.dimension == 2 ? Vec3{a.y - b.y, b.x - a.x, 0} : cross(b - a, g.points[t.v[2]] - a);
  const double l = norm(m);
  if (!(l > 0)) return false;
  plane.n = m / l;
  plane.offset = dot(plane.n, a);
  return true;
}

// The plane of simplex s with its normal out of its object's material where that is known
// (`facing`, PairCertifier::facing_: -1 turns the vertex order's normal), else the vertex
// order's.
bool oriented_plane(const UnitGeometry& g, std::span<const int8_t> facing, uint32_t s,
                    Plane& plane) {
  if (!simplex_plane(g, s, plane)) return false;
  if (s < facing.size() && facing[s] < 0) {
    plane.n = plane.n * -1.0;
    plane.offset = -plane.offset;
  }
  return true;
}

// A convex polygon in 3D: a triangle clipped by at most 6 box planes and 3 triangle sides.
struct Polygon {
  std::array<Vec3, 16> p;
  int n = 0;
};

// Keeps the part of `poly` where dot(h, x) <= offset (Sutherland-Hodgman, one plane).
void clip(Polygon& poly, Vec3 h, double offset) {
  Polygon out;
  for (int i = 0; i < poly.n && out.n + 2 <= static_cast<int>(out.p.size()); ++i) {
    const Vec3 s = poly.p[(i + poly.n - 1) % poly.n], e = poly.p[i];
    const double ds = dot(h, s) - offset, de = dot(h, e) - offset;
    if (de <= 0) {
      if (ds > 0) out.p[out.n++] = s + (e - s) * (ds / (ds - de));
      out.p[out.n++] = e;
    } else if (ds <= 0) {
      out.p[out.n++] = s + (e - s) * (ds / (ds - de));
    }
  }
  poly = out;
}

void clip_to_box(Polygon& poly, const Box& box) {
  for (int i = 0; i < 3 && poly.n > 0; ++i) {
    Vec3 h;
    h[i] = 1;
    clip(poly, h, box.hi[i]);
    clip(poly, h * -1.0, -box.lo[i]);
  }
}

double area(const Polygon& poly) {
  Vec3 sum;
  for (int i = 1; i + 1 < poly.n; ++i)
    sum = sum + cross(poly.p[i] - poly.p[0], poly.p[i + 1] - poly.p[0]);
  return 0.5 * norm(sum);
}

// A reflection x -> x - 2 (n . x - offset) n in a plane with unit normal n.
Vec3 reflect_point(const Plane& p, Vec3 x) { return x - p.n * (2 * p.signed_distance(x)); }
Vec3 reflect_vector(const Plane& p, Vec3 v) { return v - p.n * (2 * dot(p.n, v)); }

// Do the triangles of object `from` clipped to `clip_box` lie strictly on the side `side`
// (+1 / -1) of `mirror` and, reflected, on the triangles of object `onto`? Coverage by areas of
// coplanar (within `round`, PairCertifier::mirror_round_), equally oriented triangles (out of the
// material where `facing` knows it, else by vertex order), which a closed mesh does not overlap, up
// to `round` times the piece's perimeter; the candidates come from the BVH around each reflected
// piece. Triangles `buried` inside their object (glued between its parts) are neither pieces
// nor covers. False also when more than `cap` triangles of `from` meet the box.
bool reflects_onto(const UnitGeometry& g, std::span<const int8_t> facing,
                   std::span<const uint8_t> buried, const SimplexBvh& bvh, const Plane& mirror,
                   int side, ObjectId from, ObjectId onto, const Box& clip_box, size_t cap,
                   double flat, double round) {
  const int dim = g.dimension;
  auto is_buried = [&](uint32_t s) { return s < buried.size() && buried[s] != 0; };
  std::vector<uint32_t> sources;
  if (!bvh.visit_overlapping(clip_box, [&](uint32_t s) {
        if (g.object_of[s] == from && !is_buried(s) &&
            simplex_overlaps_box(dim, g.points, g.simplices[s], clip_box, 0))
          sources.push_back(s);
        return sources.size() <= cap;
      }))
    return false;
  // The simplices of `onto` coplanar with a reflected piece, with the same orientation.
  auto for_each_cover = [&](const Box& piece, Vec3 normal, Vec3 on_plane, auto&& f) {
    Box query = piece;
    for (int i = 0; i < dim; ++i) {
      query.lo[i] -= round;
      query.hi[i] += round;
    }
    bvh.visit_overlapping(query, [&](uint32_t u) {
      Plane other;
      if (g.object_of[u] == onto && !is_buried(u) && oriented_plane(g, facing, u, other) &&
          dot(other.n, normal) >= 1 - 1e-12 && std::abs(other.signed_distance(on_plane)) <= round)
        f(u, other);
      return true;
    });
  };
  for (uint32_t s : sources) {
    Plane own;
    if (!oriented_plane(g, facing, s, own)) return false;
    const Vec3 rn = reflect_vector(mirror, own.n);
    const Simplex& t = g.simplices[s];
    Polygon poly;
    for (int e = 0; e < 3; ++e) poly.p[poly.n++] = g.points[t.v[e]];
    clip_to_box(poly, clip_box);
    const double own_area = poly.n >= 3 ? area(poly) : 0;
    if (!(own_area > 0)) continue;
    Box piece;
    double perimeter = 0;
    for (int i = 0; i < poly.n; ++i) {
      if (!(side * mirror.signed_distance(poly.p[i]) > flat)) return false;
      perimeter += dist(poly.p[i], poly.p[(i + 1) % poly.n]);
    }
    for (int i = 0; i < poly.n; ++i) {
      poly.p[i] = reflect_point(mirror, poly.p[i]);
      piece.extend(poly.p[i]);
    }
    double covered = 0;
    for_each_cover(piece, rn, poly.p[0], [&](uint32_t u, const Plane& other) {
      Polygon part = poly;
      const Simplex& w = g.simplices[u];
      // w's sides run around the normal of its vertex order, which `other` may have turned.
      const Vec3 order_normal = u < facing.size() && facing[u] < 0 ? other.n * -1.0 : other.n;
      for (int e = 0; e < 3 && part.n > 0; ++e) {
        const Vec3 a = g.points[w.v[e]], b = g.points[w.v[(e + 1) % 3]];
        const Vec3 outward = cross(b - a, order_normal);  // w's inside is where this is <= 0
        clip(part, outward, dot(outward, a));
      }
      if (part.n >= 3) covered += area(part);
    });
    if (covered < own_area - round * perimeter) return false;
  }
  return true;
}

}  // namespace

namespace {

/// std::sort under a cancel flag: chunks of kSortChunk sorted, then merged pairwise, `poll`
/// between any two of those steps (a whole sort of the 1M sides of a 327k-triangle scene
/// takes ~100 ms on this machine, a chunk or a merge pass a few). `less` must be a strict
/// total order, so that the result is std::sort's.
template <class T, class Less, class Poll>
void sort_polling(std::vector<T>& v, Less less, Poll poll) {
  constexpr size_t kSortChunk = size_t{1} << 16;
  const size_t n = v.size();
  for (size_t b = 0; b < n; b += kSortChunk) {
    poll();
    std::sort(v.begin() + static_cast<std::ptrdiff_t>(b),
              v.begin() + static_cast<std::ptrdiff_t>(std::min(n, b + kSortChunk)), less);
  }
  for (size_t width = kSortChunk; width < n; width *= 2) {
    for (size_t b = 0; b + width < n; b += 2 * width) {
      poll();
      const auto first = v.begin() + static_cast<std::ptrdiff_t>(b);
      std::inplace_merge(first, first + static_cast<std::ptrdiff_t>(width),
                         v.begin() + static_cast<std::ptrdiff_t>(std::min(n, b + 2 * width)), less);
    }
  }
}

// A side of a simplex keyed by its object and its end points' canonical indices (3D: side
// s * 3 + e runs from vertex e to e + 1 of simplex s; 2D: side s * 2 + e is end point e).
struct SideRecord {
  uint32_t object, lo, hi, side;
};

// Parts of one object that share an edge: the most triangles around one edge that are paired.
constexpr size_t kMaxAroundEdge = 16;

// Pairs the n > 2 triangles around one edge (3D) where closed parts of one object meet along
// it: three boxes written as one object, a slot's walls on its floor. By the input's vertex
// indices when each part has its own (every index pair twice); else around the edge by angle
// (an STL's welded corners): the triangles' vertex orders must alternate around it (each
// part's pair runs the edge both ways), coplanar ones (faces glued together) taking the turn
// the alternation asks, and each is paired with its neighbour on the side away from its
// normal, the material's side when the input's normals point out. False (non-manifold) when
// neither works.
bool pair_around_edge(const UnitGeometry& g, const std::vector<uint32_t>& canonical,
                      std::span<const SideRecord> group, std::vector<uint32_t>& across) {
  const size_t n = group.size();
  if (n % 2 != 0 || n > kMaxAroundEdge) return false;
  auto pair = [&](uint32_t x, uint32_t y) {
    across[x] = y / 3;
    across[y] = x / 3;
  };
  std::array<std::pair<uint64_t, uint32_t>, kMaxAroundEdge> by_index;
  for (size_t k = 0; k < n; ++k) {
    const Simplex& t = g.simplices[group[k].side / 3];
    const int e = static_cast<int>(group[k].side % 3);
    const uint32_t a = std::min(t.v[e], t.v[(e + 1) % 3]), b = std::max(t.v[e], t.v[(e + 1) % 3]);
    by_index[k] = {(uint64_t{a} << 32) | b, group[k].side};
  }
  std::sort(by_index.begin(), by_index.begin() + static_cast<std::ptrdiff_t>(n));
  bool twice = true;
  for (size_t k = 0; k < n && twice; k += 2) {
    twice = by_index[k].first == by_index[k + 1].first &&
            (k + 2 >= n || by_index[k + 2].first != by_index[k].first);
  }
  if (twice) {
    for (size_t k = 0; k < n; k += 2) pair(by_index[k].second, by_index[k + 1].second);
    return true;
  }
  // Around the edge: angle of each triangle's third vertex about the line lo -> hi, and
  // whether the triangle runs the edge lo -> hi (then its normal turns the way angles grow).
  const Vec3 p = g.points[group[0].lo], d = g.points[group[0].hi] - p;
  const int i = std::abs(d.x) <= std::abs(d.y) && std::abs(d.x) <= std::abs(d.z)
                    ? 0
                    : (std::abs(d.y) <= std::abs(d.z) ? 1 : 2);
  Vec3 w;
  w[i] = 1;
  const Vec3 b0 = cross(d, w) / norm(cross(d, w)), b1 = cross(d, b0) / norm(cross(d, b0));
  struct Around {
    double angle;
    bool forward;
    uint32_t side;
  };
  std::array<Around, kMaxAroundEdge> around;
  for (size_t k = 0; k < n; ++k) {
    const Simplex& t = g.simplices[group[k].side / 3];
    const int e = static_cast<int>(group[k].side % 3);
    const Vec3 u = g.points[t.v[(e + 2) % 3]] - p;
    around[k] = {std::atan2(dot(u, b1), dot(u, b0)), canonical[t.v[e]] == group[k].lo,
                 group[k].side};
  }
  const auto first = around.begin(), last = around.begin() + static_cast<std::ptrdiff_t>(n);
  std::sort(first, last, [](const Around& x, const Around& y) { return x.angle < y.angle; });
  // Faces within this angle of each other are coplanar (glued); at most two such.
  constexpr double kSameAngle = 1e-9;
  constexpr double kTurn = 6.283185307179586;
  auto gap_before = [&](size_t k) {
    return k == 0 ? around[0].angle + kTurn - around[n - 1].angle
                  : around[k].angle - around[k - 1].angle;
  };
  size_t start = n;
  for (size_t k = 0; k < n && start == n; ++k)
    if (gap_before(k) > kSameAngle) start = k;
  if (start == n) return false;
  std::rotate(first, first + static_cast<std::ptrdiff_t>(start), last);
  for (size_t k = 1; k + 1 < n; ++k)
    if (gap_before(k) <= kSameAngle && gap_before(k + 1) <= kSameAngle) return false;
  // Alternating from the first triangle's direction; a coplanar couple is put in the order
  // that keeps the alternation (the first couple in either, whichever alternates).
  auto alternate = [&]() {
    for (size_t k = 0; k < n; ++k) {
      const bool want = k % 2 == 0 ? around[0].forward : !around[0].forward;
      if (around[k].forward == want) continue;
      if (k + 1 < n && gap_before(k + 1) <= kSameAngle && around[k + 1].forward == want) {
        std::swap(around[k], around[k + 1]);
        continue;
      }
      return false;
    }
    return true;
  };
  const std::array<Around, kMaxAroundEdge> sorted = around;
  if (!alternate()) {
    if (!(gap_before(1) <= kSameAngle)) return false;
    around = sorted;
    std::swap(around[0], around[1]);
    if (!alternate()) return false;
  }
  // A triangle running lo -> hi has its normal towards growing angles: its material lies
  // before it. Pairs (backward, forward) in angle order bound the material.
  const size_t from = around[0].forward ? 1 : 0;
  for (size_t k = 0; k < n; k += 2)
    pair(around[(from + k) % n].side, around[(from + k + 1) % n].side);
  return true;
}

}  // namespace

PairCertifier::PairCertifier(const UnitGeometry& geometry, const SimplexBvh& bvh,
                             const ContactPairs* contacts, bool extruded, bool cones,
                             const std::atomic<bool>* cancel)
    : geometry_(geometry),
      bvh_(bvh),
      contacts_(contacts),
      extruded_(extruded),
      cones_(cones),
      flat_(std::max(kFlat, 8 * geometry.rounding)),
      mirror_round_(std::max(kMirrorRound, 4 * geometry.rounding)) {
  const auto poll = [cancel] { throw_if_cancelled(cancel, "the octree's certificates"); };
  poll();
  const std::vector<Vec3>& pts = geometry.points;
  // Points at one position share one canonical index (exact positions: the lattice snap makes
  // equal input coordinates bitwise equal).
  std::vector<uint32_t> order(pts.size());
  std::iota(order.begin(), order.end(), 0u);
  sort_polling(
      order,
      [&](uint32_t a, uint32_t b) {
        return std::tie(pts[a].x, pts[a].y, pts[a].z, a) <
               std::tie(pts[b].x, pts[b].y, pts[b].z, b);
      },
      poll);
  poll();
  canonical_.resize(pts.size());
  for (size_t i = 0; i < order.size(); ++i) {
    canonical_[order[i]] =
        i > 0 && pts[order[i]] == pts[order[i - 1]] ? canonical_[order[i - 1]] : order[i];
  }
  // Sides by (object, canonical end points); two records of one key are across each other.
  const int dim = geometry.dimension;
  const int sides = dim == 2 ? 2 : 3;
  std::vector<SideRecord> records;
  records.reserve(geometry.simplices.size() * sides);
  for (uint32_t s = 0; s < geometry.simplices.size(); ++s) {
    const Simplex& t = geometry.simplices[s];
    for (int e = 0; e < sides; ++e) {
      uint32_t a = canonical_[t.v[e]];
      uint32_t b = dim == 2 ? a : canonical_[t.v[(e + 1) % 3]];
      if (a > b) std::swap(a, b);
      records.push_back({geometry.object_of[s], a, b, s * sides + e});
    }
  }
  sort_polling(
      records,
      [](const SideRecord& x, const SideRecord& y) {
        return std::tie(x.object, x.lo, x.hi, x.side) < std::tie(y.object, y.lo, y.hi, y.side);
      },
      poll);
  poll();
  across_.assign(records.size(), kOpen);
  for (size_t i = 0; i < records.size();) {
    size_t j = i + 1;
    while (j < records.size() && records[j].object == records[i].object &&
           records[j].lo == records[i].lo && records[j].hi == records[i].hi) {
      ++j;
    }
    if (j - i == 2) {
      across_[records[i].side] = records[i + 1].side / sides;
      across_[records[i + 1].side] = records[i].side / sides;
    } else if (j - i > 2 &&
               (dim != 3 || !pair_around_edge(geometry, canonical_,
                                              std::span(records).subspan(i, j - i), across_))) {
      for (size_t k = i; k < j; ++k) across_[records[k].side] = kNonManifold;
    }
    i = j;
  }
  if (dim != 3) return;
  poll();
  match_split_sides(cancel);
  poll();
  // Closed objects: every edge has exactly one triangle across (or several, end to end, along
  // a T-junction: match_split_sides). Their triangles need not be consistently ordered: each
  // shell (edge-connected part) is oriented by walking it, each triangle ordered against the
  // one it was reached from (a shared edge runs both ways), and then turned as a whole by the
  // nesting rule below. Only a shell that cannot be oriented (a
  // self-crossing mesh that closes up as a Moebius strip) leaves its object unusable.
  const uint32_t objects = geometry.object_count;
  const size_t simplices = geometry.simplices.size();
  std::vector<uint8_t> closed(objects, 1);
  for (uint32_t s = 0; s < simplices; ++s) {
    const ObjectId o = geometry.object_of[s];
    if (o >= objects) continue;
    for (int e = 0; e < 3; ++e) {
      const uint32_t u = across_[s * 3 + e];
      if (u == kOpen || u == kNonManifold) closed[o] = 0;
    }
  }
  // The simplices across a side, with whether each runs the side's line the same way as the
  // side's own simplex does.
  auto for_each_across = [&](uint32_t side, auto&& f) {
    const uint32_t u = across_[side];
    if (u == kSplit) {
      for (auto it = split_links(side); it != split_.end() && it->side == side; ++it)
        f(it->simplex, it->alike);
      return;
    }
    const Simplex& t = geometry.simplices[side / 3];
    const int e = static_cast<int>(side % 3);
    const uint32_t from = canonical_[t.v[e]], to = canonical_[t.v[(e + 1) % 3]];
    const Simplex& w = geometry.simplices[u];
    bool alike = false;
    for (int i = 0; i < 3; ++i)
      alike |= canonical_[w.v[i]] == from && canonical_[w.v[(i + 1) % 3]] == to;
    f(u, alike);
  };
  // Per triangle, +1 or -1: its vertex order against its shell's first triangle's (0 until
  // reached); and its shell, named by that first triangle.
  poll();
  std::vector<int8_t> order_sign(simplices, 0);
  std::vector<uint32_t> shell_of(simplices, 0);
  {
    std::vector<uint32_t> stack;
    for (uint32_t first = 0; first < simplices; ++first) {
      const ObjectId o = geometry.object_of[first];
      if (order_sign[first] != 0 || o >= objects || !closed[o]) continue;
      if ((first & 0xFFFFu) == 0) poll();
      order_sign[first] = 1;
      shell_of[first] = first;
      stack.assign(1, first);
      while (!stack.empty()) {
        const uint32_t s = stack.back();
        stack.pop_back();
        for (int e = 0; e < 3; ++e) {
          // Ordered alike, u runs the edge the other way.
          for_each_across(s * 3 + e, [&](uint32_t u, bool alike) {
            const int8_t want = static_cast<int8_t>(alike ? -order_sign[s] : order_sign[s]);
            if (order_sign[u] == 0) {
              order_sign[u] = want;
              shell_of[u] = first;
              stack.push_back(u);
            } else if (order_sign[u] != want) {
              closed[o] = 0;  // not orientable
            }
          });
        }
      }
    }
  }
  // With several shells, the sign of the whole enclosed volume does not say which side of a
  // shell is material (a cavity's shell faces inward): each shell's own volume, with its
  // triangles ordered as above, must take the sign its nesting asks — positive for a shell
  // inside an even number of the object's other shells (an outer skin, an island in a
  // cavity), negative inside an odd number (a cavity) — or the shell is turned.
  // Per object, its shells' roots and volumes (few per object: past kMaxShells, none is
  // oriented, as a bound on the nesting tests below).
  constexpr size_t kMaxShells = 16;
  struct Shell {
    uint32_t root;
    double volume = 0;
    int8_t turn = 0;  ///< +1 or -1: the sign that makes its ordered normals point out
  };
  std::vector<std::vector<Shell>> shells(objects);
  auto shell_index = [&](ObjectId o, uint32_t root) {
    const std::vector<Shell>& list = shells[o];
    return static_cast<size_t>(
        std::find_if(list.begin(), list.end(), [&](const Shell& h) { return h.root == root; }) -
        list.begin());
  };
  for (uint32_t s = 0; s < simplices; ++s) {
    const ObjectId o = geometry.object_of[s];
    if (o >= objects || !closed[o]) continue;
    const uint32_t r = shell_of[s];
    std::vector<Shell>& list = shells[o];
    size_t i = shell_index(o, r);
    if (i == list.size()) {
      if (list.size() == kMaxShells) {
        closed[o] = 0;
        continue;
      }
      list.push_back({r});
    }
    const Simplex& t = geometry.simplices[s];
    list[i].volume += order_sign[s] * dot(pts[t.v[0]], cross(pts[t.v[1]], pts[t.v[2]]));
  }
  // The simplices of the objects with several shells, by object.
  std::vector<std::vector<uint32_t>> of_object(objects);
  for (uint32_t s = 0; s < simplices; ++s) {
    const ObjectId o = geometry.object_of[s];
    if (o < objects && closed[o] && shells[o].size() > 1) of_object[o].push_back(s);
  }
  // Whether shell `inner` lies inside shell `outer` (same object): at its vertices of least
  // and greatest x, y and z, none outside and one inside by the parity of a ray's crossings in
  // a direction no input is aligned with. Vertices on the outer shell (within flat_) decide
  // nothing, and one vertex outside says the shells only touch or overlap (parts glued or
  // pushed into each other, whose union is the object) rather than nest (a cavity).
  auto inside = [&](ObjectId o, uint32_t inner, uint32_t outer) {
    constexpr int kTests = 6;
    uint32_t test[kTests];
    bool any = false;
    for (uint32_t s : of_object[o]) {
      if (shell_of[s] != inner) continue;
      for (uint32_t v : geometry.simplices[s].v) {
        for (int k = 0; k < kTests; ++k) {
          const int axis = k / 2;
          if (!any ||
              (k % 2 == 0 ? pts[v][axis] < pts[test[k]][axis] : pts[v][axis] > pts[test[k]][axis]))
            test[k] = v;
        }
        any = true;
      }
    }
    const Vec3 d =
        Vec3{0.5773502691896258, 0.5773502691896257, 0.5773502691896259} + Vec3{1e-3, -2e-3, 7e-4};
    int crossings[kTests] = {};
    double near2[kTests];
    std::fill(near2, near2 + kTests, 1e300);
    for (uint32_t s : of_object[o]) {
      if (shell_of[s] != outer) continue;
      const Simplex& t = geometry.simplices[s];
      const Vec3 a = pts[t.v[0]], e1 = pts[t.v[1]] - a, e2 = pts[t.v[2]] - a;
      const Vec3 h = cross(d, e2);
      const double det = dot(e1, h);
      for (int k = 0; k < kTests; ++k) {
        const Vec3 p = pts[test[k]];
        near2[k] =
            std::min(near2[k], dist2(p, closest_point_on_triangle(p, a, pts[t.v[1]], pts[t.v[2]])));
        if (det == 0) continue;
        const Vec3 q = p - a;
        const double u = dot(q, h) / det;
        if (u < 0 || u > 1) continue;
        const Vec3 kq = cross(q, e1);
        const double v = dot(d, kq) / det;
        if (v < 0 || u + v > 1) continue;
        if (dot(e2, kq) / det > 0) ++crossings[k];
      }
    }
    bool in = false;
    for (int k = 0; k < kTests; ++k) {
      if (!(near2[k] > flat_ * flat_)) continue;
      if (crossings[k] % 2 == 0) return false;
      in = true;
    }
    return in;
  };
  for (uint32_t o = 0; o < objects; ++o) {
    if (!closed[o]) continue;
    for (Shell& h : shells[o]) {
      int depth = 0;
      if (shells[o].size() > 1) {
        poll();
        for (const Shell& other : shells[o])
          if (other.root != h.root && inside(o, h.root, other.root)) ++depth;
      }
      const double expected = depth % 2 == 0 ? 1.0 : -1.0;
      if (h.volume * expected > 0) h.turn = 1;
      if (h.volume * expected < 0) h.turn = -1;
      if (h.turn == 0) closed[o] = 0;  // no volume: which side is material is unknown
    }
  }
  facing_.assign(simplices, 0);
  for (uint32_t s = 0; s < simplices; ++s) {
    const ObjectId o = geometry.object_of[s];
    if (o >= objects || !closed[o]) continue;
    const Shell& h = shells[o][shell_index(o, shell_of[s])];
    facing_[s] = static_cast<int8_t>(order_sign[s] * h.turn);
  }
  // Faces glued between parts of one object (a slot's wall standing on its floor: the wall's
  // underside lies on the floor's top) are inside the object, not on its surface: a triangle
  // covered whole by coplanar triangles of one other shell of its object facing the other way
  // is buried. Every point of it lies on those, so leaving it out of the certificates changes
  // no distance, and its normal (into the other part) is no gradient of the object's distance.
  for (uint32_t o = 0; o < objects; ++o) {
    if (!closed[o] || shells[o].size() < 2) continue;
    if (buried_.empty()) buried_.assign(simplices, 0);
    poll();
    for (uint32_t s : of_object[o]) {
      Plane own;
      if (!simplex_plane(geometry, s, own)) continue;
      const Simplex& t = geometry.simplices[s];
      Box bounds;
      double perimeter = 0;
      for (int e = 0; e < 3; ++e) {
        bounds.extend(pts[t.v[e]]);
        perimeter += dist(pts[t.v[e]], pts[t.v[(e + 1) % 3]]);
      }
      for (int i = 0; i < 3; ++i) {
        bounds.lo[i] -= flat_;
        bounds.hi[i] += flat_;
      }
      Polygon whole;
      for (int e = 0; e < 3; ++e) whole.p[whole.n++] = pts[t.v[e]];
      const double own_area = area(whole);
      std::array<double, kMaxShells> covered{};
      size_t seen = 0;
      const bool bounded = bvh_.visit_overlapping(bounds, [&](uint32_t u) {
        if (geometry.object_of[u] != o || shell_of[u] == shell_of[s]) return true;
        Plane other;
        if (!simplex_plane(geometry, u, other) ||
            facing_[u] * facing_[s] * dot(other.n, own.n) > -1 + 1e-12)
          return true;
        const Simplex& w = geometry.simplices[u];
        for (uint32_t v : w.v)
          if (std::abs(own.signed_distance(pts[v])) > flat_) return true;
        Polygon part;
        for (int e = 0; e < 3; ++e) part.p[part.n++] = pts[w.v[e]];
        for (int e = 0; e < 3 && part.n > 0; ++e) {
          const Vec3 a = pts[t.v[e]], b = pts[t.v[(e + 1) % 3]];
          const Vec3 outward = cross(b - a, own.n);  // s's inside is where this is <= 0
          clip(part, outward, dot(outward, a));
        }
        if (part.n >= 3) covered[shell_index(o, shell_of[u])] += area(part);
        return ++seen <= kMaxActive;
      });
      if (!bounded) continue;
      for (double c : covered)
        if (c >= own_area - mirror_round_ * perimeter) buried_[s] = 1;
    }
  }
}

CellVerdict PairCertifier::classify(const Box& box, std::span<const uint32_t> inside) const {
  // A quick test first, which gives the verdict certify would give: simplices of three
  // objects touching the cell make three active objects (kSplit without a BVH query).
  // Folded patches of two objects may still be mirror images, so certify decides those.
  if (!inside.empty() && !junctions_) {
    const UnitGeometry& g = geometry_;
    ObjectId objects[2] = {kNoObject, kNoObject};
    for (uint32_t s : inside) {
      const ObjectId o = g.object_of[s];
      int k = o == objects[0] ? 0 : (o == objects[1] ? 1 : -1);
      if (k < 0) {
        if (objects[1] != kNoObject) return CellVerdict::kSplit;
        k = objects[0] == kNoObject ? 0 : 1;
        objects[k] = o;
      }
    }
  }
  return certify(box).verdict;
}

CellVerdict PairCertifier::classify_child(const Box& box, std::span<const uint32_t> inside,
                                          uint8_t parent) const {
  const CellVerdict v = classify(box, inside);
  const int axis = junction_axis_of_mark(parent);
  if (v != CellVerdict::kSplit || !junctions_ || axis < 0) return v;
  const Junction j = certify_junction(box, 2, axis);
  if (!j.certified) return v;
  return static_cast<CellVerdict>(static_cast<int>(CellVerdict::kJunctionX) + j.axis);
}

PairCertifier::Certificate PairCertifier::certify(const Box& box) const {
  const UnitGeometry& g = geometry_;
  const int dim = g.dimension;
  Certificate out;
  const Vec3 c = box.center();
  const double r = 0.5 * norm(box.hi - box.lo);
  // Distances a little generous, so rounding never drops a simplex that can be nearest.
  auto widen = [](double d) { return d * (1 + 1e-9) + 1e-15; };

  const ClosestHit first = bvh_.nearest(c);
  if (!first.found()) return out;
  const ObjectId a = g.object_of[first.simplex];
  const double da = std::sqrt(first.dist2);
  const double reach = widen(da + 2 * r);
  const ClosestHit second = bvh_.nearest_excluding(c, &a, 1, reach * reach);
  if (!second.found()) {
    out.verdict = CellVerdict::kOneObject;
    out.a = a;
    return out;
  }
  const ObjectId b = g.object_of[second.simplex];
  const uint32_t pair[2] = {a, b};
  if (bvh_.nearest_excluding(c, pair, 2, reach * reach).found()) {
    if (!junctions_) return out;
    const Junction j = certify_junction(box);
    if (j.certified) {
      out.verdict = static_cast<CellVerdict>(static_cast<int>(CellVerdict::kJunctionX) + j.axis);
      out.axis = j.axis;
      out.a = j.objects[0];
      out.b = j.objects[1];
    }
    return out;
  }
  if (contacts_ != nullptr && contacts_->touching(a, b)) return out;

  // The simplices of each object that can be nearest to a point of the cell.
  const double dist_of[2] = {da, std::sqrt(second.dist2)};
  double range2[2], slack[2];
  for (int k = 0; k < 2; ++k) {
    const double range = widen(dist_of[k] + 2 * r);
    range2[k] = range * range;
    slack[k] = widen(dist_of[k] + r);
  }
  Box query = box;
  for (int i = 0; i < dim; ++i) {
    query.lo[i] -= std::max(slack[0], slack[1]);
    query.hi[i] += std::max(slack[0], slack[1]);
  }
  std::vector<uint32_t> patch[2];
  const bool bounded = bvh_.visit_overlapping(query, [&](uint32_t s) {
    const ObjectId o = g.object_of[s];
    const int k = o == a ? 0 : (o == b ? 1 : -1);
    if (k < 0 || buried(s)) return true;
    const Vec3 q = closest_point_on_simplex(dim, g.points, g.simplices[s], c);
    if (dist2(c, q) > range2[k] ||
        !simplex_overlaps_box(dim, g.points, g.simplices[s], box, slack[k]))
      return true;
    patch[k].push_back(s);
    return patch[0].size() + patch[1].size() <= kMaxActive;
  });
  if (!bounded || patch[0].empty() || patch[1].empty()) return out;

  Plane plane[2];
  const int arity = dim == 2 ? 2 : 3;
  auto flat = [&]() {
    for (int k = 0; k < 2; ++k) {
      if (!fit_plane(g, patch[k], plane[k])) return false;
      const Plane& p = plane[k];
      auto on_plane = [&](uint32_t v) { return std::abs(p.signed_distance(g.points[v])) <= flat_; };
      for (uint32_t s : patch[k]) {
        const Simplex& t = g.simplices[s];
        for (int e = 0; e < arity; ++e)
          if (!on_plane(t.v[e])) return false;
        // Every side within reach continues, unfolded and on the plane, into another simplex:
        // then no point of the cell has its nearest point on a rim of the patch.
        for (int e = 0; e < arity; ++e) {
          const Vec3 pe = g.points[t.v[e]];
          const Vec3 qe = g.points[t.v[(e + 1) % arity]];
          if (dim == 2 ? dist2(c, pe) > range2[k]
                       : dist2(c, closest_point_on_segment(c, pe, qe)) > range2[k]) {
            continue;
          }
          const uint32_t u = across_[s * arity + e];
          if (u == kOpen || u == kNonManifold) return false;
          // The vertices off this side of the simplices across it (2D: u's other end point):
          // one, or (a T-junction, kSplit) the far vertex of each simplex along it.
          uint32_t far[kMaxSplit];
          int n_far = 0;
          if (u == kSplit) {
            const uint32_t side = s * arity + e;
            for (auto it = split_links(side); it != split_.end() && it->side == side; ++it) {
              if (n_far == kMaxSplit) return false;
              far[n_far++] = g.simplices[it->simplex].v[(it->other_side + 2) % 3];
            }
          } else {
            const Simplex& w = g.simplices[u];
            far[0] = kOpen;
            for (int i = 0; i < arity; ++i) {
              const uint32_t cv = canonical_[w.v[i]];
              if (cv != canonical_[t.v[e]] && (dim == 2 || cv != canonical_[t.v[(e + 1) % 3]])) {
                far[0] = w.v[i];
              }
            }
            n_far = 1;
          }
          for (int f = 0; f < n_far; ++f) {
            if (far[f] == kOpen || !on_plane(far[f])) return false;
            const Vec3 pf = g.points[far[f]];
            if (dim == 2) {
              // u must go on beyond pe, away from this segment's other end.
              if (!(dot(qe - pe, pf - pe) < 0)) return false;
            } else {
              const Vec3 own = g.points[t.v[(e + 2) % 3]];
              const double side_own = dot(cross(qe - pe, own - pe), p.n);
              const double side_far = dot(cross(qe - pe, pf - pe), p.n);
              if (!(side_own * side_far < 0)) return false;
            }
          }
        }
      }
    }
    return true;
  };
  if (!flat()) {
    Certificate mirror = certify_mirror(box, pair, dist_of, r, patch);
    if (mirror.verdict != CellVerdict::kSplit || !extruded_) return mirror;
    return certify_extruded(box, pair, dist_of, r, patch);
  }
  if (planes_meet_in(dim, plane[0], plane[1], box, flat_)) return out;
  // Which bisector branches cross the cell: s_a = s_b and s_a = -s_b are affine, so their
  // extremes over the cell are at its corners.
  double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
  for (int corner = 0; corner < (1 << dim); ++corner) {
    Vec3 x;
    for (int i = 0; i < 3; ++i) x[i] = (corner >> i) & 1 ? box.hi[i] : box.lo[i];
    const double sa = plane[0].signed_distance(x), sb = plane[1].signed_distance(x);
    const double f[2] = {sa - sb, sa + sb};
    for (int k = 0; k < 2; ++k) {
      lo[k] = std::min(lo[k], f[k]);
      hi[k] = std::max(hi[k], f[k]);
    }
  }
  const bool crosses_plus = lo[0] <= flat_ && hi[0] >= -flat_;
  const bool crosses_minus = lo[1] <= flat_ && hi[1] >= -flat_;
  if (crosses_plus && crosses_minus) return out;
  out.verdict = CellVerdict::kPair;
  const int first_k = a < b ? 0 : 1;
  out.a = pair[first_k];
  out.b = pair[1 - first_k];
  out.normal[0] = plane[first_k].n;
  out.offset[0] = plane[first_k].offset;
  out.normal[1] = plane[1 - first_k].n;
  out.offset[1] = plane[1 - first_k].offset;
  return out;
}

PairCertifier::Certificate PairCertifier::certify_mirror(
    const Box& box, const ObjectId pair[2], const double dist[2], double r,
    const std::vector<uint32_t> patch[2]) const {
  const UnitGeometry& g = geometry_;
  const int dim = g.dimension;
  Certificate out;
  if (dim != 3) return out;
  // The distinct planes of each patch; mirror planes are the mid-planes of an antiparallel
  // pair (one face of each object facing the other).
  constexpr size_t kMaxPlanes = 8;
  std::vector<Plane> planes[2];
  for (int k = 0; k < 2; ++k) {
    for (uint32_t s : patch[k]) {
      Plane p;
      if (!oriented_plane(g, facing_, s, p)) return out;
      const bool seen = std::any_of(planes[k].begin(), planes[k].end(), [&](const Plane& q) {
        return dot(p.n, q.n) >= 1 - 1e-12 && std::abs(p.offset - q.offset) <= flat_;
      });
      if (!seen) planes[k].push_back(p);
      if (planes[k].size() > kMaxPlanes) return out;
    }
  }
  // Every simplex that can be nearest to a point of the cell overlaps the cell inflated by
  // d_k(c) + r (see certify).
  const double grow = (std::max(dist[0], dist[1]) + r) * (1 + 1e-9) + 1e-15;
  Box near = box;
  for (int i = 0; i < dim; ++i) {
    near.lo[i] -= grow;
    near.hi[i] += grow;
  }
  for (const Plane& pa : planes[0]) {
    for (const Plane& pb : planes[1]) {
      // Only thin gaps: across wider ones the paper's rule resolves the rims in a few cells
      // and keeps the GVD's pieces about as fine as the clearance, which roadmap paths need.
      const double gap = std::abs(pa.offset + pb.offset);
      if (dot(pa.n, pb.n) > -1 + 1e-12 || gap > kMirrorGap) continue;
      // Vertices off their mirror images by the rounding mirror_round_ tilt the bisector by
      // about mirror_round_ / gap: over the cell it stays within kMirrorTolerance of the gap.
      if (r * mirror_round_ > kMirrorTolerance * gap * gap) continue;
      Plane mirror;
      mirror.n = pa.n - pb.n;
      mirror.n = mirror.n / norm(mirror.n);
      mirror.offset = 0.5 * (pa.offset - pb.offset);
      // A's side: where its facing plane lies.
      const double sa = pa.offset - mirror.offset;
      if (!(std::abs(sa) > flat_)) continue;
      const int side_a = sa < 0 ? -1 : 1;
      if (!reflects_onto(g, facing_, buried_, bvh_, mirror, side_a, pair[0], pair[1], near,
                         kMaxActive, flat_, mirror_round_) ||
          !reflects_onto(g, facing_, buried_, bvh_, mirror, -side_a, pair[1], pair[0], near,
                         kMaxActive, flat_, mirror_round_))
        continue;
      out.verdict = CellVerdict::kPair;
      out.mirror = true;
      const int first_k = pair[0] < pair[1] ? 0 : 1;
      out.a = pair[first_k];
      out.b = pair[1 - first_k];
      // Normal from a towards b.
      const double toward_b = first_k == 0 ? -side_a : side_a;
      for (int k = 0; k < 2; ++k) {
        out.normal[k] = mirror.n * toward_b;
        out.offset[k] = mirror.offset * toward_b;
      }
      return out;
    }
  }
  return out;
}

PairCertifier::Certificate PairCertifier::certify_extruded(
    const Box& box, const ObjectId pair[2], const double dist[2], double r,
    const std::vector<uint32_t> patch[2]) const {
  const UnitGeometry& g = geometry_;
  Certificate out;
  if (g.dimension != 3 || facing_.empty()) return out;
  // Surfacing closes cells on the domain box with straight cuts; keep extruded cells off it.
  for (int i = 0; i < 3; ++i)
    if (!(box.lo[i] > 0) || !(box.hi[i] < 1)) return out;
  // The gradient directions: a's outward normals and b's inward ones, square to an axis within
  // `perpendicular`, 1e-10 near the origin: a tilt t moves the bisector by at most t of the
  // cell across it. (1e-12 refused a scene turned and moved 1000 away, whose coordinates'
  // rounding tilts a small triangle's normal by ~4e-12: every rim refined to the gap, the leaf
  // limit.) Farther out, the input's own rounding (UnitGeometry::rounding) tilts a triangle of
  // least altitude h (unit) by ~3.5 roundings / h: 4000 roundings hold triangles down to
  // h ~ 1e-3 (a scene 1e5 times its size away: 4e-8).
  const double perpendicular = std::max(1e-10, 4e3 * geometry_.rounding);
  // A slanted face's normal comes from its triangle's vertices on the 2^-48 lattice, whose
  // rounding tilts it by up to ~2e-12 on a small triangle (the walls of a triangular bore at
  // 60 degrees: with 1e-12 here, their mouths' rims refined to the gap, 306,636 leaves at 1e-4
  // for two of them). A tilt of 1e-10 moves the bisector by at most 1e-10 of the cell across it.
  const double slant_perpendicular = perpendicular;
  std::vector<Vec3> normals;
  std::vector<Plane> planes[2];
  constexpr size_t kMaxPlanes = 8;
  for (int k = 0; k < 2; ++k) {
    for (uint32_t s : patch[k]) {
      Plane p;
      if (facing_[s] == 0 || !oriented_plane(g, facing_, s, p)) return out;
      normals.push_back(p.n * (k == 0 ? 1.0 : -1.0));
      const bool seen = std::any_of(planes[k].begin(), planes[k].end(), [&](const Plane& q) {
        return dot(p.n, q.n) >= 1 - 1e-12 && std::abs(p.offset - q.offset) <= flat_;
      });
      if (!seen) planes[k].push_back(p);
      if (planes[k].size() > kMaxPlanes) return out;
    }
  }
  int axis = -1;
  for (int a = 0; a < 3 && axis < 0; ++a) {
    if (std::all_of(normals.begin(), normals.end(),
                    [&](Vec3 n) { return std::abs(n[a]) <= perpendicular; }))
      axis = a;
  }
  // The direction e of extrusion and the cross-section's axes b[0], b[1] (both perpendicular
  // to e). Along a coordinate axis: the other two. Else slanted, perpendicular to one axis
  // `slanted` (e = the normals' common perpendicular in the plane of the other two): that
  // axis and the one perpendicular to e in that plane, along which every octree edge not
  // along `slanted` runs in the cross-section; so the quadrant keeps every octree edge
  // crossing the bisector at most once.
  Vec3 along, b[2];
  int slanted = -1;
  int mixed = -1;     // a cross-section axis (skew: any axis) the gradients straddle, or -1
  int monotone = -1;  // a wedge's: the one axis along which d_a - d_b is monotone
  if (axis >= 0) {
    along[axis] = 1;
    b[0][(axis + 1) % 3] = 1;
    b[1][(axis + 2) % 3] = 1;
  } else {
    for (int a = 0; a < 3 && slanted < 0; ++a) {
      // The normal with the largest part in the plane perpendicular to a.
      Vec3 w;
      for (Vec3 n : normals) {
        Vec3 in = n;
        in[a] = 0;
        if (norm2(in) > norm2(w)) w = in;
      }
      if (!(norm(w) > 0.1)) continue;
      w = w / norm(w);
      const Vec3 e = cross(w, Vec3{a == 0 ? 1.0 : 0, a == 1 ? 1.0 : 0, a == 2 ? 1.0 : 0});
      // Nearly along an axis, the faces it crosses at a glancing angle would carry long,
      // barely sloping curves: left to splitting.
      constexpr double kMinSlant = 0.01;
      if (std::abs(e[(a + 1) % 3]) < kMinSlant || std::abs(e[(a + 2) % 3]) < kMinSlant) continue;
      if (std::all_of(normals.begin(), normals.end(),
                      [&](Vec3 n) { return std::abs(dot(n, e)) <= slant_perpendicular; })) {
        slanted = a;
        along = e / norm(e);
        b[0][a] = 1;
        b[1] = w;
      }
    }
    if (slanted < 0) {
      // Skew: e square to no axis (a faceted sphere's rims). e is the common perpendicular of
      // the two normals farthest from parallel; every octree edge then runs across the
      // cross-section, so it crosses the bisector at most once when the gradients keep one
      // sign along each of the three axes (checked below, `octant`).
      double best = 0;
      for (size_t i = 0; i < normals.size(); ++i)
        for (size_t j = i + 1; j < normals.size(); ++j) {
          const Vec3 c = cross(normals[i], normals[j]);
          if (norm2(c) > best) {
            best = norm2(c);
            along = c;
          }
        }
      // Normals within ~0.6 degrees of each other leave e ill-defined (and the faces' own
      // flat certificates serve there).
      constexpr double kMinBend = 0.01;
      if (!(best > kMinBend * kMinBend)) return out;
      along = along / norm(along);
      // Nearly square to an axis, the faces it crosses at a glancing angle would carry long,
      // barely sloping curves (as for slanted cells): left to splitting.
      constexpr double kMinSlant = 0.01;
      for (int a = 0; a < 3; ++a)
        if (std::abs(along[a]) < kMinSlant) return out;
      // Within the slanted cells' tolerance: the normals of each face come from its own
      // triangles on the 2^-48 lattice, and e (their cross product) missed being square to
      // them by ~1e-12 on a hexagonal shaft turned about a skew axis, so that with 1e-12 here
      // every rim cell was refused down to the gap (1,047,509 leaves at 1e-4 for two such
      // shafts, 119,477 now).
      if (!std::all_of(normals.begin(), normals.end(),
                       [&](Vec3 n) { return std::abs(dot(n, along)) <= slant_perpendicular; }))
        return out;
      // One axis may be straddled (the rims of a sphere across its great circles): a cone, as
      // along an axis, whose lines along that axis are counted below. Or two, the third keeping
      // one sign (a part turned about a skew axis against the frame): a wedge, whose lines
      // along both are counted.
      int straddled = 0;
      for (int a = 0; a < 3; ++a) {
        const bool up = std::all_of(normals.begin(), normals.end(),
                                    [&](Vec3 n) { return n[a] >= -perpendicular; });
        const bool down = std::all_of(normals.begin(), normals.end(),
                                      [&](Vec3 n) { return n[a] <= perpendicular; });
        if (!up && !down) {
          if (++straddled > 2 || !cones_) return out;
          if (mixed < 0) mixed = a;
        } else {
          monotone = a;
        }
      }
      if (straddled < 2) monotone = -1;
      // On a wedge's faces square to its monotone axis the bisector is C sheared along e:
      // it turns by less than a half turn, but by nearly one where e lies nearly in the
      // face, and the surfacer sorts its pieces across the middle of that turn (pair_spokes
      // in cell_surfacer.cpp, up to kMaxFaceSpan plus room for rounding).
      if (monotone >= 0 && !(span_square_to(normals, monotone) <= kMaxFaceSpan)) return out;
      out.skew = true;
      // The cross-section's axes for `rise` below: any two orthonormal ones square to e.
      b[0] = normals[0] - along * dot(normals[0], along);
      b[0] = b[0] / norm(b[0]);
      b[1] = cross(along, b[0]);
    }
  }
  // One quadrant of the cross-section holds them all; or else (along an axis) one cone of at
  // most 2 kMaxCone around their mean, which can straddle one cross-section axis (`mixed`):
  // lines along it may then meet the curve twice, so the cell's own lines along it are
  // checked below.
  Vec3 rise;
  const bool skew = out.skew;  // a slanted cone becomes one below, after its quadrant test
  for (int k = 0; k < 2 && !skew; ++k) {
    const bool up = std::all_of(normals.begin(), normals.end(),
                                [&](Vec3 n) { return dot(n, b[k]) >= -perpendicular; });
    const bool down = std::all_of(normals.begin(), normals.end(),
                                  [&](Vec3 n) { return dot(n, b[k]) <= perpendicular; });
    if (!up && !down) {
      if (mixed >= 0 || !cones_) return out;
      if (axis >= 0) {
        mixed = (axis + 1 + k) % 3;
      } else if (k == 0) {
        // Slanted, straddling its own axis a (a sphere's meridian rims across a coordinate
        // plane, its equator's): a cone whose lines along a are counted as a skew cone's (e
        // from the certificate again; the two faces square to a, parallel to e, carry
        // straight pieces).
        mixed = slanted;
        slanted = -1;
        out.skew = true;
      } else {
        // Slanted, straddling w (a part turned about two axes against the frame: its rims
        // square to a, their normals across w): d_a - d_b is monotone along a alone. Every
        // octree edge along either other axis runs along w in the cross-section, so lines
        // along both are counted: a skew cone across two axes (a wedge), e from the
        // certificate again.
        monotone = slanted;
        mixed = (slanted + 1) % 3;
        slanted = -1;
        out.skew = true;
      }
    }
    rise = rise + b[k] * (up ? 1.0 : -1.0);
  }
  if (out.skew && mixed < 0) {
    // The gradients' mean direction (they lie within the octant, so within a quarter turn of
    // each other): d_a - d_b grows along it.
    for (Vec3 n : normals) rise = rise + n;
    rise = rise / norm(rise) * std::sqrt(2.0);  // scaled back by 1/sqrt(2) below
  }
  if (mixed >= 0) {
    // The middle of the normals' angular span in the cross-section (not their sum, which
    // leans to the face with more triangles in reach): every normal within kMaxCone of it.
    // Angles from the first normal: all lie within a quarter turn of it when the span does.
    const double first = std::atan2(dot(normals[0], b[1]), dot(normals[0], b[0]));
    double lo = 0, hi = 0;
    for (Vec3 n : normals) {
      double a = std::atan2(dot(n, b[1]), dot(n, b[0])) - first;
      constexpr double kPi = 3.14159265358979323846;
      if (a > kPi) a -= 2 * kPi;
      if (a < -kPi) a += 2 * kPi;
      lo = std::min(lo, a);
      hi = std::max(hi, a);
    }
    const double middle = first + 0.5 * (lo + hi);
    const Vec3 mean = b[0] * std::cos(middle) + b[1] * std::sin(middle);
    // A quadrant turned against the axes has its extremes at exactly kMaxCone: allow rounding.
    const double cos_cone = std::cos(kMaxCone) - 1e-12;
    for (Vec3 n : normals)
      if (dot(n, mean) < cos_cone) return out;
    rise = mean * std::sqrt(2.0);  // scaled back by 1/sqrt(2) below
  }
  // Every simplex that can be nearest to a point of the cell lies in the cell inflated by
  // max d_k(c) + r (see certify); on each plane of the nearest simplices, the object's
  // triangles must cover a strip across that box along e, so that the surface there is
  // invariant along it: triangles of a closed mesh do not overlap, so the clipped areas add
  // up to the strip's exactly when they cover it.
  const double grow = (std::max(dist[0], dist[1]) + r) * (1 + 1e-9) + 1e-15;
  Box near = box;
  for (int i = 0; i < 3; ++i) {
    near.lo[i] -= grow;
    near.hi[i] += grow;
  }
  for (int k = 0; k < 2; ++k) {
    std::vector<Vec3> n;
    std::vector<double> offset;
    for (const Plane& plane : planes[k]) {
      n.push_back(plane.n);
      offset.push_back(plane.offset);
    }
    if (!strips_cover(near, axis, along, pair[k], n, offset)) return out;
  }
  if (mixed >= 0) {
    // The lines of the cell along `mixed` where octree edges of it and of its children can
    // run, at most two crossings each (`twice` where some line has two: beside the roof's
    // apex): at 0, 1/4, ... 1 of the cell across the monotone axis, and along an extruded
    // axis at any point (all alike); skew (no invariant axis), at the quarters across both
    // other axes. Then its children are certified with it (kCone...), or, skew, asked again.
    // A wedge's lines along both axes other than the monotone one.
    for (int line = 0; line < (monotone >= 0 ? 2 : 1); ++line) {
      const int m = line == 0 ? mixed : 3 - monotone - mixed;
      const int p = axis >= 0 ? 3 - axis - m : (m + 1) % 3;
      const int q = axis >= 0 ? -1 : (m + 2) % 3;
      for (int i = 0; i <= 4; ++i) {
        for (int j = 0; j <= (q >= 0 ? 4 : 0); ++j) {
          Vec3 p0 = box.center(), p1;
          p0[p] = box.lo[p] + 0.25 * i * (box.hi[p] - box.lo[p]);
          if (q >= 0) p0[q] = box.lo[q] + 0.25 * j * (box.hi[q] - box.lo[q]);
          p1 = p0;
          p0[m] = box.lo[m];
          p1[m] = box.hi[m];
          const int crossings = line_crossings(p0, p1, m, patch);
          if (crossings > 2) return out;
          out.twice |= crossings == 2;
        }
      }
    }
    out.inherited = false;
    out.mixed = mixed;
    out.monotone = monotone;
  }
  if (axis >= 0) {
    out.verdict = mixed < 0 ? extruded_verdict(axis) : cone_verdict(axis, mixed, out.twice);
  } else if (out.skew) {
    out.verdict = mixed < 0       ? CellVerdict::kSkew
                  : monotone >= 0 ? skew_wedge_verdict(monotone, out.twice)
                                  : skew_cone_verdict(mixed, out.twice);
  } else {
    const int i = (slanted + 1) % 3, j = (slanted + 2) % 3;
    out.verdict = slanted_verdict(slanted, along[i] * along[j] < 0);
  }
  out.axis = axis;
  out.slanted = slanted;
  out.along = along;
  const int first_k = pair[0] < pair[1] ? 0 : 1;
  out.a = pair[first_k];
  out.b = pair[1 - first_k];
  // rise is where d_pair[0] - d_pair[1] grows; for a = pair[1] it is the other way.
  out.rise = rise * ((first_k == 0 ? 1.0 : -1.0) / std::sqrt(2.0));
  return out;
}

namespace {

// The level and lattice cell (at that level) of a cell box of the unit domain.
std::array<uint32_t, 4> cell_at(const Box& box) {
  const int level = static_cast<int>(std::lround(-std::log2(box.hi.x - box.lo.x)));
  std::array<uint32_t, 4> out{static_cast<uint32_t>(level), 0, 0, 0};
  for (int a = 0; a < 3; ++a)
    out[a + 1] = static_cast<uint32_t>(std::floor(std::ldexp(box.lo[a], level) + 0.5));
  return out;
}

}  // namespace

void PairCertifier::refuse_junctions_in(const Box& box) {
  const std::lock_guard<std::mutex> lock(refused_mutex_);
  refused_.insert(cell_at(box));
}

bool PairCertifier::junction_refused(const Box& box) const {
  const std::lock_guard<std::mutex> lock(refused_mutex_);
  if (refused_.empty()) return false;
  const std::array<uint32_t, 4> c = cell_at(box);
  for (uint32_t level = 0; level <= c[0]; ++level) {
    std::array<uint32_t, 4> up{level, 0, 0, 0};
    for (int a = 1; a < 4; ++a) up[a] = c[a] >> (c[0] - level);
    if (refused_.count(up) != 0) return true;
  }
  return false;
}

PairCertifier::Junction PairCertifier::certify_junction(const Box& box, int min_objects,
                                                        int axis_first) const {
  const UnitGeometry& g = geometry_;
  Junction out;
  if (g.dimension != 3 || facing_.empty() || junction_refused(box)) return out;
  for (int i = 0; i < 3; ++i)
    if (!(box.lo[i] > 0) || !(box.hi[i] < 1)) return out;
  auto widen = [](double d) { return d * (1 + 1e-9) + 1e-15; };
  const Vec3 c = box.center();
  const double r = 0.5 * norm(box.hi - box.lo);
  // The active objects (certify, step 1): every object within D + 2r of the centre.
  ObjectId objects[kMaxJunction + 1];
  double dist[kMaxJunction + 1];
  const int n = objects_in_reach(bvh_, g.object_of, c, r, kMaxJunction, objects, dist);
  if (n < std::max(2, min_objects)) return out;
  if (contacts_ != nullptr)
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j)
        if (contacts_->touching(objects[i], objects[j])) return out;
  // Each object's simplices that can be nearest to a point of the cell (as in certify).
  double range2[kMaxJunction], slack[kMaxJunction], most = 0;
  for (int k = 0; k < n; ++k) {
    const double range = widen(dist[k] + 2 * r);
    range2[k] = range * range;
    slack[k] = widen(dist[k] + r);
    most = std::max(most, slack[k]);
  }
  Box query = box;
  for (int i = 0; i < 3; ++i) {
    query.lo[i] -= most;
    query.hi[i] += most;
  }
  std::vector<uint32_t> patch[kMaxJunction];
  size_t total = 0;
  const bool bounded = bvh_.visit_overlapping(query, [&](uint32_t s) {
    const ObjectId o = g.object_of[s];
    const int k = static_cast<int>(std::find(objects, objects + n, o) - objects);
    if (k == n || buried(s)) return true;
    const Vec3 q = closest_point_on_simplex(3, g.points, g.simplices[s], c);
    if (dist2(c, q) > range2[k] ||
        !simplex_overlaps_box(3, g.points, g.simplices[s], box, slack[k]))
      return true;
    patch[k].push_back(s);
    return ++total <= kMaxActive;
  });
  if (!bounded) return out;
  // Every one square to one axis e, closed, on at most kMaxPlanes planes per object.
  const double perpendicular = std::max(1e-10, 4e3 * geometry_.rounding);
  constexpr size_t kMaxPlanes = 8;
  std::vector<Vec3> normals[kMaxJunction];
  std::vector<double> offsets[kMaxJunction];
  bool square_to[3] = {true, true, true};
  for (int k = 0; k < n; ++k) {
    if (patch[k].empty()) return out;
    for (uint32_t s : patch[k]) {
      Plane p;
      if (facing_[s] == 0 || !oriented_plane(g, facing_, s, p)) return out;
      int square = 0;
      for (int a = 0; a < 3; ++a) {
        square += std::abs(p.n[a]) <= perpendicular ? 1 : 0;
        square_to[a] = square_to[a] && std::abs(p.n[a]) <= perpendicular;
      }
      // Two objects: their sections rectilinear (every plane square to two axes).
      if (n == 2 && square < 2) return out;
      bool seen = false;
      for (size_t i = 0; i < normals[k].size() && !seen; ++i)
        seen = dot(p.n, normals[k][i]) >= 1 - 1e-12 && std::abs(p.offset - offsets[k][i]) <= flat_;
      if (seen) continue;
      if (normals[k].size() == kMaxPlanes) return out;
      normals[k].push_back(p.n);
      offsets[k].push_back(p.offset);
    }
  }
  // On each plane a strip across the box that holds every simplex that can be nearest, along
  // an axis every plane is square to (where they are square to two, facing faces of which one
  // may end across one of them: the first that gives strips, axis_first tried first).
  Box near = box;
  for (int i = 0; i < 3; ++i) {
    near.lo[i] -= most;
    near.hi[i] += most;
  }
  int axis = -1;
  for (int t = 0; t < 3 && axis < 0; ++t) {
    const int a = axis_first >= 0 ? (axis_first + t) % 3 : t;
    if (!square_to[a]) continue;
    Vec3 along;
    along[a] = 1;
    bool covered = true;
    for (int k = 0; k < n && covered; ++k)
      covered = strips_cover(near, a, along, objects[k], normals[k], offsets[k]);
    if (covered) axis = a;
  }
  if (axis < 0) return out;
  out.certified = true;
  out.axis = axis;
  out.n_objects = n;
  for (int k = 0; k < n; ++k) {  // ascending (insertion: n <= kMaxJunction)
    int at = k;
    for (; at > 0 && out.objects[at - 1] > objects[k]; --at) out.objects[at] = out.objects[at - 1];
    out.objects[at] = objects[k];
  }
  return out;
}

bool PairCertifier::strips_cover(const Box& near, int axis, Vec3 along, ObjectId object,
                                 std::span<const Vec3> n, std::span<const double> offset) const {
  const UnitGeometry& g = geometry_;
  for (size_t i = 0; i < n.size(); ++i) {
    const Plane plane{n[i], offset[i]};
    const Vec3 u = cross(along, plane.n);
    double area_sum = 0, lo = 1e300, hi = -1e300;
    size_t seen = 0;
    const bool bounded = bvh_.visit_overlapping(near, [&](uint32_t s) {
      if (g.object_of[s] != object || buried(s)) return true;
      Plane own;
      if (!oriented_plane(g, facing_, s, own) || dot(own.n, plane.n) < 1 - 1e-12 ||
          std::abs(plane.signed_distance(g.points[g.simplices[s].v[0]])) > flat_)
        return true;
      Polygon poly;
      for (int e = 0; e < 3; ++e) poly.p[poly.n++] = g.points[g.simplices[s].v[e]];
      clip_to_box(poly, near);
      if (poly.n < 3) return true;
      area_sum += area(poly);
      for (int k = 0; k < poly.n; ++k) {
        lo = std::min(lo, dot(u, poly.p[k]));
        hi = std::max(hi, dot(u, poly.p[k]));
      }
      return ++seen <= 4 * kMaxActive;
    });
    if (!bounded || !(hi > lo)) return false;
    double strip = 0;
    if (axis >= 0) {
      strip = (hi - lo) * (near.hi[axis] - near.lo[axis]);
    } else {
      // The plane inside the box, between lo and hi across e.
      const Vec3 m = near.center();
      const Vec3 on = m - plane.n * plane.signed_distance(m);
      const double reach = norm(near.hi - near.lo);
      Polygon poly;
      for (const auto& [x, y] : {std::pair{-1.0, -1.0}, {1.0, -1.0}, {1.0, 1.0}, {-1.0, 1.0}})
        poly.p[poly.n++] = on + along * (x * reach) + u * (y * reach);
      clip_to_box(poly, near);
      clip(poly, u, hi);
      clip(poly, u * -1.0, -lo);
      strip = poly.n >= 3 ? area(poly) : 0;
    }
    if (!(strip > 0) || std::abs(area_sum - strip) > 1e-9 * strip) return false;
  }
  return true;
}

std::vector<PairCertifier::SplitLink>::const_iterator PairCertifier::split_links(
    uint32_t side) const {
  return std::lower_bound(split_.begin(), split_.end(), side,
                          [](const SplitLink& l, uint32_t x) { return l.side < x; });
}

void PairCertifier::match_split_sides(const std::atomic<bool>* cancel) {
  const UnitGeometry& g = geometry_;
  const std::vector<Vec3>& pts = g.points;
  // An end point within this of the other side's line lies on it: the lattice's rounding
  // (2^-48) of a T-junction's vertex computed on a slanted edge, and a little.
  const double on_line = mirror_round_;
  // Simplices looked at per open side at most (a crowd of coincident copies: left open).
  constexpr size_t kMaxCandidates = 64;
  std::vector<SplitLink> links;
  std::vector<uint32_t> matched;
  for (uint32_t side = 0; side < across_.size(); ++side) {
    if ((side & 0xFFFFu) == 0) throw_if_cancelled(cancel, "the octree's certificates");
    if (across_[side] != kOpen) continue;
    const uint32_t s = side / 3;
    const int e = static_cast<int>(side % 3);
    const Simplex& t = g.simplices[s];
    const Vec3 p = pts[t.v[e]], q = pts[t.v[(e + 1) % 3]];
    const double len = norm(q - p);
    if (!(len > 2 * on_line)) continue;
    const Vec3 dir = (q - p) / len;
    auto off_line = [&](Vec3 x) {
      const Vec3 r = x - p;
      return norm(r - dir * dot(r, dir));
    };
    Box query;
    for (int i = 0; i < 3; ++i) {
      query.lo[i] = std::min(p[i], q[i]) - on_line;
      query.hi[i] = std::max(p[i], q[i]) + on_line;
    }
    const size_t first = links.size();
    double covered = 0;
    size_t seen = 0;
    const bool bounded = bvh_.visit_overlapping(query, [&](uint32_t u) {
      if (u == s || g.object_of[u] != g.object_of[s]) return true;
      if (++seen > kMaxCandidates) return false;
      const Simplex& w = g.simplices[u];
      for (int f = 0; f < 3; ++f) {
        // Only open sides: a side matched end to end has its one simplex across already.
        if (across_[u * 3 + f] != kOpen) continue;
        const Vec3 a = pts[w.v[f]], b = pts[w.v[(f + 1) % 3]];
        if (off_line(a) > on_line || off_line(b) > on_line) continue;
        const double ta = dot(a - p, dir), tb = dot(b - p, dir);
        const double lo = std::max(0.0, std::min(ta, tb)), hi = std::min(len, std::max(ta, tb));
        if (!(hi - lo > 2 * on_line)) continue;  // meets it at a point, or not at all
        covered += hi - lo;
        links.push_back({side, u, static_cast<uint8_t>(f), ta < tb});
      }
      return true;
    });
    // Covered once along its whole length, by sides that overlap only at their ends.
    const size_t found = links.size() - first;
    if (!bounded || found == 0 || found > kMaxSplit ||
        std::abs(covered - len) > 2 * on_line * static_cast<double>(found + 1)) {
      links.resize(first);
      continue;
    }
    matched.push_back(side);
  }
  for (uint32_t side : matched) across_[side] = kSplit;
  // Sorted by side (they were made in that order).
  split_ = std::move(links);
}

int PairCertifier::line_crossings(Vec3 p0, Vec3 p1, int along,
                                  const std::vector<uint32_t> patch[2]) const {
  const UnitGeometry& g = geometry_;
  // Per simplex of the patch, the component along `along` of its gradient direction (outward
  // normals of 0, inward ones of 1); NaN where its plane is degenerate.
  std::vector<double> grad[2];
  for (int k = 0; k < 2; ++k) {
    grad[k].reserve(patch[k].size());
    for (uint32_t s : patch[k]) {
      Plane p;
      grad[k].push_back(facing_[s] != 0 && oriented_plane(g, facing_, s, p)
                            ? p.n[along] * (k == 0 ? 1.0 : -1.0)
                            : std::numeric_limits<double>::quiet_NaN());
    }
  }
  // d_pair[0] - d_pair[1] at x, exact (nearest simplex among the cell's patch: every point of
  // the cell has its nearest simplices there). Keeps the squared distance to every simplex of
  // the patch (d2) and the nearest per object (best) for monotone_at_last.
  std::vector<double> d2[2] = {std::vector<double>(patch[0].size()),
                               std::vector<double>(patch[1].size())};
  double best[2] = {1e300, 1e300};
  auto gap_at = [&](Vec3 x) {
    for (int k = 0; k < 2; ++k) {
      best[k] = 1e300;
      for (size_t i = 0; i < patch[k].size(); ++i) {
        d2[k][i] = dist2(x, closest_point_on_simplex(3, g.points, g.simplices[patch[k][i]], x));
        best[k] = std::min(best[k], d2[k][i]);
      }
    }
    return std::sqrt(best[0]) - std::sqrt(best[1]);
  };
  // Whether d_0 - d_1 is monotone along a segment of length 2r whose middle c gap_at was last
  // evaluated at: the simplices of its patch that can be nearest to a point of it (within
  // d_k(c) + 2r of c) have gradient directions whose components along `along` share a sign.
  auto monotone_at_last = [&](double r) {
    bool up = true, down = true;
    for (int k = 0; k < 2; ++k) {
      const double range = (std::sqrt(best[k]) + 2 * r) * (1 + 1e-9) + 1e-15;
      for (size_t i = 0; i < patch[k].size(); ++i) {
        if (d2[k][i] > range * range) continue;
        const double n = grad[k][i];
        if (std::isnan(n)) return false;
        up &= n >= -1e-12;
        down &= n <= 1e-12;
      }
    }
    return up || down;
  };
  int evaluations = 0;
  // Crossings of [a, b] (values fa, fb at the ends); -1: undecided. d_0 - d_1 is 2-Lipschitz.
  // Pieces of 2^-30 of the segment count by their ends' signs: a loop of the bisector that
  // small is below what any octree edge resolves (the edge points keep a hair of 1e-6 of the
  // edge), as where the two crossings meet at the apex of a roof. A line that runs nearly
  // along the bisector near the apex changes slope by less than the Lipschitz bound prunes, so
  // a dozen pieces next to the crossing stay open on each of the 30 levels (~600 evaluations;
  // the budget was 512, and such cells near a bore's end failed, round after round).
  constexpr int kMaxEvaluations = 8192;
  auto count = [&](auto&& self, Vec3 a, Vec3 b, double fa, double fb, int depth) -> int {
    if (fa == 0 || fb == 0 || ++evaluations > kMaxEvaluations) return -1;
    const bool change = (fa < 0) != (fb < 0);
    if (!change && 0.5 * (std::abs(fa) + std::abs(fb)) > dist(a, b)) return 0;
    if (depth >= 30) return change ? 1 : 0;
    const Vec3 m = (a + b) * 0.5;
    const double fm = gap_at(m);  // the monotone test's distances too
    if (monotone_at_last(0.5 * dist(a, b))) return change ? 1 : 0;
    const int left = self(self, a, m, fa, fm, depth + 1);
    if (left < 0) return -1;
    const int right = self(self, m, b, fm, fb, depth + 1);
    return right < 0 ? -1 : left + right;
  };
  const int n = count(count, p0, p1, gap_at(p0), gap_at(p1), 0);
  return n < 0 ? 3 : n;
}

}  // namespace gvd::refine
