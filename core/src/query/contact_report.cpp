// find_contacts: pairs closer than a bound (bounding-box sweep, then exact BVH distances), the
// interference depth of pairs that meet (exact for convex pairs: penetration_depth.h), and the
// sites of their GVD interface below the bound.
#include "gvd/query/contact_report.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <numeric>
#include <optional>
#include <tuple>
#include <unordered_map>

#include "gvd/common/error.h"
#include "gvd/common/parallel.h"
#include "gvd/common/union_find.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/query/penetration_depth.h"

namespace gvd::query {

using namespace gvd::scene;
using namespace gvd::surface;
using namespace gvd::graph;
using namespace gvd::result;

namespace {

using nlohmann::json;

/// Pairs of objects whose bounding boxes (unit coordinates) are within `reach` of each other:
/// a sweep over the boxes sorted by their lower x. More than `limit` of them is
/// gvd::Error{kLimitExceeded}, said before any exact distance is computed.
std::vector<std::pair<ObjectId, ObjectId>> candidate_pairs(const UnitGeometry& g, double reach,
                                                           size_t limit, double max_gap) {
  std::vector<Box> boxes(g.object_count);
  for (size_t s = 0; s < g.simplices.size(); ++s) {
    const int arity = g.dimension == 2 ? 2 : 3;
    for (int k = 0; k < arity; ++k) boxes[g.object_of[s]].extend(g.points[g.simplices[s].v[k]]);
  }
  std::vector<ObjectId> order;
  for (ObjectId o = 0; o < g.object_count; ++o)
    if (boxes[o].lo.x <= boxes[o].hi.x) order.push_back(o);
  std::sort(order.begin(), order.end(),
            [&](ObjectId l, ObjectId r) { return boxes[l].lo.x < boxes[r].lo.x; });
  std::vector<std::pair<ObjectId, ObjectId>> out;
  for (size_t i = 0; i < order.size(); ++i) {
    const Box& bi = boxes[order[i]];
    for (size_t j = i + 1; j < order.size() && boxes[order[j]].lo.x <= bi.hi.x + reach; ++j) {
      const Box& bj = boxes[order[j]];
      double gap2 = 0;
      for (int a = 0; a < 3; ++a) {
        const double d = std::max({0.0, bj.lo[a] - bi.hi[a], bi.lo[a] - bj.hi[a]});
        gap2 += d * d;
      }
      if (gap2 > reach * reach) continue;
      if (out.size() == limit) {
        throw Error(ErrorCode::kLimitExceeded,
                    "more than " + std::to_string(limit) +
                        " object pairs have bounding boxes within max_gap = " +
                        std::to_string(max_gap) + ": lower the bound");
      }
      out.emplace_back(std::min(order[i], order[j]), std::max(order[i], order[j]));
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

/// The deepest vertex of `object` inside the closed object `other`, measured to `other`'s
/// surface (user units); -1 when `other` is not closed or no vertex is inside.
double deepest_vertex_inside(const GvdIndex& index, ObjectId object, ObjectId other) {
  if (!index.is_closed(other)) return -1;
  const GvdResult& r = index.result();
  Box box;
  for (const Vec3& v : r.scene.objects[other].vertices) box.extend(v);
  double deepest = -1;
  for (const Vec3& v : r.scene.objects[object].vertices) {
    bool in_box = true;
    for (int a = 0; a < r.scene.dimension; ++a) in_box &= v[a] >= box.lo[a] && v[a] <= box.hi[a];
    if (!in_box || index.inside(v, other) != 1) continue;
    const ClosestHit hit = index.bvh().nearest_in_object(r.domain.to_unit(v), other);
    if (hit.found()) deepest = std::max(deepest, std::sqrt(hit.dist2) * r.domain.side);
  }
  return deepest;
}

/// The part of the interface between two objects where the clearance is below t, measured
/// on the GVD's pieces with exact clearances. The clearance is 1-Lipschitz, so a piece whose
/// least corner clearance exceeds t by more than the farthest any of its points lies from its
/// nearest corner (a triangle: longest edge / sqrt 3; a segment: half its length) has no point
/// below t; any other piece that is not wholly below is split (segments in two, triangles in
/// four, exact clearances at the new corners) down to pieces of 1/20 of t, where the
/// clearance is interpolated linearly. A piece whose corners are all below t counts whole.
template <class Clearance>
class BelowBound {
 public:
  BelowBound(double t, const Clearance& clearance) : t_(t), clearance_(clearance) {}

  struct Part {
    double measure = 0;    ///< area (length) below t
    Vec3 moment;           ///< measure x centroid
    double least = 1e300;  ///< the least clearance seen on the piece
    Vec3 at;               ///< where
  };

  /// The part of a piece (n = 2: segment, 3: triangle) with corners p and clearances c.
  Part piece(const Vec3* p, const double* c, int n) const {
    Part part;
    for (int k = 0; k < n; ++k) note(part, p[k], c[k]);
    add(p, c, n, kMaxDepth, part);
    return part;
  }

  /// Whether some point of segment p0 p1 (clearances c0, c1) is below t.
  bool edge(Vec3 p0, Vec3 p1, double c0, double c1, int depth = kMaxDepth) const {
    if (c0 < t_ || c1 < t_) return true;
    const double l = dist(p0, p1);
    if (std::min(c0, c1) - 0.5 * l >= t_ || depth == 0 || l <= resolution()) return false;
    const Vec3 m = (p0 + p1) * 0.5;
    const double cm = clearance_(m);
    return edge(p0, m, c0, cm, depth - 1) || edge(m, p1, cm, c1, depth - 1);
  }

 private:
  static constexpr int kMaxDepth = 14;
  double resolution() const { return 0.25 * t_; }

  static void note(Part& part, Vec3 p, double c) {
    if (c < part.least) {
      part.least = c;
      part.at = p;
    }
  }

  void add(const Vec3* p, const double* c, int n, int depth, Part& part) const {
    double lo = 1e300, hi = -1e300, longest = 0;
    for (int k = 0; k < n; ++k) {
      lo = std::min(lo, c[k]);
      hi = std::max(hi, c[k]);
      longest = std::max(longest, dist(p[k], p[(k + 1) % n]));
    }
    const double reach = n == 2 ? 0.5 * longest : longest / std::sqrt(3.0);
    if (lo - reach >= t_) return;
    if (hi < t_ || depth == 0 || longest <= resolution()) {
      linear(p, c, n, part);
      return;
    }
    if (n == 2) {
      const Vec3 m = (p[0] + p[1]) * 0.5;
      const double cm = clearance_(m);
      note(part, m, cm);
      const Vec3 a[2] = {p[0], m}, b[2] = {m, p[1]};
      const double ca[2] = {c[0], cm}, cb[2] = {cm, c[1]};
      add(a, ca, 2, depth - 1, part);
      add(b, cb, 2, depth - 1, part);
      return;
    }
    const Vec3 m01 = (p[0] + p[1]) * 0.5, m12 = (p[1] + p[2]) * 0.5, m20 = (p[2] + p[0]) * 0.5;
    const double c01 = clearance_(m01), c12 = clearance_(m12), c20 = clearance_(m20);
    note(part, m01, c01);
    note(part, m12, c12);
    note(part, m20, c20);
    const Vec3 parts[4][3] = {
        {p[0], m01, m20}, {m01, p[1], m12}, {m20, m12, p[2]}, {m01, m12, m20}};
    const double cs[4][3] = {{c[0], c01, c20}, {c01, c[1], c12}, {c20, c12, c[2]}, {c01, c12, c20}};
    for (int k = 0; k < 4; ++k) add(parts[k], cs[k], 3, depth - 1, part);
  }

  /// The part below t with the clearance interpolated linearly between the corners.
  void linear(const Vec3* p, const double* c, int n, Part& part) const {
    Vec3 kept[4];
    int m = 0;
    for (int i = 0; i < n; ++i) {
      const int j = (i + 1) % n;
      if (c[i] < t_) kept[m++] = p[i];
      if ((c[i] < t_) != (c[j] < t_) && (n == 3 || i == 0))
        kept[m++] = p[i] + (p[j] - p[i]) * ((t_ - c[i]) / (c[j] - c[i]));
    }
    if (n == 2) {
      if (m < 2) return;
      const double l = dist(kept[0], kept[1]);
      part.measure += l;
      part.moment = part.moment + (kept[0] + kept[1]) * (0.5 * l);
      return;
    }
    for (int k = 1; k + 1 < m; ++k) {
      const double area = 0.5 * norm(cross(kept[k] - kept[0], kept[k + 1] - kept[0]));
      part.measure += area;
      part.moment = part.moment + (kept[0] + kept[k] + kept[k + 1]) * (area / 3);
    }
  }

  double t_;
  const Clearance& clearance_;
};

/// The sites of the interface between contact.a and contact.b: the pieces of a's cell facing
/// b (indices into its simplices) measured below clearance t (BelowBound), joined where they
/// share a vertex or an edge with a point below t.
void find_sites(const GvdIndex& index, const std::vector<uint32_t>& pieces, double t,
                Contact& contact) {
  if (!(t > 0)) return;
  const GvdResult& r = index.result();
  const GvdCell& cell = r.gvd.cells[contact.a];
  const int n = r.scene.dimension == 2 ? 2 : 3;
  // The clearance of a point of the interface: its exact distance to a (and so to b).
  auto clearance = [&](Vec3 x) {
    const ClosestHit hit = index.bvh().nearest_in_object(r.domain.to_unit(x), contact.a);
    return std::sqrt(hit.dist2) * r.domain.side;
  };
  const BelowBound<decltype(clearance)> below(t, clearance);
  UnionFind parts(pieces.size());
  // The first piece at each vertex below t, and at each edge (its ends, in order) that has a
  // point below t (2D pieces meet at vertices only).
  std::unordered_map<Vec3, uint32_t, PositionHash>
      at_vertex;  // the GVD's pieces share vertices exactly
  struct EdgeKey {
    Vec3 lo, hi;
    bool operator==(const EdgeKey& o) const { return lo == o.lo && hi == o.hi; }
  };
  struct EdgeHash {
    size_t operator()(const EdgeKey& e) const {
      return PositionHash{}(e.lo) * 31 + PositionHash{}(e.hi);
    }
  };
  std::unordered_map<EdgeKey, std::pair<uint32_t, bool>, EdgeHash> at_edge;
  std::vector<typename BelowBound<decltype(clearance)>::Part> part(pieces.size());
  for (uint32_t i = 0; i < pieces.size(); ++i) {
    Vec3 p[3];
    double c[3];
    for (int k = 0; k < n; ++k) {
      const uint32_t v = cell.indices[static_cast<size_t>(pieces[i]) * n + k];
      p[k] = cell.positions[v];
      c[k] = cell.clearance[v];
    }
    part[i] = below.piece(p, c, n);
    if (!(part[i].measure > 0)) continue;
    for (int k = 0; k < n; ++k) {
      if (!(c[k] < t)) continue;
      const auto [it, added] = at_vertex.try_emplace(p[k], i);
      if (!added) parts.unite(i, it->second);
    }
    if (n == 2) continue;
    for (int k = 0; k < 3; ++k) {
      const int j = (k + 1) % 3;
      const bool order = std::tie(p[k].x, p[k].y, p[k].z) < std::tie(p[j].x, p[j].y, p[j].z);
      const EdgeKey key{order ? p[k] : p[j], order ? p[j] : p[k]};
      const auto [it, added] = at_edge.try_emplace(key, i, false);
      if (added) {
        it->second.second = below.edge(p[k], p[j], c[k], c[j]);
      } else if (it->second.second) {
        parts.unite(i, it->second.first);
      }
    }
  }
  // Per component: measure, centroid, and the least clearances seen on its pieces.
  std::unordered_map<uint32_t, size_t> site_of;
  std::vector<std::vector<std::pair<double, Vec3>>> low;
  for (uint32_t i = 0; i < pieces.size(); ++i) {
    if (!(part[i].measure > 0)) continue;
    const auto [it, added] = site_of.try_emplace(parts.find(i), contact.sites.size());
    if (added) {
      contact.sites.emplace_back();
      low.emplace_back();
    }
    ContactSite& site = contact.sites[it->second];
    site.centroid = site.centroid + part[i].moment;
    site.area += part[i].measure;
    low[it->second].emplace_back(part[i].least, part[i].at);
  }
  // The least gap across each site, measured where its clearance is least: the exact closest
  // points on a and on b, and their distance.
  constexpr size_t kProbes = 16;
  const SimplexBvh& bvh = index.bvh();
  for (size_t s = 0; s < contact.sites.size(); ++s) {
    ContactSite& site = contact.sites[s];
    site.centroid = site.centroid * (1 / site.area);
    std::vector<std::pair<double, Vec3>>& probes = low[s];
    const size_t keep = std::min(probes.size(), kProbes);
    std::partial_sort(probes.begin(), probes.begin() + static_cast<std::ptrdiff_t>(keep),
                      probes.end(), [](const auto& l, const auto& q) {
                        return std::tie(l.first, l.second.x, l.second.y, l.second.z) <
                               std::tie(q.first, q.second.x, q.second.y, q.second.z);
                      });
    site.min_gap = std::numeric_limits<double>::infinity();
    for (size_t k = 0; k < keep; ++k) {
      const Vec3 u = r.domain.to_unit(probes[k].second);
      const ClosestHit ha = bvh.nearest_in_object(u, contact.a);
      const ClosestHit hb = bvh.nearest_in_object(u, contact.b);
      if (!ha.found() || !hb.found()) continue;
      const double gap = dist(ha.point, hb.point) * r.domain.side;
      if (gap < site.min_gap) {
        site.min_gap = gap;
        site.on_a = r.domain.from_unit(ha.point);
        site.on_b = r.domain.from_unit(hb.point);
      }
    }
  }
  std::sort(contact.sites.begin(), contact.sites.end(),
            [](const ContactSite& l, const ContactSite& q) { return l.area > q.area; });
}

json point_json(Vec3 p, int dimension) {
  return dimension == 2 ? json::array({p.x, p.y}) : json::array({p.x, p.y, p.z});
}

}  // namespace

std::vector<Contact> find_contacts(const GvdIndex& index, double max_gap, size_t max_candidates) {
  if (!(max_gap >= 0) || !std::isfinite(max_gap)) {
    throw Error(ErrorCode::kInvalidArgument,
                "max_gap must be a finite distance >= 0 (got " + std::to_string(max_gap) + ")");
  }
  const GvdResult& r = index.result();
  const double side = r.domain.side;
  const double reach = max_gap / side;
  const std::vector<std::pair<ObjectId, ObjectId>> candidates =
      candidate_pairs(r.geometry, reach, max_candidates, max_gap);
  std::vector<SimplexBvh::ObjectPair> measured(candidates.size());
  const int threads = resolve_threads(0);
  parallel_for(
      candidates.size(), threads,
      [&](size_t b, size_t e, int) {
        for (size_t i = b; i < e; ++i) {
          // Touching pairs (distance 0) are found with a bound of zero too.
          measured[i] = index.bvh().object_distance(candidates[i].first, candidates[i].second,
                                                    std::max(reach * reach, 1e-300));
        }
      },
      1);
  std::vector<Contact> out;
  for (size_t i = 0; i < candidates.size(); ++i) {
    if (!measured[i].found) continue;
    const double gap = std::sqrt(measured[i].dist2) * side;
    if (!(gap < max_gap) && measured[i].dist2 != 0) continue;
    Contact c;
    c.a = candidates[i].first;
    c.b = candidates[i].second;
    c.gap = gap;
    c.on_a = r.domain.from_unit(measured[i].on_a);
    c.on_b = r.domain.from_unit(measured[i].on_b);
    c.interference = measured[i].dist2 == 0;
    out.push_back(c);
  }
  // The interface pieces of every pair, in one pass over the cells of the objects involved.
  std::unordered_map<uint64_t, size_t> contact_of;
  std::vector<uint8_t> involved(r.scene.objects.size(), 0);
  for (size_t i = 0; i < out.size(); ++i) {
    contact_of[(static_cast<uint64_t>(out[i].a) << 32) | out[i].b] = i;
    involved[out[i].a] = 1;
  }
  // The convex shapes of the objects that interfere, each found once.
  std::vector<ObjectId> interfering;
  for (const Contact& c : out) {
    if (!c.interference) continue;
    interfering.push_back(c.a);
    interfering.push_back(c.b);
  }
  std::sort(interfering.begin(), interfering.end());
  interfering.erase(std::unique(interfering.begin(), interfering.end()), interfering.end());
  std::vector<std::optional<ConvexShape>> shapes(interfering.size());
  parallel_for(
      interfering.size(), threads,
      [&](size_t b, size_t e, int) {
        for (size_t i = b; i < e; ++i)
          shapes[i] = ConvexShape::of(r.scene.objects[interfering[i]], r.scene.dimension);
      },
      1);
  auto shape_of = [&](ObjectId o) -> const std::optional<ConvexShape>& {
    return shapes[std::lower_bound(interfering.begin(), interfering.end(), o) -
                  interfering.begin()];
  };
  std::vector<std::vector<uint32_t>> pieces(out.size());
  const size_t arity = r.scene.dimension == 2 ? 2 : 3;
  for (ObjectId a = 0; a < r.gvd.cells.size(); ++a) {
    if (!involved[a]) continue;
    const GvdCell& cell = r.gvd.cells[a];
    for (size_t k = 0; k * arity < cell.indices.size(); ++k) {
      const ObjectId b = cell.other[cell.indices[k * arity]];
      if (b == kNoObject || b <= a) continue;
      const auto it = contact_of.find((static_cast<uint64_t>(a) << 32) | b);
      if (it != contact_of.end()) pieces[it->second].push_back(static_cast<uint32_t>(k));
    }
  }
  parallel_for(
      out.size(), threads,
      [&](size_t b, size_t e, int) {
        for (size_t i = b; i < e; ++i) {
          Contact& c = out[i];
          const auto edge =
              std::lower_bound(r.graph.edges.begin(), r.graph.edges.end(), std::pair{c.a, c.b},
                               [](const DualEdge& d, const std::pair<ObjectId, ObjectId>& key) {
                                 return std::pair{d.a, d.b} < key;
                               });
          if (edge != r.graph.edges.end() && edge->a == c.a && edge->b == c.b)
            c.interface_area = edge->area;
          if (c.interference) {
            c.depth_lower_bound = std::max(deepest_vertex_inside(index, c.a, c.b),
                                           deepest_vertex_inside(index, c.b, c.a));
            const std::optional<ConvexShape>&sa = shape_of(c.a), &sb = shape_of(c.b);
            if (sa && sb) {
              const auto penetration = ConvexShape::penetration(*sa, *sb);
              if (penetration) c.penetration_depth = penetration->depth;
            }
          }
          find_sites(index, pieces[i], 0.5 * max_gap, c);
        }
      },
      1);
  std::sort(out.begin(), out.end(), [](const Contact& l, const Contact& q) {
    return std::tie(l.gap, l.a, l.b) < std::tie(q.gap, q.a, q.b);
  });
  return out;
}

std::string contacts_to_json(const GvdIndex& index, double max_gap,
                             const std::vector<Contact>& contacts) {
  const GvdResult& r = index.result();
  const int dim = r.scene.dimension;
  json list = json::array();
  for (const Contact& c : contacts) {
    json sites = json::array();
    for (const ContactSite& s : c.sites) {
      sites.push_back({{"area", s.area},
                       {"centroid", point_json(s.centroid, dim)},
                       {"min_gap", std::isfinite(s.min_gap) ? json(s.min_gap) : json(nullptr)},
                       {"on_a", point_json(s.on_a, dim)},
                       {"on_b", point_json(s.on_b, dim)}});
    }
    list.push_back(
        {{"a", c.a},
         {"label_a", r.scene.objects[c.a].label},
         {"b", c.b},
         {"label_b", r.scene.objects[c.b].label},
         {"gap", c.gap},
         {"on_a", point_json(c.on_a, dim)},
         {"on_b", point_json(c.on_b, dim)},
         {"interference", c.interference},
         {"depth_lower_bound", c.depth_lower_bound < 0 ? json(nullptr) : json(c.depth_lower_bound)},
         {"penetration_depth", c.penetration_depth < 0 ? json(nullptr) : json(c.penetration_depth)},
         {"interface_area", c.interface_area},
         {"sites", std::move(sites)}});
  }
  json out{{"max_gap", max_gap}, {"contacts", std::move(list)}};
  if (!r.scene.units.empty()) out["units"] = r.scene.units;
  return out.dump();
}

}  // namespace gvd::query
