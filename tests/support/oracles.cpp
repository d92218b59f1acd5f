#include "support/oracles.h"

#include <algorithm>
#include <cmath>
#include <tuple>
#include <utility>
#include <vector>

#include "gvd/geometry/primitives.h"

namespace gvd::test {

using namespace gvd::scene;
using namespace gvd::surface;

double brute_distance(const Scene& scene, ObjectId o, Vec3 p) {
  const SceneObject& obj = scene.objects[o];
  double best = 1e300;
  for (const Simplex& s : obj.simplices) {
    const Vec3 q = scene.dimension == 2
                       ? closest_point_on_segment(p, obj.vertices[s.v[0]], obj.vertices[s.v[1]])
                       : closest_point_on_triangle(p, obj.vertices[s.v[0]], obj.vertices[s.v[1]],
                                                   obj.vertices[s.v[2]]);
    best = std::min(best, dist(p, q));
  }
  return best;
}

double brute_mesh_distance(const SceneObject& a, const SceneObject& b) {
  auto edges = [](const SceneObject& o) {
    std::vector<std::pair<uint32_t, uint32_t>> e;
    for (const Simplex& t : o.simplices) {
      for (int k = 0; k < 3; ++k) {
        const uint32_t i = t.v[k], j = t.v[(k + 1) % 3];
        e.emplace_back(std::min(i, j), std::max(i, j));
      }
    }
    std::sort(e.begin(), e.end());
    e.erase(std::unique(e.begin(), e.end()), e.end());
    return e;
  };
  const auto ea = edges(a), eb = edges(b);
  // Whether an edge of `from` crosses or touches a triangle of `to`.
  auto crosses = [](const SceneObject& from, const std::vector<std::pair<uint32_t, uint32_t>>& e,
                    const SceneObject& to) {
    for (const auto& [i, j] : e) {
      for (const Simplex& t : to.simplices) {
        if (segment_hits_triangle(from.vertices[i], from.vertices[j], to.vertices[t.v[0]],
                                  to.vertices[t.v[1]], to.vertices[t.v[2]]))
          return true;
      }
    }
    return false;
  };
  if (crosses(a, ea, b) || crosses(b, eb, a)) return 0;
  double best2 = 1e300;
  for (const auto& [p, q] : {std::pair{&a, &b}, std::pair{&b, &a}}) {
    for (const Vec3& v : p->vertices) {
      for (const Simplex& t : q->simplices) {
        const Vec3 c = closest_point_on_triangle(v, q->vertices[t.v[0]], q->vertices[t.v[1]],
                                                 q->vertices[t.v[2]]);
        best2 = std::min(best2, norm2(v - c));
      }
    }
  }
  for (const auto& [i, j] : ea) {
    for (const auto& [k, l] : eb) {
      best2 = std::min(
          best2, segment_segment_dist2(a.vertices[i], a.vertices[j], b.vertices[k], b.vertices[l]));
    }
  }
  return std::sqrt(best2);
}

NearestAnswer brute_nearest(const Scene& scene, Vec3 p) {
  NearestAnswer a;
  for (ObjectId o = 0; o < scene.objects.size(); ++o) {
    const double d = brute_distance(scene, o, p);
    if (d < a.distance) {
      a.second = a.object;
      a.second_distance = a.distance;
      a.object = o;
      a.distance = d;
    } else if (d < a.second_distance) {
      a.second = o;
      a.second_distance = d;
    }
  }
  return a;
}

namespace {

// Whether p, a point on the plane of triangle (t0, t1, t2) with unit normal n and doubled area
// area2, lies in the triangle, its edges included to `slack` of the area.
bool in_triangle(Vec3 p, Vec3 t0, Vec3 t1, Vec3 t2, Vec3 n, double area2, double slack) {
  const double l0 = dot(cross(t2 - t1, p - t1), n), l1 = dot(cross(t0 - t2, p - t2), n),
               l2 = dot(cross(t1 - t0, p - t0), n);
  const double eps = -slack * area2;
  return l0 >= eps && l1 >= eps && l2 >= eps;
}

}  // namespace

bool segment_hits_triangle(Vec3 a, Vec3 b, Vec3 t0, Vec3 t1, Vec3 t2) {
  const Vec3 e1 = t1 - t0, e2 = t2 - t0;
  const Vec3 m = cross(e1, e2);
  const double area2 = norm(m);
  if (!(area2 > 0)) return false;  // a degenerate triangle
  const Vec3 n = m / area2;
  // What counts as on the plane: the rounding of coordinates computed in double precision
  // (a segment that lies in the triangle's plane has its ends ~1e-16 off it, either side).
  const double size = std::max({norm(e1), norm(e2), norm(t2 - t1), norm(b - a)});
  const double flat = 1e-12 * size;
  const double slack = 1e-12;
  const double da = dot(a - t0, n), db = dot(b - t0, n);
  if ((da > flat && db > flat) || (da < -flat && db < -flat)) return false;
  if (std::fabs(da) <= flat && std::fabs(db) <= flat) {
    // In the plane: a 2D question (an end in the triangle, or the segment across a side).
    // Möller–Trumbore divides by a determinant that is rounding noise here.
    if (in_triangle(a, t0, t1, t2, n, area2, slack) || in_triangle(b, t0, t1, t2, n, area2, slack))
      return true;
    const Vec3 u = e1 / norm(e1), w = cross(n, u);
    auto flat2 = [&](Vec3 p) { return Vec3{dot(p - t0, u), dot(p - t0, w), 0}; };
    const Vec3 pa = flat2(a), pb = flat2(b), q[3] = {flat2(t0), flat2(t1), flat2(t2)};
    for (int k = 0; k < 3; ++k) {
      if (segments_intersect_2d(pa, pb, q[k], q[(k + 1) % 3])) return true;
    }
    return false;
  }
  // Across the plane, or an end on it: the point where the segment meets the plane.
  const double s = std::fabs(da) <= flat ? 0.0 : std::fabs(db) <= flat ? 1.0 : da / (da - db);
  return in_triangle(a + (b - a) * s, t0, t1, t2, n, area2, slack);
}

bool segments_intersect_2d(Vec3 a, Vec3 b, Vec3 c, Vec3 d) {
  auto orient = [](Vec3 p, Vec3 q, Vec3 r) {
    const double v = (q.x - p.x) * (r.y - p.y) - (q.y - p.y) * (r.x - p.x);
    return (v > 0) - (v < 0);
  };
  auto on_segment = [](Vec3 p, Vec3 q, Vec3 r) {
    return std::min(p.x, q.x) <= r.x && r.x <= std::max(p.x, q.x) && std::min(p.y, q.y) <= r.y &&
           r.y <= std::max(p.y, q.y);
  };
  const int o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a), o4 = orient(c, d, b);
  if (o1 != o2 && o3 != o4) return true;
  if (o1 == 0 && on_segment(a, b, c)) return true;
  if (o2 == 0 && on_segment(a, b, d)) return true;
  if (o3 == 0 && on_segment(c, d, a)) return true;
  if (o4 == 0 && on_segment(c, d, b)) return true;
  return false;
}

size_t count_gvd_object_crossings(const Scene& scene, const Gvd& gvd, size_t budget) {
  const int dim = scene.dimension;
  const int arity = dim == 2 ? 2 : 3;
  // Bounding boxes only skip what cannot meet (an object's, a simplex's): every simplex whose
  // box meets the GVD simplex's box is tested.
  struct Bounds {
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
    void add(Vec3 p) {
      for (int i = 0; i < 3; ++i) {
        lo[i] = std::min(lo[i], p[i]);
        hi[i] = std::max(hi[i], p[i]);
      }
    }
    void add(const Bounds& b) {
      add(Vec3{b.lo[0], b.lo[1], b.lo[2]});
      add(Vec3{b.hi[0], b.hi[1], b.hi[2]});
    }
    bool meets(const Bounds& o) const {
      for (int i = 0; i < 3; ++i) {
        if (hi[i] < o.lo[i] || o.hi[i] < lo[i]) return false;
      }
      return true;
    }
  };
  std::vector<Bounds> object_bounds(scene.objects.size());
  std::vector<std::vector<Bounds>> simplex_bounds(scene.objects.size());
  for (size_t o = 0; o < scene.objects.size(); ++o) {
    const SceneObject& obj = scene.objects[o];
    for (const Simplex& t : obj.simplices) {
      Bounds b;
      for (int k = 0; k < arity; ++k) b.add(obj.vertices[t.v[k]]);
      simplex_bounds[o].push_back(b);
      object_bounds[o].add(b);
    }
  }
  size_t crossings = 0;
  for (const GvdCell& cell : gvd.cells) {
    const size_t count = cell.indices.size() / arity;
    const size_t stride = budget == 0 || count <= budget ? 1 : count / budget;
    for (size_t s = 0; s + arity <= cell.indices.size(); s += arity * stride) {
      const Vec3 g0 = cell.positions[cell.indices[s]];
      const Vec3 g1 = cell.positions[cell.indices[s + 1]];
      const Vec3 g2 = arity == 3 ? cell.positions[cell.indices[s + 2]] : g1;
      Bounds gb;
      gb.add(g0);
      gb.add(g1);
      gb.add(g2);
      double scale = 0;  // what a touch within rounding may need: a hair around the box
      for (int i = 0; i < 3; ++i)
        scale = std::max({scale, std::fabs(gb.lo[i]), std::fabs(gb.hi[i])});
      for (int i = 0; i < 3; ++i) {
        gb.lo[i] -= 1e-9 * scale;
        gb.hi[i] += 1e-9 * scale;
      }
      bool hit = false;
      for (size_t o = 0; o < scene.objects.size() && !hit; ++o) {
        if (!object_bounds[o].meets(gb)) continue;
        const SceneObject& obj = scene.objects[o];
        for (size_t i = 0; i < obj.simplices.size() && !hit; ++i) {
          if (!simplex_bounds[o][i].meets(gb)) continue;
          const Simplex& t = obj.simplices[i];
          const Vec3 a = obj.vertices[t.v[0]], b = obj.vertices[t.v[1]];
          if (dim == 2) {
            hit = segments_intersect_2d(g0, g1, a, b);
          } else {
            const Vec3 c = obj.vertices[t.v[2]];
            hit =
                segment_hits_triangle(g0, g1, a, b, c) || segment_hits_triangle(g1, g2, a, b, c) ||
                segment_hits_triangle(g2, g0, a, b, c) || segment_hits_triangle(a, b, g0, g1, g2) ||
                segment_hits_triangle(b, c, g0, g1, g2) || segment_hits_triangle(c, a, g0, g1, g2);
          }
        }
      }
      crossings += hit;
    }
  }
  return crossings;
}

bool inside_cell(const GvdCell& cell, Vec3 p) {
  const Vec3 dirs[3] = {
      {0.5773, 0.5774, 0.5771}, {-0.8121, 0.3147, 0.4913}, {0.1234, -0.9012, 0.4153}};
  int inside_votes = 0;
  for (const Vec3& d : dirs) {
    const Vec3 far = p + d * 1e6;
    int crossings = 0;
    for (size_t s = 0; s + 3 <= cell.indices.size(); s += 3) {
      crossings += segment_hits_triangle(p, far, cell.positions[cell.indices[s]],
                                         cell.positions[cell.indices[s + 1]],
                                         cell.positions[cell.indices[s + 2]]);
    }
    inside_votes += crossings % 2;
  }
  return inside_votes >= 2;
}

size_t count_open_edges(const GvdCell& cell, int dimension) {
  // Vertices are compared by exact position (a vertex may be stored once per neighbour).
  using Key = std::tuple<double, double, double>;
  auto key = [&](uint32_t i) {
    const Vec3 p = cell.positions[i];
    return Key{p.x, p.y, p.z};
  };
  if (dimension == 2) {
    std::vector<std::pair<Key, int>> ends;
    for (size_t s = 0; s + 2 <= cell.indices.size(); s += 2) {
      ends.push_back({key(cell.indices[s]), -1});
      ends.push_back({key(cell.indices[s + 1]), +1});
    }
    std::sort(ends.begin(), ends.end());
    size_t open = 0;
    for (size_t i = 0; i < ends.size();) {
      int balance = 0;
      size_t j = i;
      for (; j < ends.size() && ends[j].first == ends[i].first; ++j) balance += ends[j].second;
      open += balance != 0;
      i = j;
    }
    return open;
  }
  // Directed edges; an edge a->b cancels b->a.
  std::vector<std::pair<std::pair<Key, Key>, int>> edges;
  for (size_t s = 0; s + 3 <= cell.indices.size(); s += 3) {
    for (int e = 0; e < 3; ++e) {
      const Key a = key(cell.indices[s + e]);
      const Key b = key(cell.indices[s + (e + 1) % 3]);
      if (a < b) {
        edges.push_back({{a, b}, +1});
      } else {
        edges.push_back({{b, a}, -1});
      }
    }
  }
  std::sort(edges.begin(), edges.end());
  size_t open = 0;
  for (size_t i = 0; i < edges.size();) {
    int balance = 0;
    size_t j = i;
    for (; j < edges.size() && edges[j].first == edges[i].first; ++j) balance += edges[j].second;
    open += balance != 0;
    i = j;
  }
  return open;
}

Orientation measure_orientation(const Scene& scene, const Gvd& gvd,
                                const std::function<double(Vec3)>& step_at, size_t budget,
                                const std::function<bool(ObjectId, ObjectId)>& counted) {
  const int dim = scene.dimension;
  const int arity = dim == 2 ? 2 : 3;
  Orientation out;
  for (const GvdCell& cell : gvd.cells) {
    const size_t count = cell.indices.size() / arity;
    const size_t stride = count <= budget ? 1 : count / budget;
    for (size_t t = 0; t < count; t += stride) {
      const size_t s = t * arity;
      const ObjectId other = cell.other[cell.indices[s]];
      if (other == kNoObject) continue;
      if (counted && !counted(cell.object, other)) continue;
      const Vec3 a = cell.positions[cell.indices[s]];
      const Vec3 b = cell.positions[cell.indices[s + 1]];
      Vec3 n, c;
      double size;
      if (dim == 2) {
        n = Vec3{-(b - a).y, (b - a).x, 0};
        c = (a + b) * 0.5;
        size = norm(b - a);
      } else {
        const Vec3 d = cell.positions[cell.indices[s + 2]];
        n = cross(b - a, d - a);
        c = (a + b + d) / 3.0;
        size = 0.5 * norm(n);
      }
      if (norm(n) == 0) continue;
      // The probes stay within half the pair's clearance at c: a step across a thin gap would
      // land both in the objects' material, where d_a - d_b is the same constant on both
      // sides and says nothing about the simplex's facing.
      const double clearance =
          std::min(brute_distance(scene, cell.object, c), brute_distance(scene, other, c));
      const double step = std::min(step_at(c), 0.5 * clearance);
      if (!(step > 0)) continue;
      const Vec3 in = c + n / norm(n) * step;
      const Vec3 out_point = c - n / norm(n) * step;
      const double din = brute_distance(scene, cell.object, in) - brute_distance(scene, other, in);
      const double dout =
          brute_distance(scene, cell.object, out_point) - brute_distance(scene, other, out_point);
      out.tested += size;
      if (!(din < dout)) out.flipped += size;
    }
  }
  return out;
}

}  // namespace gvd::test
