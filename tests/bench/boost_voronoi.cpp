#include "bench/boost_voronoi.h"

#include <algorithm>
#include <boost/polygon/segment_data.hpp>
#include <boost/polygon/voronoi.hpp>
#include <chrono>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string>

namespace gvd::bench {

using namespace gvd::scene;

namespace {

namespace bp = boost::polygon;
using IPoint = bp::point_data<int32_t>;
using ISegment = bp::segment_data<int32_t>;
using Diagram = bp::voronoi_diagram<double>;

constexpr double kGrid = 1073741824.0;  // 2^30

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// Exact orientation of (p, q, r); coordinates are in [0, 2^30], so the products fit int64.
int orient(IPoint p, IPoint q, IPoint r) {
  const int64_t v = (int64_t{q.x()} - p.x()) * (int64_t{r.y()} - p.y()) -
                    (int64_t{q.y()} - p.y()) * (int64_t{r.x()} - p.x());
  return v > 0 ? 1 : (v < 0 ? -1 : 0);
}

bool on_segment(IPoint p, IPoint q, IPoint r) {  // r on pq, given collinear
  return std::min(p.x(), q.x()) <= r.x() && r.x() <= std::max(p.x(), q.x()) &&
         std::min(p.y(), q.y()) <= r.y() && r.y() <= std::max(p.y(), q.y());
}

bool intersect(const ISegment& s, const ISegment& t) {
  const IPoint a = s.low(), b = s.high(), c = t.low(), d = t.high();
  const int o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a), o4 = orient(c, d, b);
  if (o1 != o2 && o3 != o4) return true;
  return (o1 == 0 && on_segment(a, b, c)) || (o2 == 0 && on_segment(a, b, d)) ||
         (o3 == 0 && on_segment(c, d, a)) || (o4 == 0 && on_segment(c, d, b));
}

struct P2 {
  double x = 0, y = 0;
};

/// Length of segment pq inside [lo, hi]^2 (Liang–Barsky).
double clipped_length(P2 p, P2 q, double lo, double hi) {
  double t0 = 0, t1 = 1;
  const double dx = q.x - p.x, dy = q.y - p.y;
  const double pk[4] = {-dx, dx, -dy, dy};
  const double qk[4] = {p.x - lo, hi - p.x, p.y - lo, hi - p.y};
  for (int k = 0; k < 4; ++k) {
    if (pk[k] == 0) {
      if (qk[k] < 0) return 0;
      continue;
    }
    const double t = qk[k] / pk[k];
    if (pk[k] < 0)
      t0 = std::max(t0, t);
    else
      t1 = std::min(t1, t);
    if (t0 > t1) return 0;
  }
  return (t1 - t0) * std::hypot(dx, dy);
}

}  // namespace

BoostAdjacency boost_voronoi_adjacency(const Scene& scene, const Box& box) {
  if (scene.dimension != 2) throw std::runtime_error("boost_voronoi_adjacency: 2D scenes only");
  BoostAdjacency out;
  auto t0 = std::chrono::steady_clock::now();
  const double side = std::max(box.hi.x - box.lo.x, box.hi.y - box.lo.y);
  out.scale = kGrid / side;
  auto to_int = [&](Vec3 p) {
    const double x = std::round((p.x - box.lo.x) * out.scale);
    const double y = std::round((p.y - box.lo.y) * out.scale);
    if (!(x >= 0 && x <= kGrid && y >= 0 && y <= kGrid))
      throw std::runtime_error("boost_voronoi_adjacency: vertex outside the box");
    return IPoint(static_cast<int32_t>(x), static_cast<int32_t>(y));
  };

  std::vector<ISegment> segments;
  std::vector<ObjectId> object_of;
  std::vector<size_t> first(scene.objects.size() + 1, 0);
  struct IBox {
    int32_t lx, ly, hx, hy;
  };
  std::vector<IBox> boxes;
  for (size_t o = 0; o < scene.objects.size(); ++o) {
    const SceneObject& obj = scene.objects[o];
    first[o] = segments.size();
    IBox b{INT32_MAX, INT32_MAX, INT32_MIN, INT32_MIN};
    for (const Simplex& s : obj.simplices) {
      const IPoint p = to_int(obj.vertices[s.v[0]]), q = to_int(obj.vertices[s.v[1]]);
      if (p == q) continue;  // collapsed on the grid: its endpoints still carry the object
      segments.emplace_back(p, q);
      object_of.push_back(static_cast<ObjectId>(o));
      b = {std::min({b.lx, p.x(), q.x()}), std::min({b.ly, p.y(), q.y()}),
           std::max({b.hx, p.x(), q.x()}), std::max({b.hy, p.y(), q.y()})};
    }
    boxes.push_back(b);
  }
  first[scene.objects.size()] = segments.size();
  out.segments = segments.size();

  // Boost requires segments that meet at most in shared endpoints: within an object only
  // consecutive segments (sharing a vertex) may touch; across objects nothing may.
  auto shares_endpoint = [](const ISegment& s, const ISegment& t) {
    return s.low() == t.low() || s.low() == t.high() || s.high() == t.low() || s.high() == t.high();
  };
  for (size_t o = 0; o < scene.objects.size(); ++o) {
    for (size_t i = first[o]; i < first[o + 1]; ++i) {
      for (size_t j = i + 1; j < first[o + 1]; ++j) {
        if (shares_endpoint(segments[i], segments[j])) continue;
        if (intersect(segments[i], segments[j]))
          throw std::runtime_error("boost_voronoi_adjacency: object '" + scene.objects[o].label +
                                   "' self-intersects on the integer grid");
      }
    }
    for (size_t p = o + 1; p < scene.objects.size(); ++p) {
      const IBox& a = boxes[o];
      const IBox& b = boxes[p];
      if (a.hx < b.lx || b.hx < a.lx || a.hy < b.ly || b.hy < a.ly) continue;
      for (size_t i = first[o]; i < first[o + 1]; ++i) {
        for (size_t j = first[p]; j < first[p + 1]; ++j) {
          if (intersect(segments[i], segments[j]))
            throw std::runtime_error("boost_voronoi_adjacency: objects '" + scene.objects[o].label +
                                     "' and '" + scene.objects[p].label +
                                     "' meet on the integer grid");
        }
      }
    }
  }
  out.input_seconds = seconds_since(t0);

  t0 = std::chrono::steady_clock::now();
  Diagram vd;
  bp::construct_voronoi(segments.begin(), segments.end(), &vd);
  out.voronoi_seconds = seconds_since(t0);

  t0 = std::chrono::steady_clock::now();
  auto site_point = [&](const Diagram::cell_type& cell) {
    const ISegment& s = segments[cell.source_index()];
    const IPoint p =
        cell.source_category() == bp::SOURCE_CATEGORY_SEGMENT_START_POINT ? s.low() : s.high();
    return P2{static_cast<double>(p.x()), static_cast<double>(p.y())};
  };
  const double far = 4 * kGrid;
  std::map<std::pair<ObjectId, ObjectId>, double> length;
  std::vector<P2> line;
  for (const Diagram::edge_type& e : vd.edges()) {
    if (!e.is_primary() || &e > e.twin()) continue;  // each twin pair once
    ++out.voronoi_edges;
    const Diagram::cell_type& c1 = *e.cell();
    const Diagram::cell_type& c2 = *e.twin()->cell();
    ObjectId a = object_of[c1.source_index()], b = object_of[c2.source_index()];
    if (a == b) continue;
    if (a > b) std::swap(a, b);

    line.clear();
    if (e.is_finite() && e.is_curved()) {
      // Parabola between a point site and a segment site, sampled in the segment's frame:
      // y(x) = ((x - px)^2 + py^2) / (2 py) with the segment on the x axis.
      const Diagram::cell_type& pc = c1.contains_point() ? c1 : c2;
      const Diagram::cell_type& sc = c1.contains_point() ? c2 : c1;
      const P2 p = site_point(pc);
      const ISegment& s = segments[sc.source_index()];
      const P2 o{static_cast<double>(s.low().x()), static_cast<double>(s.low().y())};
      P2 u{s.high().x() - o.x, s.high().y() - o.y};
      const double len = std::hypot(u.x, u.y);
      u = {u.x / len, u.y / len};
      P2 n{-u.y, u.x};
      double px = (p.x - o.x) * u.x + (p.y - o.y) * u.y;
      double py = (p.x - o.x) * n.x + (p.y - o.y) * n.y;
      if (py < 0) {
        n = {-n.x, -n.y};
        py = -py;
      }
      auto along = [&](double x, double y) { return (x - o.x) * u.x + (y - o.y) * u.y; };
      const double x0 = along(e.vertex0()->x(), e.vertex0()->y());
      const double x1 = along(e.vertex1()->x(), e.vertex1()->y());
      constexpr int kChords = 32;
      line.push_back({e.vertex0()->x(), e.vertex0()->y()});
      for (int k = 1; k < kChords; ++k) {
        const double x = x0 + (x1 - x0) * k / kChords;
        const double y = ((x - px) * (x - px) + py * py) / (2 * py);
        line.push_back({o.x + u.x * x + n.x * y, o.y + u.y * x + n.y * y});
      }
      line.push_back({e.vertex1()->x(), e.vertex1()->y()});
    } else if (e.is_finite()) {
      line = {{e.vertex0()->x(), e.vertex0()->y()}, {e.vertex1()->x(), e.vertex1()->y()}};
    } else {
      // Infinite: a bisector of two point sites (Boost's voronoi_visualizer construction);
      // cell 1 lies on the left of the edge.
      P2 origin, dir;
      if (c1.contains_point() && c2.contains_point()) {
        const P2 p1 = site_point(c1), p2 = site_point(c2);
        origin = {(p1.x + p2.x) / 2, (p1.y + p2.y) / 2};
        dir = {p1.y - p2.y, p2.x - p1.x};
      } else {
        origin = c1.contains_segment() ? site_point(c2) : site_point(c1);
        const ISegment& s = segments[(c1.contains_segment() ? c1 : c2).source_index()];
        const double dx = s.high().x() - s.low().x(), dy = s.high().y() - s.low().y();
        const bool low_is_origin = s.low().x() == origin.x && s.low().y() == origin.y;
        dir = (low_is_origin != c1.contains_point()) ? P2{dy, -dx} : P2{-dy, dx};
      }
      const double k = far / std::max(std::abs(dir.x), std::abs(dir.y));
      line.push_back(e.vertex0() ? P2{e.vertex0()->x(), e.vertex0()->y()}
                                 : P2{origin.x - dir.x * k, origin.y - dir.y * k});
      line.push_back(e.vertex1() ? P2{e.vertex1()->x(), e.vertex1()->y()}
                                 : P2{origin.x + dir.x * k, origin.y + dir.y * k});
    }
    double inside = 0;
    for (size_t k = 0; k + 1 < line.size(); ++k)
      inside += clipped_length(line[k], line[k + 1], 0, kGrid);
    if (inside <= 0) {
      ++out.edges_outside;
      continue;
    }
    length[{a, b}] += inside / out.scale;
  }
  for (const auto& [ab, len] : length) out.pairs.push_back({ab.first, ab.second, len});
  out.adjacency_seconds = seconds_since(t0);
  return out;
}

}  // namespace gvd::bench
