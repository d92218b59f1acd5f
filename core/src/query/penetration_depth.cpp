// ConvexShape: the convexity check and the separating-axis test of two convex objects.
#include "gvd/query/penetration_depth.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "gvd/common/union_find.h"

namespace gvd::query {

using namespace gvd::scene;

namespace {

/// Whether the arcs a-b and c-d (each shorter than a half circle) cross on the unit sphere;
/// bxa = cross(b, a), dxc = cross(d, c). The arcs cross where both planes' signs change and
/// the crossing lies on the same half of the sphere as both.
bool arcs_cross(Vec3 a, Vec3 b, Vec3 bxa, Vec3 c, Vec3 d, Vec3 dxc) {
  const double cba = dot(c, bxa), dba = dot(d, bxa);
  const double adc = dot(a, dxc), bdc = dot(b, dxc);
  return cba * dba < 0 && adc * bdc < 0 && cba * bdc > 0;
}

}  // namespace

std::optional<ConvexShape> ConvexShape::of(const SceneObject& object, int dimension,
                                           uint64_t budget, Verdict* verdict) {
  Verdict local = Verdict::kNotConvex;
  Verdict& said = verdict != nullptr ? *verdict : local;
  said = Verdict::kNotConvex;
  const size_t m = object.simplices.size();
  const int arity = dimension == 2 ? 2 : 3;
  if (m < static_cast<size_t>(dimension == 2 ? 3 : 4)) return std::nullopt;
  // The vertices the simplices use, renumbered.
  std::vector<uint32_t> index(object.vertices.size(), ~0u);
  ConvexShape s;
  std::vector<uint32_t> used;
  for (const Simplex& t : object.simplices) {
    for (int k = 0; k < arity; ++k) {
      if (t.v[k] >= object.vertices.size()) return std::nullopt;
      if (index[t.v[k]] == ~0u) {
        index[t.v[k]] = static_cast<uint32_t>(used.size());
        used.push_back(t.v[k]);
      }
    }
  }
  // The last check takes faces times vertices: a larger object is over the budget at once,
  // before anything else is spent on it (a neuron of a million triangles, say).
  if (static_cast<double>(m) * static_cast<double>(used.size()) > static_cast<double>(budget)) {
    said = Verdict::kOverBudget;
    return std::nullopt;
  }
  Box box;
  for (uint32_t v : used) {
    box.extend(object.vertices[v]);
    s.centre_ = s.centre_ + object.vertices[v];
  }
  s.centre_ = s.centre_ / static_cast<double>(used.size());
  for (uint32_t v : used) s.points_.push_back(object.vertices[v] - s.centre_);
  const double size = norm(box.hi - box.lo);
  const double eps = 1e-9 * size;
  const size_t n = s.points_.size();
  auto at = [&](uint32_t original) { return s.points_[index[original]]; };

  if (dimension == 2) {
    // One loop through every vertex, each in two segments.
    std::vector<uint32_t> first(n, ~0u), second(n, ~0u);
    for (uint32_t t = 0; t < m; ++t) {
      for (int k = 0; k < 2; ++k) {
        const uint32_t v = index[object.simplices[t].v[k]];
        if (first[v] == ~0u) {
          first[v] = t;
        } else if (second[v] == ~0u) {
          second[v] = t;
        } else {
          return std::nullopt;
        }
      }
    }
    for (size_t v = 0; v < n; ++v)
      if (second[v] == ~0u) return std::nullopt;
    std::vector<uint32_t> loop;  // vertices in order
    uint32_t v = 0, t = first[0];
    do {
      loop.push_back(v);
      const Simplex& e = object.simplices[t];
      v = index[e.v[0]] == v ? index[e.v[1]] : index[e.v[0]];
      t = first[v] == t ? second[v] : first[v];
    } while (v != 0 && loop.size() <= n);
    if (loop.size() != n || n != m) return std::nullopt;
    double area2 = 0;
    for (size_t i = 0; i < n; ++i) {
      const Vec3 p = s.points_[loop[i]], q = s.points_[loop[(i + 1) % n]];
      area2 += p.x * q.y - p.y * q.x;
    }
    if (!(std::abs(area2) > eps * size)) return std::nullopt;
    const double sense = area2 > 0 ? 1.0 : -1.0;
    double turned = 0;
    for (size_t i = 0; i < n; ++i) {
      const Vec3 p = s.points_[loop[i]], q = s.points_[loop[(i + 1) % n]];
      const Vec3 r = s.points_[loop[(i + 2) % n]];
      const Vec3 e = q - p, f = r - q;
      const double len = norm(e);
      if (len == 0 || norm(f) == 0) return std::nullopt;
      turned += std::atan2(sense * (e.x * f.y - e.y * f.x), dot(e, f));
      // Outward: to the right of a counter-clockwise boundary.
      const Vec3 normal = Vec3{e.y, -e.x, 0} * (sense / len);
      s.normal_.push_back(normal);
      s.offset_.push_back(dot(normal, p));
    }
    if (std::abs(turned - 2 * std::numbers::pi) > 1e-6) return std::nullopt;
  } else {
    // Every edge in two triangles that run it in opposite directions, one connected part.
    struct Side {
      uint64_t edge;
      uint32_t triangle;
      bool forward;  ///< runs it from the smaller vertex to the larger
    };
    std::vector<Side> sides;
    sides.reserve(3 * m);
    for (uint32_t t = 0; t < m; ++t) {
      for (int k = 0; k < 3; ++k) {
        const uint32_t a = index[object.simplices[t].v[k]];
        const uint32_t b = index[object.simplices[t].v[(k + 1) % 3]];
        if (a == b) return std::nullopt;
        sides.push_back({uint64_t{std::min(a, b)} << 32 | std::max(a, b), t, a < b});
      }
    }
    std::sort(sides.begin(), sides.end(), [](const Side& x, const Side& y) {
      return x.edge != y.edge ? x.edge < y.edge : x.triangle < y.triangle;
    });
    if (sides.size() % 2 != 0) return std::nullopt;
    UnionFind parts(m);
    for (size_t i = 0; i < sides.size(); i += 2) {
      const Side &x = sides[i], &y = sides[i + 1];
      if (x.edge != y.edge || x.forward == y.forward) return std::nullopt;
      if (i + 2 < sides.size() && sides[i + 2].edge == x.edge) return std::nullopt;
      parts.unite(x.triangle, y.triangle);
    }
    for (uint32_t t = 0; t < m; ++t)
      if (parts.find(t) != parts.find(0)) return std::nullopt;
    // Outward normals: the orientation whose enclosed volume is positive.
    double volume6 = 0;
    std::vector<Vec3> normal(m);
    for (uint32_t t = 0; t < m; ++t) {
      const Simplex& x = object.simplices[t];
      const Vec3 p = at(x.v[0]), q = at(x.v[1]), r = at(x.v[2]);
      volume6 += dot(p, cross(q, r));
      normal[t] = cross(q - p, r - p);
      const double len = norm(normal[t]);
      if (len == 0) return std::nullopt;
      normal[t] = normal[t] / len;
    }
    if (!(std::abs(volume6) > eps * size * size)) return std::nullopt;
    const double sense = volume6 > 0 ? 1.0 : -1.0;
    for (uint32_t t = 0; t < m; ++t) {
      s.normal_.push_back(normal[t] * sense);
      s.offset_.push_back(dot(s.normal_.back(), at(object.simplices[t].v[0])));
    }
    // Convex at every edge first (fails fast on most meshes that are not), keeping the
    // edges where the surface bends.
    for (size_t i = 0; i < sides.size(); i += 2) {
      const uint32_t t1 = sides[i].triangle, t2 = sides[i + 1].triangle;
      const uint32_t a = static_cast<uint32_t>(sides[i].edge >> 32);
      const uint32_t b = static_cast<uint32_t>(sides[i].edge & 0xFFFFFFFFu);
      for (int k = 0; k < 3; ++k) {
        const uint32_t o = index[object.simplices[t2].v[k]];
        if (o != a && o != b && dot(s.normal_[t1], s.points_[o]) - s.offset_[t1] > eps)
          return std::nullopt;
      }
      const Vec3 n1 = s.normal_[t1], n2 = s.normal_[t2];
      if (dot(n1, n2) > 1 - 1e-12) continue;  // coplanar faces: no edge of the polytope
      s.edges_.push_back({s.points_[a], s.points_[b] - s.points_[a], n1, n2, cross(n2, n1)});
    }
  }
  // Every vertex on or behind every face.
  for (size_t f = 0; f < s.normal_.size(); ++f)
    for (const Vec3& p : s.points_)
      if (dot(s.normal_[f], p) - s.offset_[f] > eps) return std::nullopt;
  said = Verdict::kConvex;
  return s;
}

std::optional<ConvexShape::Penetration> ConvexShape::penetration(const ConvexShape& a,
                                                                 const ConvexShape& b,
                                                                 uint64_t budget) {
  const double work = static_cast<double>(a.normal_.size()) * b.points_.size() +
                      static_cast<double>(b.normal_.size()) * a.points_.size() +
                      static_cast<double>(a.edges_.size()) * b.edges_.size();
  if (work > static_cast<double>(budget)) return std::nullopt;
  // Points of b relative to a's centre are b's plus `shift`.
  const Vec3 shift = b.centre_ - a.centre_;
  Penetration least{std::numeric_limits<double>::infinity(), {}};
  auto consider = [&](double depth, Vec3 direction) {
    if (depth < least.depth) least = {depth, direction};
  };
  // Along a face normal n of a: a reaches offset along n, b's lowest point is its support in -n.
  for (size_t f = 0; f < a.normal_.size(); ++f) {
    const Vec3 normal = a.normal_[f];
    double low = std::numeric_limits<double>::infinity();
    for (const Vec3& p : b.points_) low = std::min(low, dot(normal, p));
    consider(a.offset_[f] - (low + dot(normal, shift)), normal);
  }
  // Along -m for a face normal m of b: the same with the roles exchanged.
  for (size_t f = 0; f < b.normal_.size(); ++f) {
    const Vec3 normal = b.normal_[f];
    double low = std::numeric_limits<double>::infinity();
    for (const Vec3& p : a.points_) low = std::min(low, dot(normal, p));
    consider(b.offset_[f] - (low - dot(normal, shift)), normal * -1.0);
  }
  // Along the normals of the Minkowski difference's edge-edge faces: a's edge arc and the arc
  // of b's edge turned inside out (-n1, -n2) cross; then a's edge supports a along the normal
  // and b's edge supports b against it.
  for (const Edge& x : a.edges_) {
    for (const Edge& y : b.edges_) {
      if (!arcs_cross(x.n1, x.n2, x.arc, y.n1 * -1.0, y.n2 * -1.0, y.arc)) continue;
      Vec3 normal = cross(x.direction, y.direction);
      const double len = norm(normal);
      if (!(len > 1e-12 * norm(x.direction) * norm(y.direction))) continue;  // parallel
      normal = normal / len;
      if (dot(normal, x.n1 + x.n2) < 0) normal = normal * -1.0;
      consider(dot(normal, x.point) - dot(normal, y.point + shift), normal);
    }
  }
  least.depth = std::max(0.0, least.depth);
  return least;
}

}  // namespace gvd::query
