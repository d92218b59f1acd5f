#include "gvd/surface/compact_gvd.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <vector>

#include "gvd/common/error.h"
#include "gvd/common/parallel.h"
#include "gvd/geometry/simplex_bvh.h"

namespace gvd::surface {

using namespace gvd::scene;

namespace {

constexpr double kFlat = 1e-12;  // relative to the local size: what counts as one plane

// Polled every 4096 vertices of a cell (a vertex's star costs microseconds; with curved
// removal, exact triangle distances: still well under a millisecond per 4096).
void check_cancel(const std::atomic<bool>* cancel, uint32_t v) {
  if ((v & 4095) == 0 && cancel != nullptr && cancel->load(std::memory_order_relaxed))
    throw Error(ErrorCode::kCancelled, "compaction cancelled");
}

// 2D: a vertex between two segments of one line (same other object) is dropped and the two
// segments become one.
void compact_cell_2d(GvdCell& cell, const std::atomic<bool>* cancel) {
  const size_t nv = cell.positions.size();
  std::vector<uint32_t> out_of(nv, ~0u), into(nv, ~0u);  // segment leaving / entering a vertex
  std::vector<uint8_t> many(nv, 0);
  const size_t ns = cell.indices.size() / 2;
  for (uint32_t s = 0; s < ns; ++s) {
    const uint32_t a = cell.indices[2 * s], b = cell.indices[2 * s + 1];
    many[a] |= out_of[a] != ~0u;
    many[b] |= into[b] != ~0u;
    out_of[a] = s;
    into[b] = s;
  }
  std::vector<uint8_t> dead(ns, 0);
  for (uint32_t v = 0; v < nv; ++v) {
    check_cancel(cancel, v);
    if (many[v] || out_of[v] == ~0u || into[v] == ~0u) continue;
    const uint32_t s_in = into[v], s_out = out_of[v];
    if (s_in == s_out || dead[s_in] || dead[s_out]) continue;
    const uint32_t a = cell.indices[2 * s_in], b = cell.indices[2 * s_out + 1];
    if (a == b) continue;
    const Vec3 pa = cell.positions[a], pv = cell.positions[v], pb = cell.positions[b];
    const Vec3 d = pb - pa;
    const double l2 = norm2(d);
    if (!(l2 > 0)) continue;
    // v on segment [a, b] (between its ends, off the line by at most kFlat of its length).
    const double cr = (pv.x - pa.x) * d.y - (pv.y - pa.y) * d.x;
    const double t = dot(pv - pa, d) / l2;
    if (!(std::abs(cr) <= kFlat * l2) || !(t > 0 && t < 1)) continue;
    cell.indices[2 * s_in + 1] = b;  // a -> b
    into[b] = s_in;
    dead[s_out] = 1;
  }
  std::vector<uint32_t> kept;
  kept.reserve(cell.indices.size());
  for (uint32_t s = 0; s < ns; ++s) {
    if (dead[s]) continue;
    kept.push_back(cell.indices[2 * s]);
    kept.push_back(cell.indices[2 * s + 1]);
  }
  cell.indices = std::move(kept);
}

// Ear clipping of a simple polygon given in 2D (ring order counter-clockwise); false when no
// ear is found (degenerate). Triangles as indices into the ring.
bool ear_clip(const std::vector<double>& x, const std::vector<double>& y,
              std::vector<uint32_t>& triangles) {
  const size_t n = x.size();
  std::vector<uint32_t> ring(n);
  for (uint32_t i = 0; i < n; ++i) ring[i] = i;
  auto cross = [&](uint32_t a, uint32_t b, uint32_t c) {
    return (x[b] - x[a]) * (y[c] - y[a]) - (y[b] - y[a]) * (x[c] - x[a]);
  };
  double scale = 0;
  for (size_t i = 0; i < n; ++i) scale = std::max({scale, std::abs(x[i]), std::abs(y[i])});
  const double tiny = 1e-14 * scale * scale;
  while (ring.size() > 3) {
    bool found = false;
    for (size_t i = 0; i < ring.size() && !found; ++i) {
      const uint32_t a = ring[(i + ring.size() - 1) % ring.size()], b = ring[i],
                     c = ring[(i + 1) % ring.size()];
      if (!(cross(a, b, c) > tiny)) continue;  // reflex or straight: not an ear
      bool empty = true;
      for (uint32_t p : ring) {
        if (p == a || p == b || p == c) continue;
        if (cross(a, b, p) >= 0 && cross(b, c, p) >= 0 && cross(c, a, p) >= 0) {
          empty = false;
          break;
        }
      }
      if (!empty) continue;
      triangles.insert(triangles.end(), {a, b, c});
      ring.erase(ring.begin() + static_cast<std::ptrdiff_t>(i));
      found = true;
    }
    if (!found) return false;
  }
  if (!(cross(ring[0], ring[1], ring[2]) > tiny)) return false;
  triangles.insert(triangles.end(), {ring[0], ring[1], ring[2]});
  return true;
}

// Curved stars: where the removal may move the surface (`tolerance` > 0), the bound of how far
// each triangle is from the surfaced GVD, and what every new triangle must keep clear of.
struct CurvedRemoval {
  double tolerance = 0;  // of the least clearance at the star's vertices
  const SimplexBvh* bvh = nullptr;
  const Domain* domain = nullptr;
};

void compact_cell_3d(GvdCell& cell, const CurvedRemoval& curved, const std::atomic<bool>* cancel) {
  const size_t nv = cell.positions.size();
  std::vector<uint32_t>& idx = cell.indices;
  const size_t nt0 = idx.size() / 3;
  // Triangles around each vertex: the surfaced ones in CSR form, new ones in linked lists.
  std::vector<uint32_t> begin(nv + 1, 0), incident(idx.size());
  for (uint32_t i : idx) ++begin[i + 1];
  for (size_t v = 0; v < nv; ++v) begin[v + 1] += begin[v];
  {
    std::vector<uint32_t> fill(begin.begin(), begin.end() - 1);
    for (uint32_t t = 0; t < nt0; ++t)
      for (int k = 0; k < 3; ++k) incident[fill[idx[3 * t + k]]++] = t;
  }
  std::vector<uint32_t> head(nv, ~0u), next, added;  // added[i]: a new triangle, next[i]: link
  std::vector<uint8_t> dead(nt0, 0);
  std::vector<double> error(nt0, 0.0);  // how far each triangle may be from the surfaced GVD
  std::vector<uint32_t> around, link, made, sorted_link;
  std::vector<std::pair<uint32_t, uint32_t>> edges;
  std::vector<double> px, py;
  for (uint32_t v = 0; v < nv; ++v) {
    check_cancel(cancel, v);
    around.clear();
    for (uint32_t k = begin[v]; k < begin[v + 1]; ++k)
      if (!dead[incident[k]]) around.push_back(incident[k]);
    for (uint32_t i = head[v]; i != ~0u; i = next[i])
      if (!dead[added[i]]) around.push_back(added[i]);
    if (around.size() < 3) continue;
    // The link as a cycle: each triangle (v, p, q) in its orientation gives the edge p -> q.
    link.clear();
    edges.clear();
    for (uint32_t t : around) {
      int k = 0;
      while (idx[3 * t + k] != v) ++k;
      edges.push_back({idx[3 * t + (k + 1) % 3], idx[3 * t + (k + 2) % 3]});
    }
    bool cycle = true;
    link.push_back(edges[0].first);
    uint32_t at = edges[0].second;
    for (size_t step = 1; step < edges.size() && cycle; ++step) {
      link.push_back(at);
      size_t found = edges.size();
      for (size_t e = 0; e < edges.size(); ++e)
        if (edges[e].first == at) found = (found == edges.size()) ? e : edges.size() + 1;
      if (found >= edges.size())
        cycle = false;
      else
        at = edges[found].second;
    }
    if (!cycle || at != link[0]) continue;
    {
      sorted_link = link;
      std::sort(sorted_link.begin(), sorted_link.end());
      if (std::adjacent_find(sorted_link.begin(), sorted_link.end()) != sorted_link.end()) continue;
    }
    // One plane: the star's area-weighted normal n; every triangle facing along it (no
    // fold) and every link vertex on the plane through v, to kFlat of the star's radius
    // plus the coordinates' rounding.
    const Vec3 o = cell.positions[v];
    Vec3 n;
    double radius = 0, magnitude = std::max({std::abs(o.x), std::abs(o.y), std::abs(o.z)});
    for (uint32_t w : link) radius = std::max(radius, dist(o, cell.positions[w]));
    for (uint32_t t : around) {
      const Vec3 a = cell.positions[idx[3 * t]], b = cell.positions[idx[3 * t + 1]],
                 c = cell.positions[idx[3 * t + 2]];
      n = n + cross(b - a, c - a);
    }
    if (!(radius > 0 && norm(n) > 0)) continue;
    n = n / norm(n);
    // Every triangle facing along n (within 60 degrees when the star is curved, so that it
    // projects onto the plane without folding).
    double least_cos = 1;
    for (uint32_t t : around) {
      const Vec3 a = cell.positions[idx[3 * t]], b = cell.positions[idx[3 * t + 1]],
                 c = cell.positions[idx[3 * t + 2]];
      const Vec3 m = cross(b - a, c - a);
      const double l = norm(m);
      least_cos = l > 0 ? std::min(least_cos, dot(m, n) / l) : -1;  // a sliver: keep the star
      if (!(least_cos > 0)) break;
    }
    if (!(least_cos > 0)) continue;
    const double tolerance = kFlat * radius + 1e-15 * magnitude;
    double off = 0;  // how far the link is from the plane through v
    for (uint32_t w : link) off = std::max(off, std::abs(dot(cell.positions[w] - o, n)));
    double star_error = 0;
    for (uint32_t t : around) star_error = std::max(star_error, error[t]);
    double new_error = star_error;
    if (!(off <= tolerance)) {
      // Curved: the old star and the new patch both lie within `off` of the plane over the
      // same region of it, so they are within 2 off of each other.
      if (curved.tolerance <= 0 || curved.bvh == nullptr || !(least_cos > 0.5)) continue;
      double clearance = cell.clearance[v];
      for (uint32_t w : link) clearance = std::min(clearance, cell.clearance[w]);
      new_error = star_error + 2 * off;
      if (!(new_error <= curved.tolerance * clearance)) continue;
    }
    // The link in the plane's coordinates (counter-clockwise seen along n, as the triangles).
    Vec3 u = std::abs(n.x) < 0.9 ? cross(n, Vec3{1, 0, 0}) : cross(n, Vec3{0, 1, 0});
    u = u / norm(u);
    const Vec3 w2 = cross(n, u);
    px.clear();
    py.clear();
    for (uint32_t w : link) {
      px.push_back(dot(cell.positions[w] - o, u));
      py.push_back(dot(cell.positions[w] - o, w2));
    }
    // The link goes once around v in the plane (its angles add up to one turn), so it bounds
    // the star's projection and ear clipping covers exactly the star.
    double turn = 0;
    for (size_t i = 0; i < link.size(); ++i) {
      const size_t j = (i + 1) % link.size();
      turn += std::atan2(px[i] * py[j] - py[i] * px[j], px[i] * px[j] + py[i] * py[j]);
    }
    if (!(std::abs(turn - 2 * std::acos(-1.0)) < 1e-6)) continue;
    made.clear();
    if (!ear_clip(px, py, made)) continue;
    double least_clearance = cell.clearance[v];
    for (uint32_t w : link) least_clearance = std::min(least_clearance, cell.clearance[w]);
    // A moved piece must keep clear of every object by half the least clearance of its star.
    // The distance to the objects is 1-Lipschitz: the old star's points are at least that
    // clearance less the star's radius away, the new patch within new_error of them, so the
    // exact test is needed only when those two together exceed half the clearance.
    if (new_error > star_error && radius + new_error > 0.5 * least_clearance) {
      // Exact triangle distances; crossings count as 0.
      const double clearance = least_clearance;
      const double keep = 0.5 * clearance / curved.domain->side;
      bool clear = true;
      for (size_t k = 0; k < made.size() && clear; k += 3) {
        Vec3 q[3];
        for (int j = 0; j < 3; ++j)
          q[j] = curved.domain->to_unit(cell.positions[link[made[k + j]]]);
        clear = !curved.bvh->closest_to_simplex(q, keep * keep).found();
      }
      if (!clear) continue;
    }
    for (uint32_t t : around) dead[t] = 1;
    for (size_t k = 0; k < made.size(); k += 3) {
      const uint32_t t = static_cast<uint32_t>(idx.size() / 3);
      for (int j = 0; j < 3; ++j) {
        const uint32_t w = link[made[k + j]];
        idx.push_back(w);
        added.push_back(t);
        next.push_back(head[w]);
        head[w] = static_cast<uint32_t>(added.size() - 1);
      }
      dead.push_back(0);
      error.push_back(new_error);
    }
  }
  std::vector<uint32_t> kept;
  kept.reserve(idx.size());
  for (size_t t = 0; t < dead.size(); ++t)
    if (!dead[t]) kept.insert(kept.end(), {idx[3 * t], idx[3 * t + 1], idx[3 * t + 2]});
  idx = std::move(kept);
}

// Drops the vertices no simplex uses and renumbers.
void drop_unused(GvdCell& cell) {
  std::vector<uint32_t> map(cell.positions.size(), ~0u);
  for (uint32_t i : cell.indices) map[i] = 0;
  uint32_t next = 0;
  for (size_t v = 0; v < map.size(); ++v) {
    if (map[v] == ~0u) continue;
    map[v] = next;
    cell.positions[next] = cell.positions[v];
    cell.other[next] = cell.other[v];
    cell.clearance[next] = cell.clearance[v];
    ++next;
  }
  cell.positions.resize(next);
  cell.other.resize(next);
  cell.clearance.resize(next);
  for (uint32_t& i : cell.indices) i = map[i];
}

}  // namespace

CompactStats compact_gvd(Gvd& gvd, const CompactOptions& options) {
  const int threads = options.threads;
  CurvedRemoval curved;
  if (options.bvh != nullptr && options.domain != nullptr) {
    curved.tolerance = options.curved_tolerance;
    curved.bvh = options.bvh;
    curved.domain = options.domain;
  }
  const int arity = gvd.dimension == 2 ? 2 : 3;
  CompactStats stats;
  for (const GvdCell& c : gvd.cells) stats.simplices_before += c.indices.size() / arity;
  parallel_for(
      gvd.cells.size(), threads,
      [&](size_t b, size_t e, int) {
        for (size_t i = b; i < e; ++i) {
          GvdCell& cell = gvd.cells[i];
          if (gvd.dimension == 2) {
            compact_cell_2d(cell, options.cancel);
          } else {
            compact_cell_3d(cell, curved, options.cancel);
          }
          drop_unused(cell);
        }
      },
      1);
  for (const GvdCell& c : gvd.cells) stats.simplices_after += c.indices.size() / arity;
  return stats;
}

}  // namespace gvd::surface
