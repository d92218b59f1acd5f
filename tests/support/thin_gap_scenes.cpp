#include "support/thin_gap_scenes.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include "gvd/geometry/primitives.h"
#include "support/scenes.h"

namespace gvd::test {

using namespace gvd::scene;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr uint32_t kNone = UINT32_MAX;
/// Default domain side over the scene's largest extent (5 % padding on both sides).
constexpr double kDomainPerExtent = 1.1;
/// Allowed relative deviation of a measured gap from the intended one.
constexpr double kGapTolerance = 1e-9;
/// Polygon pairs: every multiple of kUnit in (-1, 1) is a double, so sums and differences of
/// such coordinates inside the unit square are exact.
constexpr double kUnit = 0x1p-53;
/// Polygon pairs: least edge length, least piece area (of the polygon's), least distance
/// between objects of different pairs.
constexpr double kMinEdge = 1e-3;
constexpr double kMinAreaFraction = 0.05;
constexpr double kPairSeparation = 1e-2;

std::string num(double v) {
  std::ostringstream s;
  s.precision(17);
  s << v;
  return s.str();
}

std::string quoted(const std::string& label) { return "'" + label + "'"; }

[[noreturn]] void fail(const std::string& where, const std::string& what) {
  throw std::runtime_error(where + ": " + what);
}

[[noreturn]] void bad_option(const std::string& where, const std::string& what) {
  throw std::invalid_argument(where + ": " + what);
}

// ---------------------------------------------------------------------------------------------
// Small geometry

double cross2(Vec3 a, Vec3 b) { return a.x * b.y - a.y * b.x; }

/// Rounds to the 2^-53 lattice (exact for |x| < 1: scaling by a power of two is exact).
double snap(double x) { return std::round(x * 0x1p53) * kUnit; }

double largest_extent(const std::vector<SceneObject>& objects) {
  Box b;
  for (const SceneObject& o : objects) b.extend(bounds(o));
  return std::max({b.hi.x - b.lo.x, b.hi.y - b.lo.y, b.hi.z - b.lo.z});
}

double box_gap2(const Box& a, const Box& b) {
  double d2 = 0;
  for (int i = 0; i < 3; ++i) {
    const double d = std::max({a.lo[i] - b.hi[i], b.lo[i] - a.hi[i], 0.0});
    d2 += d * d;
  }
  return d2;
}

uint64_t edge_key(uint32_t a, uint32_t b) { return (static_cast<uint64_t>(a) << 32) | b; }

/// Number of equal parts of at most ~`cell` for a length (the slack keeps 0.6 / 0.05 at 12).
int parts(double length, double cell) {
  return std::max(1, static_cast<int>(std::ceil(length / cell - 1e-9)));
}

/// Coordinates through every key (sorted, deduplicated), each interval split into equal parts
/// of at most ~`cell`: faces meeting along a line then share its subdivision points.
std::vector<double> grid_lines(std::vector<double> keys, double cell) {
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  std::vector<double> out{keys.front()};
  for (size_t i = 1; i < keys.size(); ++i) {
    const double a = keys[i - 1], b = keys[i];
    const int n = parts(b - a, cell);
    for (int k = 1; k <= n; ++k) out.push_back(k == n ? b : a + (b - a) * k / n);
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Meshing: planar caps (z = 0, CCW seen from +z) extruded into closed prisms along z

struct Cap {
  std::vector<Vec3> points;
  std::vector<std::array<uint32_t, 3>> triangles;
};

/// The occupied cells of a rectilinear grid, two triangles each (no T-junctions: one grid).
Cap grid_cap(const std::vector<double>& xs, const std::vector<double>& ys,
             const std::function<bool(size_t, size_t)>& occupied) {
  Cap cap;
  const size_t nx = xs.size() - 1, ny = ys.size() - 1;
  std::vector<uint32_t> index((nx + 1) * (ny + 1), kNone);
  auto vertex = [&](size_t i, size_t j) {
    uint32_t& slot = index[j * (nx + 1) + i];
    if (slot == kNone) {
      slot = static_cast<uint32_t>(cap.points.size());
      cap.points.push_back({xs[i], ys[j], 0});
    }
    return slot;
  };
  for (size_t j = 0; j < ny; ++j) {
    for (size_t i = 0; i < nx; ++i) {
      if (!occupied(i, j)) continue;
      const uint32_t a = vertex(i, j), b = vertex(i + 1, j), c = vertex(i + 1, j + 1),
                     d = vertex(i, j + 1);
      cap.triangles.push_back({a, b, c});
      cap.triangles.push_back({a, c, d});
    }
  }
  return cap;
}

/// The region between two closed loops sampled along matching rays (inner[i] to outer[i], i
/// CCW around the region), split into `layers` rings of quads, two triangles each; ring j is at
/// fraction j / layers of every ray, the loops themselves taken exactly. `disc`: the inner
/// points are all one centre, and the innermost ring is a fan around it.
Cap ray_cap(const std::vector<Vec3>& inner, const std::vector<Vec3>& outer, int layers, bool disc) {
  Cap cap;
  const auto m = static_cast<uint32_t>(outer.size());
  const int first = disc ? 1 : 0;
  if (disc) cap.points.push_back(inner[0]);
  for (int j = first; j <= layers; ++j) {
    const double t = static_cast<double>(j) / layers;
    for (uint32_t i = 0; i < m; ++i) {
      cap.points.push_back(
          j == layers ? outer[i] : (j == 0 ? inner[i] : inner[i] + (outer[i] - inner[i]) * t));
    }
  }
  auto at = [&](int j, uint32_t i) {
    return static_cast<uint32_t>(first + (j - first) * m + i % m);
  };
  if (disc) {
    for (uint32_t i = 0; i < m; ++i) cap.triangles.push_back({0, at(1, i), at(1, i + 1)});
  }
  for (int j = first; j < layers; ++j) {
    for (uint32_t i = 0; i < m; ++i) {
      const uint32_t a = at(j, i), b = at(j + 1, i), c = at(j + 1, i + 1), d = at(j, i + 1);
      cap.triangles.push_back({a, b, c});
      cap.triangles.push_back({a, c, d});
    }
  }
  return cap;
}

/// Every cap triangle must be CCW with positive area: a fold would still give a closed mesh.
void check_cap(const std::string& where, const Cap& cap) {
  for (size_t t = 0; t < cap.triangles.size(); ++t) {
    const auto& tri = cap.triangles[t];
    const Vec3 a = cap.points[tri[0]], b = cap.points[tri[1]], c = cap.points[tri[2]];
    if (!(cross2(b - a, c - a) > 0)) {
      fail(where, "cap triangle " + std::to_string(t) + " is inverted or degenerate");
    }
  }
}

/// A closed prism: the cap at z = zs.front() (facing -z) and at zs.back() (facing +z), joined
/// by walls along every boundary edge of the cap (a directed cap edge without its reverse, so
/// the material is on its left), one quad per edge and z interval. The walls' rows are the
/// cap's own boundary points: caps and walls share every vertex.
SceneObject extrude(const std::string& label, const Cap& cap, const std::vector<double>& zs) {
  const auto n = static_cast<uint32_t>(cap.points.size());
  std::unordered_set<uint64_t> directed;
  for (const auto& t : cap.triangles) {
    for (int k = 0; k < 3; ++k) directed.insert(edge_key(t[k], t[(k + 1) % 3]));
  }
  std::vector<std::pair<uint32_t, uint32_t>> boundary;
  std::vector<uint32_t> column(n, kNone);
  std::vector<uint32_t> column_vertex;
  for (const auto& t : cap.triangles) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = t[k], b = t[(k + 1) % 3];
      if (directed.count(edge_key(b, a))) continue;
      boundary.push_back({a, b});
      if (column[a] == kNone) {
        column[a] = static_cast<uint32_t>(column_vertex.size());
        column_vertex.push_back(a);
      }
    }
  }
  const size_t layers = zs.size() - 1;
  const auto nb = static_cast<uint32_t>(column_vertex.size());
  SceneObject o;
  o.label = label;
  // Bottom cap, top cap, then the boundary columns' intermediate rows.
  for (const Vec3& p : cap.points) o.vertices.push_back({p.x, p.y, zs.front()});
  for (const Vec3& p : cap.points) o.vertices.push_back({p.x, p.y, zs.back()});
  for (size_t l = 1; l < layers; ++l) {
    for (uint32_t v : column_vertex)
      o.vertices.push_back({cap.points[v].x, cap.points[v].y, zs[l]});
  }
  auto vid = [&](uint32_t v, size_t l) {
    if (l == 0) return v;
    if (l == layers) return n + v;
    return static_cast<uint32_t>(2 * n + (l - 1) * nb + column[v]);
  };
  for (const auto& t : cap.triangles) o.simplices.push_back({{t[0], t[2], t[1]}});
  for (const auto& t : cap.triangles) o.simplices.push_back({{n + t[0], n + t[1], n + t[2]}});
  for (const auto& [a, b] : boundary) {
    for (size_t l = 0; l < layers; ++l) {
      const uint32_t p0 = vid(a, l), q0 = vid(b, l), q1 = vid(b, l + 1), p1 = vid(a, l + 1);
      o.simplices.push_back({{p0, q0, q1}});  // outward: the edge's right side
      o.simplices.push_back({{p0, q1, p1}});
    }
  }
  return o;
}

/// Where the ray from the origin along `dir` leaves a convex polygon (CCW, containing the
/// origin); a hit within 1e-12 of a vertex is that vertex exactly, and a hit on an
/// axis-aligned edge keeps the edge's coordinate exactly.
Vec3 ray_exit(const std::vector<Vec3>& polygon, Vec3 dir) {
  const size_t n = polygon.size();
  for (size_t k = 0; k < n; ++k) {
    const Vec3 p = polygon[k], q = polygon[(k + 1) % n];
    const double den = cross2(dir, q - p);
    if (den == 0) continue;
    const double s = cross2(p, dir) / den;
    if (s < -1e-12 || s > 1 + 1e-12) continue;
    const Vec3 hit = s <= 1e-12 ? p : (s >= 1 - 1e-12 ? q : p + (q - p) * s);
    if (dot(hit, dir) > 0) return hit;
  }
  throw std::logic_error("ray_exit: the polygon does not contain the origin");
}

// ---------------------------------------------------------------------------------------------
// Distances: brute force over the simplex pairs whose boxes come within r

int simplex_size(int dim) { return dim == 2 ? 2 : 3; }

std::vector<Box> simplex_boxes(const SceneObject& o, int dim) {
  std::vector<Box> boxes(o.simplices.size());
  for (size_t i = 0; i < o.simplices.size(); ++i) {
    for (int k = 0; k < simplex_size(dim); ++k) boxes[i].extend(o.vertices[o.simplices[i].v[k]]);
  }
  return boxes;
}

/// Calls visit(i, j) once for every box i of `a` and j of `b` that come within r of each other
/// (a little more, for rounding): b's boxes in a hashed uniform grid of cells about as large as
/// they are, so the cost is ~ the number of such pairs.
template <class Visit>
void for_near_pairs(const std::vector<Box>& a, const std::vector<Box>& b, double r, Visit visit) {
  if (a.empty() || b.empty()) return;
  Box all;
  for (const Box& x : a) all.extend(x);
  for (const Box& x : b) all.extend(x);
  double mean = 0, extent = 0;
  for (const Box& x : b) mean += std::max({x.hi.x - x.lo.x, x.hi.y - x.lo.y, x.hi.z - x.lo.z});
  mean /= static_cast<double>(b.size());
  for (int i = 0; i < 3; ++i) extent = std::max(extent, all.hi[i] - all.lo[i]);
  // At least extent / 2^20 so that cell coordinates fit 21 bits of the key.
  const double h = std::max({r, mean, extent * 0x1p-20, 1e-300});
  const int64_t top = static_cast<int64_t>(std::floor(extent / h)) + 1;
  auto cell = [&](double v, int axis) {
    return std::clamp(static_cast<int64_t>(std::floor((v - all.lo[axis]) / h)), int64_t{0}, top);
  };
  auto key = [](int64_t i, int64_t j, int64_t k) {
    return (static_cast<uint64_t>(i) << 42) | (static_cast<uint64_t>(j) << 21) |
           static_cast<uint64_t>(k);
  };
  std::unordered_map<uint64_t, std::vector<uint32_t>> grid;
  for (size_t j = 0; j < b.size(); ++j) {
    for (int64_t x = cell(b[j].lo.x, 0); x <= cell(b[j].hi.x, 0); ++x) {
      for (int64_t y = cell(b[j].lo.y, 1); y <= cell(b[j].hi.y, 1); ++y) {
        for (int64_t z = cell(b[j].lo.z, 2); z <= cell(b[j].hi.z, 2); ++z) {
          grid[key(x, y, z)].push_back(static_cast<uint32_t>(j));
        }
      }
    }
  }
  const double reach = r * (1 + 1e-9);
  const double reach2 = reach * reach;
  std::vector<uint32_t> seen(b.size(), kNone);
  for (size_t i = 0; i < a.size(); ++i) {
    const Vec3 lo = a[i].lo - Vec3{reach, reach, reach}, hi = a[i].hi + Vec3{reach, reach, reach};
    for (int64_t x = cell(lo.x, 0); x <= cell(hi.x, 0); ++x) {
      for (int64_t y = cell(lo.y, 1); y <= cell(hi.y, 1); ++y) {
        for (int64_t z = cell(lo.z, 2); z <= cell(hi.z, 2); ++z) {
          const auto it = grid.find(key(x, y, z));
          if (it == grid.end()) continue;
          for (uint32_t j : it->second) {
            if (seen[j] == i) continue;
            seen[j] = static_cast<uint32_t>(i);
            if (box_gap2(a[i], b[j]) <= reach2) visit(i, j);
          }
        }
      }
    }
  }
}

/// Squared distance of two simplices, in coordinates relative to a vertex of the first: the
/// differences are (nearly) exact, so a gap of 1e-7 between coordinates ~1 keeps ~1e-18.
double simplex_dist2(const SceneObject& a, const Simplex& s, const SceneObject& b, const Simplex& t,
                     int dim) {
  const Vec3 o = a.vertices[s.v[0]];
  if (dim == 2) {
    return segment_segment_dist2_2d(a.vertices[s.v[0]] - o, a.vertices[s.v[1]] - o,
                                    b.vertices[t.v[0]] - o, b.vertices[t.v[1]] - o);
  }
  const Vec3 p[3] = {a.vertices[s.v[0]] - o, a.vertices[s.v[1]] - o, a.vertices[s.v[2]] - o};
  const Vec3 q[3] = {b.vertices[t.v[0]] - o, b.vertices[t.v[1]] - o, b.vertices[t.v[2]] - o};
  return triangle_triangle_dist2(p, q);
}

/// The least distance of a and b when it is at most r, else some value > r (+inf when no boxes
/// come within r).
double bounded_distance(const SceneObject& a, const SceneObject& b, int dim, double r) {
  double best2 = kInf;
  for_near_pairs(simplex_boxes(a, dim), simplex_boxes(b, dim), r, [&](size_t i, size_t j) {
    best2 = std::min(best2, simplex_dist2(a, a.simplices[i], b, b.simplices[j], dim));
  });
  return std::sqrt(best2);
}

double min_distance(const SceneObject& a, const SceneObject& b, int dim) {
  if (a.simplices.empty() || b.simplices.empty()) {
    throw std::invalid_argument("min_distance: object without simplices");
  }
  const Box ba = bounds(a), bb = bounds(b);
  Box all = ba;
  all.extend(bb);
  const double extent = std::max({all.hi.x - all.lo.x, all.hi.y - all.lo.y, all.hi.z - all.lo.z});
  double r = std::max({std::sqrt(box_gap2(ba, bb)), 1e-6 * extent, 1e-300});
  for (;;) {
    const double d = bounded_distance(a, b, dim, r);
    if (d <= r) return d;
    r = std::isfinite(d) ? d : 4 * r;  // a finite d bounds the answer: the next pass is exact
  }
}

/// Least distance from each of `points` to object o when at most r, else > r.
std::vector<double> point_distances(const std::vector<Vec3>& points, const SceneObject& o, int dim,
                                    double r) {
  std::vector<Box> boxes(points.size());
  for (size_t i = 0; i < points.size(); ++i) boxes[i].extend(points[i]);
  std::vector<double> best2(points.size(), kInf);
  for_near_pairs(boxes, simplex_boxes(o, dim), r, [&](size_t i, size_t j) {
    const Simplex& s = o.simplices[j];
    const Vec3 p = points[i];
    const Vec3 a = o.vertices[s.v[0]] - p, b = o.vertices[s.v[1]] - p;
    const Vec3 c = dim == 2 ? Vec3{} : o.vertices[s.v[2]] - p;
    const Vec3 q =
        dim == 2 ? closest_point_on_segment({}, a, b) : closest_point_on_triangle({}, a, b, c);
    best2[i] = std::min(best2[i], norm2(q));
  });
  for (double& d : best2) d = std::sqrt(d);
  return best2;
}

/// Whether p lies inside the closed object (2D: crossing number; 3D: parity of the crossings
/// of a ray in a direction no generator's grid lines up with).
bool contains_point(const SceneObject& o, Vec3 p, int dim) {
  bool inside = false;
  if (dim == 2) {
    for (const Simplex& s : o.simplices) {
      const Vec3 a = o.vertices[s.v[0]], b = o.vertices[s.v[1]];
      if ((a.y > p.y) == (b.y > p.y)) continue;
      const double x = a.x + (p.y - a.y) * (b.x - a.x) / (b.y - a.y);
      if (p.x < x) inside = !inside;
    }
    return inside;
  }
  const Vec3 d{0.2817461, 0.5771129, 0.7665337};
  for (const Simplex& s : o.simplices) {
    const Vec3 a = o.vertices[s.v[0]] - p, e1 = o.vertices[s.v[1]] - p - a,
               e2 = o.vertices[s.v[2]] - p - a;
    const Vec3 h = cross(d, e2);
    const double det = dot(e1, h);
    if (det == 0) continue;
    const Vec3 w = Vec3{} - a;
    const double u = dot(w, h) / det;
    if (u < 0 || u > 1) continue;
    const Vec3 q = cross(w, e1);
    const double v = dot(d, q) / det;
    if (v < 0 || u + v > 1) continue;
    if (dot(e2, q) / det > 0) inside = !inside;
  }
  return inside;
}

void check_not_nested(const std::string& where, const SceneObject& a, const SceneObject& b,
                      int dim) {
  if (contains_point(a, b.vertices[b.simplices[0].v[0]], dim)) {
    fail(where, quoted(b.label) + " lies inside " + quoted(a.label));
  }
  if (contains_point(b, a.vertices[a.simplices[0].v[0]], dim)) {
    fail(where, quoted(a.label) + " lies inside " + quoted(b.label));
  }
}

/// The facing pair a, b must be exactly g apart (to kGapTolerance) and not nested.
void check_gap(const std::string& where, const SceneObject& a, const SceneObject& b, int dim,
               double g) {
  const std::string pair = quoted(a.label) + " and " + quoted(b.label);
  const double d = bounded_distance(a, b, dim, 2 * g);
  if (d == 0) fail(where, pair + " intersect");
  if (!(d <= 2 * g)) {
    fail(where,
         pair + " have no simplices within 2 g = " + num(2 * g) + ", expected gap " + num(g));
  }
  if (std::abs(d - g) > kGapTolerance * g) {
    fail(where, pair + " are " + num(d) + " apart, expected " + num(g) + " (relative error " +
                    num(std::abs(d - g) / g) + ")");
  }
  check_not_nested(where, a, b, dim);
}

/// Objects that do not face each other must be more than r apart (so they cannot intersect).
void check_apart(const std::string& where, const SceneObject& a, const SceneObject& b, int dim,
                 double r) {
  const double d = bounded_distance(a, b, dim, r);
  if (d <= r) {
    fail(where, quoted(a.label) + " and " + quoted(b.label) + " are " + num(d) +
                    " apart, expected more than " + num(r));
  }
  check_not_nested(where, a, b, dim);
}

/// Every vertex of `b` that `facing` selects must be exactly g from `a`: the gap holds over
/// the whole facing area, not just somewhere.
void check_face_gap(const std::string& where, const SceneObject& a, const SceneObject& b, int dim,
                    double g, const std::function<bool(Vec3)>& facing) {
  std::vector<Vec3> points;
  std::vector<size_t> ids;
  for (size_t v = 0; v < b.vertices.size(); ++v) {
    if (!facing(b.vertices[v])) continue;
    points.push_back(b.vertices[v]);
    ids.push_back(v);
  }
  if (points.empty())
    fail(where, quoted(b.label) + " has no vertex on its faces facing " + quoted(a.label));
  const std::vector<double> d = point_distances(points, a, dim, 2 * g);
  for (size_t i = 0; i < d.size(); ++i) {
    if (std::abs(d[i] - g) > kGapTolerance * g) {
      fail(where, "vertex " + std::to_string(ids[i]) + " of " + quoted(b.label) + " is " +
                      num(d[i]) + " from " + quoted(a.label) + ", expected " + num(g));
    }
  }
}

/// Wraps objects into a validated scene and insists on no warnings (validate_scene reports open
/// or non-manifold meshes and degenerate simplices as warnings: a generator bug here).
Scene checked_scene(const std::string& where, int dimension, std::vector<SceneObject> objects) {
  Scene scene = make_scene(dimension, std::move(objects));
  if (!scene.warnings.empty()) {
    const SceneWarning& w = scene.warnings.front();
    fail(where, "scene warning " + std::string(warning_kind_name(w.kind)) + " on " +
                    quoted(w.object) + ": " + w.detail);
  }
  return scene;
}

/// Verifies every object (closed mesh or closed polygon), prefixing failures with `where`.
void verify_objects(const std::string& where, const std::vector<SceneObject>& objects, int dim) {
  for (const SceneObject& o : objects) {
    try {
      dim == 2 ? verify_closed_polygon(o) : verify_closed_mesh(o);
    } catch (const std::runtime_error& e) {
      fail(where, e.what());
    }
  }
}

/// Vertices of a closed polygon in loop order (the object is verified first).
std::vector<Vec3> loop_of(const SceneObject& o) {
  std::vector<uint32_t> next(o.vertices.size(), kNone);
  for (const Simplex& s : o.simplices) next[s.v[0]] = s.v[1];
  std::vector<Vec3> loop;
  uint32_t v = o.simplices[0].v[0];
  do {
    loop.push_back(o.vertices[v]);
    v = next[v];
  } while (v != o.simplices[0].v[0]);
  return loop;
}

double loop_area(const std::vector<Vec3>& loop) {
  double a = 0;
  for (size_t i = 0; i < loop.size(); ++i) {
    a += cross2(loop[i] - loop[0], loop[(i + 1) % loop.size()] - loop[0]);
  }
  return 0.5 * a;
}

bool is_strictly_convex(const std::vector<Vec3>& loop) {
  const size_t n = loop.size();
  for (size_t i = 0; i < n; ++i) {
    const Vec3 p = loop[(i + n - 1) % n], q = loop[i], r = loop[(i + 1) % n];
    if (!(cross2(q - p, r - q) > 0)) return false;
  }
  return true;
}

double min_edge(const std::vector<Vec3>& loop) {
  double m = kInf;
  for (size_t i = 0; i < loop.size(); ++i)
    m = std::min(m, dist(loop[i], loop[(i + 1) % loop.size()]));
  return m;
}

SceneObject polygon_object(const std::string& label, const std::vector<Vec3>& loop) {
  SceneObject o;
  o.label = label;
  o.vertices = loop;
  const auto n = static_cast<uint32_t>(loop.size());
  for (uint32_t i = 0; i < n; ++i) o.simplices.push_back({{i, (i + 1) % n, 0}});
  return o;
}

/// Uniform double in [lo, hi) from a 64-bit engine (portable, unlike the std distributions).
double uniform(std::mt19937_64& rng, double lo, double hi) {
  return lo + (hi - lo) * static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

// ---------------------------------------------------------------------------------------------
// Polygon pairs

/// One pair before the move: the two pieces (CCW, on the 2^-53 lattice) sharing the cut edge
/// a[a_cut] -> a[a_cut + 1], which b runs the other way; `normal` is the unit normal of that
/// edge pointing from a to b.
struct PairPlan {
  std::vector<Vec3> a, b;
  size_t a_cut = 0, b_cut = 0;
  Vec3 normal;
  double gap = 0;  ///< fraction of the domain side
};

/// A lattice vector s (components multiples of 2^-53) with dot(s, n) = g for the unit normal n
/// of a cut edge. The lattice point nearest to g n alone can be 0.7 units off along n, 7e-10 of
/// a gap of 1.1e-7, so this walks along the line dot(s, n) = g, one unit of the component with
/// the smaller |n| per step, to a lattice point much closer to it. The walk also moves s along
/// the edge, which makes one end of the moved edge overhang the other by `along`; that end is
/// then g + along^2 / (2 g) from the other piece. The walk stops at the first point where both
/// excesses together are <= 1e-12 g (~500 steps, along ~1e-13, for g ~ 1e-7), else it returns
/// the best of 2^17 steps.
Vec3 lattice_shift(Vec3 n, double g) {
  const bool x_free = std::abs(n.x) <= std::abs(n.y);
  const double nf = x_free ? n.x : n.y, nd = x_free ? n.y : n.x;
  const double f0 = snap(g * nf);
  Vec3 best;
  double best_cost = kInf;
  for (int step = 0; step <= (1 << 17) && best_cost > 1e-12 * g; ++step) {
    const int k = step % 2 == 0 ? step / 2 : -(step + 1) / 2;
    const double f = f0 + k * kUnit;
    const double d = snap((g - f * nf) / nd);
    const Vec3 s = x_free ? Vec3{f, d, 0} : Vec3{d, f, 0};
    const double along = s.y * n.x - s.x * n.y;
    const double cost = std::abs(f * nf + d * nd - g) + along * along / (2 * g);
    if (cost < best_cost) {
      best_cost = cost;
      best = s;
    }
  }
  return best;
}

/// A random convex polygon inscribed in the circle (c, r), cut by a random line through its
/// interior into two convex pieces; resampled until no edge is < kMinEdge, both pieces have
/// kMinAreaFraction of the area, and the cut is not within ~1 degree of an axis (where
/// lattice_shift's walk would be slow to find a close lattice point).
PairPlan plan_pair(std::mt19937_64& rng, Vec3 c, double r, int min_sides, int max_sides,
                   const std::string& label) {
  for (int attempt = 0; attempt < 10000; ++attempt) {
    const int n =
        min_sides + static_cast<int>(rng() % static_cast<uint64_t>(max_sides - min_sides + 1));
    std::vector<double> angles(n);
    for (double& a : angles) a = uniform(rng, 0, 2 * kPi);
    std::sort(angles.begin(), angles.end());
    std::vector<Vec3> poly(n);
    for (int i = 0; i < n; ++i) {
      poly[i] = {snap(c.x + r * std::cos(angles[i])), snap(c.y + r * std::sin(angles[i])), 0};
    }
    const double psi = uniform(rng, 0, kPi);
    const Vec3 d{std::cos(psi), std::sin(psi), 0};
    Vec3 centre;
    for (const Vec3& p : poly) centre = centre + p / n;
    const Vec3 m = centre + Vec3{-d.y, d.x, 0} * (r * uniform(rng, -0.5, 0.5));
    if (min_edge(poly) < kMinEdge || !is_strictly_convex(poly)) continue;
    if (std::min(std::abs(d.x), std::abs(d.y)) < 0.02) continue;
    // Sutherland-Hodgman against both sides of the line, with one shared (lattice) point per
    // crossed edge.
    std::vector<double> side(n);
    bool near_vertex = false;
    for (int i = 0; i < n; ++i) {
      side[i] = cross2(d, poly[i] - m);
      near_vertex |= std::abs(side[i]) < 1e-6;
    }
    if (near_vertex) continue;
    std::vector<Vec3> left, right;
    Vec3 exit_left, enter_left;  // left piece's cut edge runs exit_left -> enter_left
    int crossings = 0;
    for (int i = 0; i < n; ++i) {
      const int j = (i + 1) % n;
      (side[i] > 0 ? left : right).push_back(poly[i]);
      if ((side[i] > 0) == (side[j] > 0)) continue;
      const Vec3 x = poly[i] + (poly[j] - poly[i]) * (side[i] / (side[i] - side[j]));
      const Vec3 cut{snap(x.x), snap(x.y), 0};
      left.push_back(cut);
      right.push_back(cut);
      (side[i] > 0 ? exit_left : enter_left) = cut;
      ++crossings;
    }
    if (crossings != 2) continue;
    const double area = loop_area(poly);
    bool ok = true;
    for (const auto* piece : {&left, &right}) {
      ok &= min_edge(*piece) >= kMinEdge && is_strictly_convex(*piece) &&
            loop_area(*piece) >= kMinAreaFraction * area;
    }
    if (!ok) continue;
    PairPlan plan;
    plan.a = std::move(left);
    plan.b = std::move(right);
    auto edge_at = [](const std::vector<Vec3>& loop, Vec3 from, Vec3 to) {
      for (size_t i = 0; i < loop.size(); ++i) {
        if (loop[i] == from && loop[(i + 1) % loop.size()] == to) return i;
      }
      throw std::logic_error("plan_pair: cut edge not found");
    };
    plan.a_cut = edge_at(plan.a, exit_left, enter_left);
    plan.b_cut = edge_at(plan.b, enter_left, exit_left);
    const Vec3 e = enter_left - exit_left;
    plan.normal = Vec3{e.y, -e.x, 0} / norm(e);  // right of a's cut edge: towards b
    return plan;
  }
  fail("make_polygon_pairs_2d: " + quoted(label), "no valid polygon cut after 10000 attempts");
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Verification

void verify_closed_mesh(const SceneObject& o) {
  const std::string where = quoted(o.label);
  const size_t nv = o.vertices.size();
  if (o.simplices.empty()) fail(where, "no triangles");
  std::vector<uint8_t> used(nv, 0);
  std::unordered_map<uint64_t, uint32_t> directed;  // directed edge -> triangle
  directed.reserve(3 * o.simplices.size());
  for (size_t t = 0; t < o.simplices.size(); ++t) {
    const uint32_t* v = o.simplices[t].v;
    const std::string tri = "triangle " + std::to_string(t);
    for (int k = 0; k < 3; ++k) {
      if (v[k] >= nv)
        fail(where, tri + " has vertex index " + std::to_string(v[k]) + " out of range");
    }
    if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2]) fail(where, tri + " repeats a vertex");
    const Vec3 a = o.vertices[v[0]];
    if (!(norm2(cross(o.vertices[v[1]] - a, o.vertices[v[2]] - a)) > 0)) {
      fail(where, tri + " has zero area");
    }
    for (int k = 0; k < 3; ++k) {
      used[v[k]] = 1;
      const auto [it, fresh] = directed.emplace(edge_key(v[k], v[(k + 1) % 3]), t);
      if (!fresh) {
        fail(where, "directed edge (" + std::to_string(v[k]) + ", " +
                        std::to_string(v[(k + 1) % 3]) + ") is used by triangles " +
                        std::to_string(it->second) + " and " + std::to_string(t) +
                        " (inconsistent orientation or non-manifold)");
      }
    }
  }
  for (const auto& [key, t] : directed) {
    const auto a = static_cast<uint32_t>(key >> 32), b = static_cast<uint32_t>(key);
    if (!directed.count(edge_key(b, a))) {
      fail(where, "edge (" + std::to_string(a) + ", " + std::to_string(b) + ") of triangle " +
                      std::to_string(t) + " has no opposite edge (open boundary or T-junction)");
    }
  }
  for (size_t v = 0; v < nv; ++v) {
    if (!used[v]) fail(where, "vertex " + std::to_string(v) + " is not used by any triangle");
  }
  std::vector<uint32_t> order(nv);
  for (size_t v = 0; v < nv; ++v) order[v] = static_cast<uint32_t>(v);
  auto less = [&](uint32_t i, uint32_t j) {
    const Vec3 p = o.vertices[i], q = o.vertices[j];
    return p.x != q.x ? p.x < q.x : (p.y != q.y ? p.y < q.y : p.z < q.z);
  };
  std::sort(order.begin(), order.end(), less);
  for (size_t i = 1; i < nv; ++i) {
    if (o.vertices[order[i - 1]] == o.vertices[order[i]]) {
      fail(where, "vertices " + std::to_string(order[i - 1]) + " and " + std::to_string(order[i]) +
                      " are at the same position (not welded)");
    }
  }
  const Vec3 r = o.vertices[0];
  double volume6 = 0;
  for (const Simplex& s : o.simplices) {
    volume6 += dot(o.vertices[s.v[0]] - r, cross(o.vertices[s.v[1]] - r, o.vertices[s.v[2]] - r));
  }
  if (!(volume6 > 0))
    fail(where, "signed volume " + num(volume6 / 6) + " is not positive (inward)");
}

void verify_closed_polygon(const SceneObject& o) {
  const std::string where = quoted(o.label);
  const size_t nv = o.vertices.size(), ns = o.simplices.size();
  if (ns < 3) fail(where, "fewer than 3 segments");
  std::vector<uint32_t> next(nv, kNone), in(nv, 0);
  for (size_t s = 0; s < ns; ++s) {
    const uint32_t a = o.simplices[s].v[0], b = o.simplices[s].v[1];
    const std::string seg = "segment " + std::to_string(s);
    if (a >= nv || b >= nv) fail(where, seg + " has a vertex index out of range");
    if (a == b || o.vertices[a] == o.vertices[b]) fail(where, seg + " has zero length");
    if (next[a] != kNone) fail(where, "vertex " + std::to_string(a) + " starts two segments");
    next[a] = b;
    ++in[b];
  }
  for (size_t v = 0; v < nv; ++v) {
    if (o.vertices[v].z != 0) fail(where, "vertex " + std::to_string(v) + " has z != 0");
    if (next[v] == kNone || in[v] != 1) {
      fail(where, "vertex " + std::to_string(v) +
                      " is not the end of exactly two segments (one in, one out)");
    }
  }
  size_t steps = 0;
  uint32_t v = 0;
  do {
    v = next[v];
    ++steps;
  } while (v != 0 && steps <= nv);
  if (steps != nv) fail(where, "segments form more than one loop");
  std::vector<uint32_t> order(nv);
  for (size_t i = 0; i < nv; ++i) order[i] = static_cast<uint32_t>(i);
  std::sort(order.begin(), order.end(), [&](uint32_t i, uint32_t j) {
    const Vec3 p = o.vertices[i], q = o.vertices[j];
    return p.x != q.x ? p.x < q.x : p.y < q.y;
  });
  for (size_t i = 1; i < nv; ++i) {
    if (o.vertices[order[i - 1]] == o.vertices[order[i]]) {
      fail(where, "vertices " + std::to_string(order[i - 1]) + " and " + std::to_string(order[i]) +
                      " are at the same position (not welded)");
    }
  }
  const std::vector<Vec3> loop = loop_of(o);
  const double area = loop_area(loop);
  if (!(area > 0)) fail(where, "signed area " + num(area) + " is not positive (clockwise)");
  // Simple: non-adjacent segments never touch, adjacent ones never fold back onto each other.
  std::vector<Box> boxes = simplex_boxes(o, 2);
  for (size_t s = 0; s < ns; ++s) {
    const Simplex& p = o.simplices[s];
    for (size_t t = s + 1; t < ns; ++t) {
      const Simplex& q = o.simplices[t];
      const Vec3 p0 = o.vertices[p.v[0]], p1 = o.vertices[p.v[1]];
      const Vec3 q0 = o.vertices[q.v[0]], q1 = o.vertices[q.v[1]];
      if (p.v[1] == q.v[0] || q.v[1] == p.v[0]) {
        const bool forward = p.v[1] == q.v[0];
        const Vec3 e = forward ? p1 - p0 : q1 - q0, f = forward ? q1 - q0 : p1 - p0;
        if (cross2(e, f) == 0 && dot(e, f) < 0) {
          fail(where, "segments " + std::to_string(s) + " and " + std::to_string(t) + " fold back");
        }
        continue;
      }
      if (box_gap2(boxes[s], boxes[t]) > 0) continue;
      if (segment_segment_dist2_2d(p0 - p0, p1 - p0, q0 - p0, q1 - p0) == 0) {
        fail(where,
             "segments " + std::to_string(s) + " and " + std::to_string(t) + " touch (not simple)");
      }
    }
  }
}

double min_distance_3d(const SceneObject& a, const SceneObject& b) { return min_distance(a, b, 3); }

double min_distance_2d(const SceneObject& a, const SceneObject& b) { return min_distance(a, b, 2); }

// ---------------------------------------------------------------------------------------------
// Generators

Scene make_blade_in_slot(const BladeInSlotOptions& options) {
  const std::string where = "make_blade_in_slot";
  constexpr double kBladeTop = 0.8, kBladeZ0 = 0.1, kBladeZ1 = 0.9, kTop = 0.5;
  if (!(options.gap > 0) || !(options.cell > 0) || !(options.width > 0) || !(options.depth > 0)) {
    bad_option(where, "gap, cell, width and depth must be > 0");
  }
  // The block spans [0,1] on x and z, the blade stays inside it on x and z and reaches y = 0.8:
  // the largest extent is 1 whatever the gap.
  const double extent = 1.0;
  const double g = options.gap * kDomainPerExtent * extent;
  const double blade_x0 = 0.5 - 0.5 * options.width, blade_x1 = 0.5 + 0.5 * options.width;
  const double slot_x0 = blade_x0 - g, slot_x1 = blade_x1 + g;
  const double floor_y = kTop - options.depth, blade_y0 = floor_y + g;
  if (!(slot_x0 > 0) || !(slot_x1 < 1))
    bad_option(where, "the slot (width + 2 g) does not fit the block");
  if (!(floor_y > 0) || !(blade_y0 < kTop)) bad_option(where, "depth must be in (g, 0.5)");

  // The block: a U cross-section (the slot's cells left out) extruded along z. One grid for
  // the whole section, so the end caps and the walls share their subdivision points.
  const std::vector<double> xs = grid_lines({0.0, slot_x0, slot_x1, 1.0}, options.cell);
  const std::vector<double> ys = grid_lines({0.0, floor_y, kTop}, options.cell);
  const Cap block_cap = grid_cap(xs, ys, [&](size_t i, size_t j) {
    const double xm = 0.5 * (xs[i] + xs[i + 1]), ym = 0.5 * (ys[j] + ys[j + 1]);
    return !(xm > slot_x0 && xm < slot_x1 && ym > floor_y);
  });
  const Cap blade_cap = grid_cap(grid_lines({blade_x0, blade_x1}, options.cell),
                                 grid_lines({blade_y0, kBladeTop}, options.cell),
                                 [](size_t, size_t) { return true; });
  check_cap(where + ": 'block'", block_cap);
  check_cap(where + ": 'blade'", blade_cap);
  std::vector<SceneObject> objects;
  objects.push_back(extrude("block", block_cap, grid_lines({0.0, 1.0}, options.cell)));
  objects.push_back(extrude("blade", blade_cap, grid_lines({kBladeZ0, kBladeZ1}, options.cell)));

  verify_objects(where, objects, 3);
  const double g_scene = options.gap * kDomainPerExtent * largest_extent(objects);
  check_gap(where, objects[0], objects[1], 3, g_scene);
  check_face_gap(where, objects[0], objects[1], 3, g_scene, [&](Vec3 p) {
    return ((p.x == blade_x0 || p.x == blade_x1) && p.y <= kTop) || p.y == blade_y0;
  });
  return checked_scene(where, 3, std::move(objects));
}

Scene make_stacked_plates(const StackedPlatesOptions& options) {
  const std::string where = "make_stacked_plates";
  const int count = options.count;
  const double t = options.thickness;
  if (count < 2) bad_option(where, "count must be >= 2");
  if (!(options.gap > 0) || !(options.cell > 0) || !(t > 0)) {
    bad_option(where, "gap, cell and thickness must be > 0");
  }
  if (!(options.inset >= 0 && options.inset < 0.5)) bad_option(where, "inset must be in [0, 0.5)");
  // The stack is count t + (count - 1) g high with g = gap 1.1 E; if that exceeds the unit
  // width, E solves E = count t + (count - 1) gap 1.1 E.
  const double shrink = 1 - (count - 1) * kDomainPerExtent * options.gap;
  if (!(shrink > 0)) bad_option(where, "gap too large for the stack");
  const double extent = std::max(1.0, count * t / shrink);
  const double g = options.gap * kDomainPerExtent * extent;
  const std::vector<double> wide = grid_lines({0.0, 1.0}, options.cell);
  const std::vector<double> inset = grid_lines({options.inset, 1.0 - options.inset}, options.cell);
  auto is_inset = [&](int i) { return options.inset > 0 && i % 2 == 1; };
  std::vector<SceneObject> objects;
  std::vector<double> y0(count), y1(count);
  for (int i = 0; i < count; ++i) {
    y0[i] = i * (t + g);
    y1[i] = y0[i] + t;
    const std::vector<double>& xs = is_inset(i) ? inset : wide;
    const Cap cap =
        grid_cap(xs, grid_lines({y0[i], y1[i]}, options.cell), [](size_t, size_t) { return true; });
    const std::string label = "plate_" + std::to_string(i);
    check_cap(where + ": " + quoted(label), cap);
    objects.push_back(extrude(label, cap, xs));  // z split as x
  }

  verify_objects(where, objects, 3);
  const double g_scene = options.gap * kDomainPerExtent * largest_extent(objects);
  for (int i = 0; i < count; ++i) {
    for (int j = i + 1; j < count; ++j) {
      if (j == i + 1) {
        check_gap(where, objects[i], objects[j], 3, g_scene);
        // The facing face of the narrower plate lies at g from the other one everywhere.
        if (!is_inset(i)) {
          check_face_gap(where, objects[i], objects[j], 3, g_scene,
                         [&](Vec3 p) { return p.y == y0[j]; });
        }
        if (!is_inset(j)) {
          check_face_gap(where, objects[j], objects[i], 3, g_scene,
                         [&](Vec3 p) { return p.y == y1[i]; });
        }
      } else {
        check_apart(where, objects[i], objects[j], 3, 2 * g_scene);
      }
    }
  }
  return checked_scene(where, 3, std::move(objects));
}

Scene make_ball_in_socket(const BallInSocketOptions& options) {
  const std::string where = "make_ball_in_socket";
  if (options.rings < 3 || options.segments < 3)
    bad_option(where, "rings and segments must be >= 3");
  if (!(options.gap > 0)) bad_option(where, "gap must be > 0");
  if (!(options.radius > 0) || !(options.radius < 0.5))
    bad_option(where, "radius must be in (0, 0.5)");
  const double g = options.gap * kDomainPerExtent;  // the box spans 1: E = 1
  SceneObject ball = make_sphere("ball", Vec3{}, options.radius, options.rings, options.segments);
  // The ball is convex and inside the cavity, a convex polyhedron with the same face normals:
  // its least distance to the cavity is the least over faces of (s - 1) times the face's
  // plane distance d_f (the ball's support in direction n_f is its own face f).
  double least_plane = kInf;
  for (const Simplex& t : ball.simplices) {
    const Vec3 a = ball.vertices[t.v[0]], b = ball.vertices[t.v[1]], c = ball.vertices[t.v[2]];
    const Vec3 n = cross(b - a, c - a);
    least_plane = std::min(least_plane, dot(n, a) / norm(n));
  }
  const double scale = 1 + g / least_plane;
  if (!(options.radius * scale < 0.5)) bad_option(where, "the cavity does not fit in the box");
  SceneObject socket = make_box("socket", Vec3{-0.5, -0.5, -0.5}, Vec3{0.5, 0.5, 0.5});
  const uint32_t base = static_cast<uint32_t>(socket.vertices.size());
  for (const Vec3& v : ball.vertices) socket.vertices.push_back(v * scale);
  for (const Simplex& t : ball.simplices)  // turned inside out: the cavity's faces face the ball
    socket.simplices.push_back({{base + t.v[0], base + t.v[2], base + t.v[1]}});
  std::vector<SceneObject> objects;
  objects.push_back(std::move(socket));
  objects.push_back(std::move(ball));
  verify_objects(where, objects, 3);
  check_gap(where, objects[0], objects[1], 3, g);
  Scene scene = make_scene(3, std::move(objects));
  for (const SceneWarning& w : scene.warnings) {
    if (w.kind != WarningKind::kMultipleComponents || w.object != "socket") {
      fail(where, "scene warning " + std::string(warning_kind_name(w.kind)) + " on " +
                      quoted(w.object) + ": " + w.detail);
    }
  }
  return scene;
}

Scene make_cube_in_cavity(const CubeInCavityOptions& options) {
  const std::string where = "make_cube_in_cavity";
  if (!(options.gap > 0) || !(options.gap < 0.1)) bad_option(where, "gap must be in (0, 0.1)");
  const double g = options.gap * kDomainPerExtent;  // the block spans 1: E = 1
  SceneObject block = make_box("block", Vec3{0, 0, 0}, Vec3{1, 1, 1});
  const SceneObject cavity =
      make_box("cavity", Vec3{0.3 - g, 0.3 - g, 0.3 - g}, Vec3{0.7 + g, 0.7 + g, 0.7 + g});
  const auto base = static_cast<uint32_t>(block.vertices.size());
  block.vertices.insert(block.vertices.end(), cavity.vertices.begin(), cavity.vertices.end());
  const size_t first_cavity = block.simplices.size();
  for (const Simplex& t : cavity.simplices)  // turned inside out: the cavity's faces face the cube
    block.simplices.push_back({{base + t.v[0], base + t.v[2], base + t.v[1]}});
  std::vector<SceneObject> objects;
  objects.push_back(std::move(block));
  objects.push_back(make_box("cube", Vec3{0.3, 0.3, 0.3}, Vec3{0.7, 0.7, 0.7}));
  verify_objects(where, objects, 3);
  check_gap(where, objects[0], objects[1], 3, g);
  if (options.cavity_inside_out) {
    for (size_t t = first_cavity; t < objects[0].simplices.size(); ++t)
      std::swap(objects[0].simplices[t].v[1], objects[0].simplices[t].v[2]);
  }
  return make_scene(3, std::move(objects));
}

Scene make_shaft_in_bore(const ShaftInBoreOptions& options) {
  const std::string where = "make_shaft_in_bore";
  constexpr double kHalf = 0.5, kHousingZ0 = 0.0, kHousingZ1 = 0.6, kShaftZ0 = -0.2, kShaftZ1 = 0.8;
  const int n = options.sides;
  const double radius = options.radius;
  if (n < 3) bad_option(where, "sides must be >= 3");
  if (!(options.gap > 0) || !(options.cell > 0)) bad_option(where, "gap and cell must be > 0");
  if (!(radius > 0) || !(radius < kHalf)) bad_option(where, "radius must be in (0, 0.5)");
  // The housing spans 1 on x and y, the shaft z in [-0.2, 0.8]: the largest extent is 1.
  const double extent = 1.0;
  const double g = options.gap * kDomainPerExtent * extent;
  const double apothem = radius * std::cos(kPi / n);
  if (!(g < apothem)) bad_option(where, "the gap is larger than the bore's apothem");
  // Same angles, apothem smaller by g: each shaft face is parallel to its bore face, g inside.
  const double shaft_radius = (apothem - g) / std::cos(kPi / n);
  std::vector<Vec3> bore(n), shaft(n);
  for (int k = 0; k < n; ++k) {
    const double a = 2 * kPi * k / n;
    bore[k] = {radius * std::cos(a), radius * std::sin(a), 0};
    shaft[k] = {shaft_radius * std::cos(a), shaft_radius * std::sin(a), 0};
  }
  const std::vector<Vec3> square = {
      {-kHalf, -kHalf, 0}, {kHalf, -kHalf, 0}, {kHalf, kHalf, 0}, {-kHalf, kHalf, 0}};

  // Housing cap: rays from the axis at the bore's vertices and the square's corners (so every
  // ray interval has one straight piece of each loop), more rays between them spaced ~cell
  // along the square; each ray from its bore point to its square point.
  std::vector<double> keys;
  for (int k = 0; k < n; ++k) keys.push_back(2 * kPi * k / n);
  for (int k = 0; k < 4; ++k) keys.push_back(kPi / 4 + k * kPi / 2);
  std::sort(keys.begin(), keys.end());
  std::vector<double> unique_keys;
  for (double a : keys) {
    if (unique_keys.empty() || a - unique_keys.back() > 1e-9) unique_keys.push_back(a);
  }
  std::vector<Vec3> inner, outer;
  for (size_t k = 0; k < unique_keys.size(); ++k) {
    const double a0 = unique_keys[k], a1 = unique_keys[(k + 1) % unique_keys.size()];
    const Vec3 d0{std::cos(a0), std::sin(a0), 0}, d1{std::cos(a1), std::sin(a1), 0};
    const Vec3 o0 = ray_exit(square, d0), o1 = ray_exit(square, d1);
    const Vec3 i0 = ray_exit(bore, d0), i1 = ray_exit(bore, d1);
    const int m = parts(dist(o0, o1), options.cell);
    for (int i = 0; i < m; ++i) {
      // On the square side exactly (its constant coordinate is kept), projected centrally onto
      // the bore edge.
      const Vec3 o = i == 0 ? o0 : o0 + (o1 - o0) * (static_cast<double>(i) / m);
      const double s = cross2(i0, o) / cross2(o, i1 - i0);
      outer.push_back(o);
      inner.push_back(i == 0 ? i0 : i0 + (i1 - i0) * s);
    }
  }
  double longest_ray = 0;
  for (size_t i = 0; i < inner.size(); ++i)
    longest_ray = std::max(longest_ray, dist(inner[i], outer[i]));
  const Cap housing_cap = ray_cap(inner, outer, parts(longest_ray, options.cell), false);

  // Shaft cap: rays from the axis through its edges' subdivision points.
  std::vector<Vec3> rim;
  for (int k = 0; k < n; ++k) {
    const Vec3 p = shaft[k], q = shaft[(k + 1) % n];
    const int m = parts(dist(p, q), options.cell);
    for (int i = 0; i < m; ++i)
      rim.push_back(i == 0 ? p : p + (q - p) * (static_cast<double>(i) / m));
  }
  const Cap shaft_cap =
      ray_cap(std::vector<Vec3>(rim.size(), Vec3{}), rim, parts(shaft_radius, options.cell), true);
  check_cap(where + ": 'housing'", housing_cap);
  check_cap(where + ": 'shaft'", shaft_cap);
  std::vector<SceneObject> objects;
  objects.push_back(
      extrude("housing", housing_cap, grid_lines({kHousingZ0, kHousingZ1}, options.cell)));
  objects.push_back(extrude("shaft", shaft_cap, grid_lines({kShaftZ0, kShaftZ1}, options.cell)));

  verify_objects(where, objects, 3);
  const double g_scene = options.gap * kDomainPerExtent * largest_extent(objects);
  check_gap(where, objects[0], objects[1], 3, g_scene);
  check_face_gap(where, objects[0], objects[1], 3, g_scene,
                 [&](Vec3 p) { return p.z >= kHousingZ0 && p.z <= kHousingZ1; });
  return checked_scene(where, 3, std::move(objects));
}

Scene make_parallel_bars_2d(const ParallelBarsOptions& options) {
  const std::string where = "make_parallel_bars_2d";
  constexpr double kLength = 1.0, kThickness = 0.1;
  const int n = options.segments;
  if (!(options.gap > 0)) bad_option(where, "gap must be > 0");
  if (n < 1) bad_option(where, "segments must be >= 1");
  // Height 2 t + g with g = gap 1.1 E: the length 1 unless that exceeds it.
  const double shrink = 1 - kDomainPerExtent * options.gap;
  if (!(shrink > 0)) bad_option(where, "gap too large");
  const double extent = std::max(kLength, 2 * kThickness / shrink);
  const double g = options.gap * kDomainPerExtent * extent;
  std::vector<double> xs(n + 1);
  for (int i = 0; i <= n; ++i) xs[i] = i == n ? kLength : kLength * i / n;
  // CCW: the bottom edge left to right, the top edge right to left, the same x on both.
  auto bar = [&](const std::string& label, double y0, double y1) {
    std::vector<Vec3> loop;
    for (int i = 0; i <= n; ++i) loop.push_back({xs[i], y0, 0});
    for (int i = n; i >= 0; --i) loop.push_back({xs[i], y1, 0});
    return polygon_object(label, loop);
  };
  std::vector<SceneObject> objects;
  objects.push_back(bar("bar_a", -kThickness, 0.0));
  objects.push_back(bar("bar_b", g, g + kThickness));

  verify_objects(where, objects, 2);
  const double g_scene = options.gap * kDomainPerExtent * largest_extent(objects);
  check_gap(where, objects[0], objects[1], 2, g_scene);
  check_face_gap(where, objects[0], objects[1], 2, g_scene, [&](Vec3 p) { return p.y == g; });
  check_face_gap(where, objects[1], objects[0], 2, g_scene, [&](Vec3 p) { return p.y == 0; });
  return checked_scene(where, 2, std::move(objects));
}

Scene make_polygon_pairs_2d(const PolygonPairsOptions& options) {
  const std::string where = "make_polygon_pairs_2d";
  const int gx = options.grid_x, gy = options.grid_y, pairs = options.pairs;
  if (gx < 1 || gy < 1 || pairs < 1 || pairs > gx * gy) {
    bad_option(where, "need 1 <= pairs <= grid_x * grid_y");
  }
  if (options.min_sides < 3 || options.max_sides < options.min_sides) {
    bad_option(where, "need 3 <= min_sides <= max_sides");
  }
  if (!(options.min_gap > 0) || !(options.max_gap >= options.min_gap)) {
    bad_option(where, "need 0 < min_gap <= max_gap");
  }
  std::mt19937_64 rng(options.seed);
  const double w = 1.0 / gx, h = 1.0 / gy, cell = std::min(w, h);
  // Every object stays this far inside its cell, moves included (E < 1, so g <= 1.1 max_gap).
  const double margin = 0.5 * kPairSeparation + 0.5 * kDomainPerExtent * options.max_gap + 1e-4;

  std::vector<int> cells(static_cast<size_t>(gx) * gy);
  for (size_t i = 0; i < cells.size(); ++i) cells[i] = static_cast<int>(i);
  std::shuffle(cells.begin(), cells.end(), rng);
  cells.resize(pairs);
  std::sort(cells.begin(), cells.end());
  std::vector<double> gaps(pairs);
  for (int i = 0; i < pairs; ++i) {
    const double f = pairs > 1 ? static_cast<double>(i) / (pairs - 1) : 0;
    gaps[i] = options.max_gap * std::pow(options.min_gap / options.max_gap, f);
  }
  std::shuffle(gaps.begin(), gaps.end(), rng);

  // Stage 1, independent of the gaps' scale: polygons and cuts.
  std::vector<PairPlan> plans;
  for (int p = 0; p < pairs; ++p) {
    const Vec3 lo{(cells[p] % gx) * w, (cells[p] / gx) * h, 0};
    const double r = 0.3 * cell * uniform(rng, 0.9, 1.0);
    const double jx = 0.5 * w - r - margin, jy = 0.5 * h - r - margin;
    if (!(jx >= 0) || !(jy >= 0)) bad_option(where, "cells too small for the pair separation");
    const Vec3 c = lo + Vec3{0.5 * w + uniform(rng, -jx, jx), 0.5 * h + uniform(rng, -jy, jy), 0};
    plans.push_back(
        plan_pair(rng, c, r, options.min_sides, options.max_sides, "p" + std::to_string(p)));
    plans.back().gap = gaps[p];
  }

  // Stage 2: the moves depend on g = gap 1.1 E and E on the moves: iterate to a fixed point
  // (a contraction by ~g, so a few rounds).
  auto build = [&](double extent) {
    std::vector<SceneObject> objects;
    for (int p = 0; p < pairs; ++p) {
      const PairPlan& plan = plans[p];
      const Vec3 s = lattice_shift(plan.normal, plan.gap * kDomainPerExtent * extent);
      const Vec3 sb{snap(0.5 * s.x), snap(0.5 * s.y), 0};
      const Vec3 sa = s - sb;  // exact: lattice values
      std::vector<Vec3> a = plan.a, b = plan.b;
      for (Vec3& v : a) v = v - sa;
      for (Vec3& v : b) v = v + sb;
      objects.push_back(polygon_object("p" + std::to_string(p) + "_a", a));
      objects.push_back(polygon_object("p" + std::to_string(p) + "_b", b));
    }
    return objects;
  };
  std::vector<SceneObject> unmoved;
  for (const PairPlan& plan : plans) {
    unmoved.push_back(polygon_object("a", plan.a));
    unmoved.push_back(polygon_object("b", plan.b));
  }
  double extent = largest_extent(unmoved);
  std::vector<SceneObject> objects;
  for (int round = 0;; ++round) {
    objects = build(extent);
    const double moved = largest_extent(objects);
    if (std::abs(moved - extent) <= 1e-13 * extent) break;
    if (round == 100) fail(where, "the scene extent does not settle");
    extent = moved;
  }

  verify_objects(where, objects, 2);
  for (const SceneObject& o : objects) {
    if (!is_strictly_convex(loop_of(o))) fail(where, quoted(o.label) + " is not strictly convex");
  }
  const double e_scene = kDomainPerExtent * largest_extent(objects);
  for (int p = 0; p < pairs; ++p) {
    const SceneObject& a = objects[2 * p];
    const SceneObject& b = objects[2 * p + 1];
    const double g = plans[p].gap * e_scene;
    check_gap(where, a, b, 2, g);
    // The cut edges: b's runs the other way, and each of its ends is the same translate of a's.
    const size_t na = a.vertices.size(), nb = b.vertices.size();
    const Vec3 a0 = a.vertices[plans[p].a_cut], a1 = a.vertices[(plans[p].a_cut + 1) % na];
    const Vec3 b0 = b.vertices[plans[p].b_cut], b1 = b.vertices[(plans[p].b_cut + 1) % nb];
    const Vec3 t = (a1 - a0) / dist(a0, a1);
    if (b0 - a1 != b1 - a0 || std::abs(dot(b0 - a1, t)) > 1e-9 * dist(a0, a1)) {
      fail(where, "the cut edges of " + quoted(a.label) + " and " + quoted(b.label) +
                      " do not face each other fully");
    }
    check_face_gap(where, a, b, 2, g, [&](Vec3 v) { return v == b0 || v == b1; });
  }
  std::vector<Box> boxes;
  for (const SceneObject& o : objects) boxes.push_back(bounds(o));
  for (size_t i = 0; i < objects.size(); ++i) {
    for (size_t j = i + 1; j < objects.size(); ++j) {
      if (i / 2 == j / 2 || box_gap2(boxes[i], boxes[j]) > kPairSeparation * kPairSeparation) {
        continue;
      }
      check_apart(where, objects[i], objects[j], 2, kPairSeparation);
    }
  }
  return checked_scene(where, 2, std::move(objects));
}

}  // namespace gvd::test
