#include "bench/table1_scenes.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

#include "support/scenes.h"

namespace gvd::bench {

using namespace gvd::scene;

namespace {

constexpr double kPi = std::numbers::pi;

/// Uniform double in [lo, hi) from a 64-bit engine (portable, unlike the std distributions).
double uniform(std::mt19937_64& rng, double lo, double hi) {
  return lo + (hi - lo) * static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

// ---------------------------------------------------------------------------------------------
// 2D primitives

double cross2(Vec3 a, Vec3 b) { return a.x * b.y - a.y * b.x; }

double point_segment_distance(Vec3 p, Vec3 a, Vec3 b) {
  const Vec3 ab = b - a;
  const double len2 = norm2(ab);
  double t = len2 > 0 ? dot(p - a, ab) / len2 : 0;
  t = std::clamp(t, 0.0, 1.0);
  return dist(p, a + ab * t);
}

/// True when closed segments ab and cd share a point (collinear overlaps included).
bool segments_intersect(Vec3 a, Vec3 b, Vec3 c, Vec3 d) {
  auto orient = [](Vec3 p, Vec3 q, Vec3 r) {
    const double v = cross2(q - p, r - p);
    return v > 0 ? 1 : (v < 0 ? -1 : 0);
  };
  auto on_segment = [](Vec3 p, Vec3 q, Vec3 r) {  // r on pq, given collinear
    return std::min(p.x, q.x) <= r.x && r.x <= std::max(p.x, q.x) && std::min(p.y, q.y) <= r.y &&
           r.y <= std::max(p.y, q.y);
  };
  const int o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a), o4 = orient(c, d, b);
  if (o1 != o2 && o3 != o4) return true;
  return (o1 == 0 && on_segment(a, b, c)) || (o2 == 0 && on_segment(a, b, d)) ||
         (o3 == 0 && on_segment(c, d, a)) || (o4 == 0 && on_segment(c, d, b));
}

double segment_distance(Vec3 a, Vec3 b, Vec3 c, Vec3 d) {
  if (segments_intersect(a, b, c, d)) return 0;
  return std::min({point_segment_distance(a, c, d), point_segment_distance(b, c, d),
                   point_segment_distance(c, a, b), point_segment_distance(d, a, b)});
}

/// A closed polygon object from a CCW vertex loop.
SceneObject polygon_object(const std::string& label, std::vector<Vec3> loop) {
  SceneObject o;
  o.label = label;
  const auto n = static_cast<uint32_t>(loop.size());
  o.vertices = std::move(loop);
  for (uint32_t i = 0; i < n; ++i) o.simplices.push_back({{i, (i + 1) % n, 0}});
  return o;
}

Box bounds(const SceneObject& o) {
  Box b;
  for (const Vec3& v : o.vertices) b.extend(v);
  return b;
}

void translate(SceneObject& o, Vec3 d) {
  for (Vec3& v : o.vertices) v = v + d;
}

// ---------------------------------------------------------------------------------------------
// 3D meshing helpers

/// A prism over a loop that is star-shaped around `centre` (CCW seen from +z), z in [z0, z1];
/// caps are fans around the centre. 4n outward triangles.
SceneObject extrude_star(const std::string& label, const std::vector<Vec3>& loop, Vec3 centre,
                         double z0, double z1) {
  SceneObject o;
  o.label = label;
  const auto n = static_cast<uint32_t>(loop.size());
  for (const Vec3& p : loop) o.vertices.push_back({p.x, p.y, z0});
  for (const Vec3& p : loop) o.vertices.push_back({p.x, p.y, z1});
  const uint32_t cb = 2 * n, ct = 2 * n + 1;
  o.vertices.push_back({centre.x, centre.y, z0});
  o.vertices.push_back({centre.x, centre.y, z1});
  for (uint32_t i = 0; i < n; ++i) {
    const uint32_t j = (i + 1) % n;
    o.simplices.push_back({{i, j, n + j}});
    o.simplices.push_back({{i, n + j, n + i}});
    o.simplices.push_back({{cb, j, i}});
    o.simplices.push_back({{ct, n + i, n + j}});
  }
  return o;
}

/// A prism over the ring between an outer loop and an inner loop of the same vertex count
/// (both CCW, vertex i of each at the same angle), z in [z0, z1]. 8n outward triangles.
SceneObject extrude_ring(const std::string& label, const std::vector<Vec3>& outer,
                         const std::vector<Vec3>& inner, double z0, double z1) {
  SceneObject o;
  o.label = label;
  const auto n = static_cast<uint32_t>(outer.size());
  // Vertex blocks: outer bottom, outer top, inner bottom, inner top.
  for (const Vec3& p : outer) o.vertices.push_back({p.x, p.y, z0});
  for (const Vec3& p : outer) o.vertices.push_back({p.x, p.y, z1});
  for (const Vec3& p : inner) o.vertices.push_back({p.x, p.y, z0});
  for (const Vec3& p : inner) o.vertices.push_back({p.x, p.y, z1});
  const uint32_t ob = 0, ot = n, ib = 2 * n, it = 3 * n;
  for (uint32_t i = 0; i < n; ++i) {
    const uint32_t j = (i + 1) % n;
    o.simplices.push_back({{ob + i, ob + j, ot + j}});  // outer wall, facing out
    o.simplices.push_back({{ob + i, ot + j, ot + i}});
    o.simplices.push_back({{ib + i, it + j, ib + j}});  // bore wall, facing the axis
    o.simplices.push_back({{ib + i, it + i, it + j}});
    o.simplices.push_back({{ot + i, ot + j, it + j}});  // top cap (+z)
    o.simplices.push_back({{ot + i, it + j, it + i}});
    o.simplices.push_back({{ob + i, ib + j, ob + j}});  // bottom cap (-z)
    o.simplices.push_back({{ob + i, ib + i, ib + j}});
  }
  return o;
}

/// Grid lines through every `key` coordinate (sorted), intervals split to at most `cell`.
std::vector<double> grid_lines(std::vector<double> keys, double cell) {
  std::sort(keys.begin(), keys.end());
  std::vector<double> out{keys.front()};
  for (size_t i = 1; i < keys.size(); ++i) {
    const double a = keys[i - 1], b = keys[i];
    const int n = std::max(1, static_cast<int>(std::ceil((b - a) / cell)));
    for (int k = 1; k <= n; ++k) out.push_back(k == n ? b : a + (b - a) * k / n);
  }
  return out;
}

/// A closed rectilinear solid: the union of the occupied cells of a rectilinear grid, its
/// boundary faces split into two outward triangles each (no T-junctions: one shared grid).
SceneObject rectilinear_solid(const std::string& label, const std::vector<double>& xs,
                              const std::vector<double>& ys, const std::vector<double>& zs,
                              const std::function<bool(int, int, int)>& occupied) {
  const int nx = static_cast<int>(xs.size()) - 1, ny = static_cast<int>(ys.size()) - 1,
            nz = static_cast<int>(zs.size()) - 1;
  SceneObject o;
  o.label = label;
  std::vector<uint32_t> index(static_cast<size_t>(nx + 1) * (ny + 1) * (nz + 1), UINT32_MAX);
  auto vertex = [&](int i, int j, int k) {
    uint32_t& slot = index[(static_cast<size_t>(k) * (ny + 1) + j) * (nx + 1) + i];
    if (slot == UINT32_MAX) {
      slot = static_cast<uint32_t>(o.vertices.size());
      o.vertices.push_back({xs[i], ys[j], zs[k]});
    }
    return slot;
  };
  auto full = [&](int i, int j, int k) {
    return i >= 0 && j >= 0 && k >= 0 && i < nx && j < ny && k < nz && occupied(i, j, k);
  };
  // A face quad given as 4 corners in CCW order seen from outside.
  auto quad = [&](std::array<int, 3> a, std::array<int, 3> b, std::array<int, 3> c,
                  std::array<int, 3> d) {
    const uint32_t va = vertex(a[0], a[1], a[2]), vb = vertex(b[0], b[1], b[2]),
                   vc = vertex(c[0], c[1], c[2]), vd = vertex(d[0], d[1], d[2]);
    o.simplices.push_back({{va, vb, vc}});
    o.simplices.push_back({{va, vc, vd}});
  };
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        if (!occupied(i, j, k)) continue;
        if (!full(i - 1, j, k)) quad({i, j, k}, {i, j, k + 1}, {i, j + 1, k + 1}, {i, j + 1, k});
        if (!full(i + 1, j, k))
          quad({i + 1, j, k}, {i + 1, j + 1, k}, {i + 1, j + 1, k + 1}, {i + 1, j, k + 1});
        if (!full(i, j - 1, k)) quad({i, j, k}, {i + 1, j, k}, {i + 1, j, k + 1}, {i, j, k + 1});
        if (!full(i, j + 1, k))
          quad({i, j + 1, k}, {i, j + 1, k + 1}, {i + 1, j + 1, k + 1}, {i + 1, j + 1, k});
        if (!full(i, j, k - 1)) quad({i, j, k}, {i, j + 1, k}, {i + 1, j + 1, k}, {i + 1, j, k});
        if (!full(i, j, k + 1))
          quad({i, j, k + 1}, {i + 1, j, k + 1}, {i + 1, j + 1, k + 1}, {i, j + 1, k + 1});
      }
    }
  }
  return o;
}

/// Wraps objects into a validated scene and insists that every mesh came out closed and
/// manifold (validate_scene reports those as warnings, a generator bug here).
Scene checked_scene(int dimension, std::vector<SceneObject> objects) {
  Scene scene = gvd::test::make_scene(dimension, std::move(objects));
  if (!scene.warnings.empty()) {
    const SceneWarning& w = scene.warnings.front();
    throw std::runtime_error("generated scene has warning " +
                             std::string(gvd::scene::warning_kind_name(w.kind)) + " on '" +
                             w.object + "': " + w.detail);
  }
  return scene;
}

// ---------------------------------------------------------------------------------------------
// Gears

/// Radius of a trapezoidal tooth profile at tooth fraction t in [0, 1): root, flank up, tip,
/// flank down, root; the tooth is centred at t = 0.5.
double tooth_radius(double t, double r_root, double r_tip) {
  const double rise = 0.15;
  if (t < 0.2 || t >= 0.8) return r_root;
  if (t < 0.2 + rise) return r_root + (r_tip - r_root) * (t - 0.2) / rise;
  if (t < 0.8 - rise) return r_tip;
  return r_tip - (r_tip - r_root) * (t - (0.8 - rise)) / rise;
}

std::vector<Vec3> gear_loop(Vec3 centre, double r_root, double r_tip, int teeth, int samples,
                            double phase) {
  std::vector<Vec3> loop;
  const int n = teeth * samples;
  for (int i = 0; i < n; ++i) {
    const double t = static_cast<double>(i % samples) / samples;
    const double a = phase + 2 * kPi * i / n;
    const double r = tooth_radius(t, r_root, r_tip);
    loop.push_back(centre + Vec3{r * std::cos(a), r * std::sin(a), 0});
  }
  return loop;
}

std::vector<Vec3> circle_loop(Vec3 centre, double r, int n, double phase) {
  std::vector<Vec3> loop;
  for (int i = 0; i < n; ++i) {
    const double a = phase + 2 * kPi * i / n;
    loop.push_back(centre + Vec3{r * std::cos(a), r * std::sin(a), 0});
  }
  return loop;
}

double loop_distance(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  double best = 1e300;
  for (size_t i = 0; i < a.size(); ++i) {
    const Vec3 p = a[i], q = a[(i + 1) % a.size()];
    for (size_t j = 0; j < b.size(); ++j) {
      best = std::min(best, segment_distance(p, q, b[j], b[(j + 1) % b.size()]));
    }
  }
  return best;
}

}  // namespace

double polyline_distance_2d(const SceneObject& a, const SceneObject& b) {
  double best = 1e300;
  for (const Simplex& s : a.simplices) {
    for (const Simplex& t : b.simplices) {
      best = std::min(best, segment_distance(a.vertices[s.v[0]], a.vertices[s.v[1]],
                                             b.vertices[t.v[0]], b.vertices[t.v[1]]));
    }
  }
  return best;
}

Scene make_gears3d(const Gears3dOptions& options) {
  // Gear A: 24 teeth, pitch radius 1.2; gear B: 16 teeth, pitch radius 0.8 (same pitch).
  const int teeth_a = 24, teeth_b = 16, samples = options.samples_per_tooth;
  const double ra_root = 1.12, ra_tip = 1.27, rb_root = 0.72, rb_tip = 0.87;
  const double width = 0.5, bore = 0.3;
  // A has a tooth centred on +x, B a tooth gap centred on -x (towards A): they mesh.
  const double phase_a = -0.5 * 2 * kPi / teeth_a;
  const double phase_b = kPi;
  const std::vector<Vec3> loop_a = gear_loop({0, 0, 0}, ra_root, ra_tip, teeth_a, samples, phase_a);
  // Centre distance by bisection: the profile gap grows with it.
  double lo = ra_root + rb_root, hi = ra_tip + rb_tip + options.tooth_gap;
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (lo + hi);
    const auto loop_b = gear_loop({mid, 0, 0}, rb_root, rb_tip, teeth_b, samples, phase_b);
    (loop_distance(loop_a, loop_b) < options.tooth_gap ? lo : hi) = mid;
  }
  const Vec3 centre_b{hi, 0, 0};
  const auto loop_b = gear_loop(centre_b, rb_root, rb_tip, teeth_b, samples, phase_b);
  const double gap = loop_distance(loop_a, loop_b);
  if (!(gap >= options.tooth_gap * 0.999)) throw std::runtime_error("gears3d: gears intersect");

  // Bore and shaft share the angular sampling, so the chord-to-chord clearance is exact.
  const int n_a = teeth_a * samples;
  const auto bore_loop = circle_loop({0, 0, 0}, bore, n_a, phase_a);
  const double shaft_r = bore - options.shaft_gap / std::cos(kPi / n_a);
  const auto shaft_loop = circle_loop({0, 0, 0}, shaft_r, n_a, phase_a);

  std::vector<SceneObject> objects;
  objects.push_back(extrude_ring("gear_a", loop_a, bore_loop, 0, width));
  objects.push_back(extrude_star("gear_b", loop_b, centre_b, 0, width));
  objects.push_back(extrude_star("shaft", shaft_loop, {0, 0, 0}, -0.6, width + 0.6));
  return checked_scene(3, std::move(objects));
}

Scene make_blades(const BladesOptions& options) {
  const double c = options.clearance, t = options.blade_thickness;
  const double lip_w = t + 2 * c, cavity_w = t + 2 * options.cavity_clearance;
  const double slot_bottom = 0.8, top = 2.0, lip_bottom = top - options.lip_height;
  const double centres[3] = {1.0, 2.0, 3.0};
  std::vector<double> xkeys{0.0, 4.0};
  for (double xc : centres) {
    for (double w : {lip_w, cavity_w}) {
      xkeys.push_back(xc - w / 2);
      xkeys.push_back(xc + w / 2);
    }
  }
  const auto xs = grid_lines(xkeys, options.cell);
  const auto ys = grid_lines({0.0, slot_bottom, lip_bottom, top}, options.cell);
  const auto zs = grid_lines({0.0, 1.0}, options.cell);
  auto in_slot = [&](int i, int j) {
    const double xm = 0.5 * (xs[i] + xs[i + 1]), ym = 0.5 * (ys[j] + ys[j + 1]);
    if (ym < slot_bottom) return false;
    const double half = (ym > lip_bottom ? lip_w : cavity_w) / 2;
    for (double xc : centres)
      if (std::abs(xm - xc) < half) return true;
    return false;
  };
  std::vector<SceneObject> objects;
  objects.push_back(
      rectilinear_solid("block", xs, ys, zs, [&](int i, int j, int) { return !in_slot(i, j); }));
  int b = 0;
  for (double xc : centres) {
    const auto bx = grid_lines({xc - t / 2, xc + t / 2}, options.cell);
    const auto by = grid_lines({slot_bottom + options.floor_clearance, top, 3.0}, options.cell);
    const auto bz = grid_lines({0.05, 0.95}, options.cell);
    objects.push_back(rectilinear_solid("blade_" + std::to_string(b++), bx, by, bz,
                                        [](int, int, int) { return true; }));
  }
  return checked_scene(3, std::move(objects));
}

Scene make_polygons2d(const Polygons2dOptions& options) {
  std::mt19937_64 rng(options.seed);
  const int g = options.grid;
  const double s = 1.0 / g;
  // Which cells hold a pair: a seeded shuffle of the cell indices.
  std::vector<int> cells(static_cast<size_t>(g) * g);
  for (size_t i = 0; i < cells.size(); ++i) cells[i] = static_cast<int>(i);
  std::shuffle(cells.begin(), cells.end(), rng);
  if (options.pairs + options.empty > static_cast<int>(cells.size()))
    throw std::runtime_error("polygons2d: more pairs and empty cells than cells");
  enum Kind : uint8_t { kSingle, kPair, kEmpty };
  std::vector<Kind> kind(cells.size(), kSingle);
  for (int i = 0; i < options.pairs; ++i) kind[cells[i]] = kPair;
  for (int i = 0; i < options.empty; ++i) kind[cells[options.pairs + i]] = kEmpty;

  // A random polygon around c of radius <= r: convex (on a circle) or star-shaped.
  auto random_polygon = [&](const std::string& label, Vec3 c, double r) {
    const int n =
        options.min_sides + static_cast<int>(rng() % (options.max_sides - options.min_sides + 1));
    const bool star = (rng() & 1) != 0;
    std::vector<double> angles(n);
    for (int i = 0; i < n; ++i) angles[i] = 2 * kPi * (i + uniform(rng, 0.1, 0.9)) / n;
    std::vector<Vec3> loop;
    for (int i = 0; i < n; ++i) {
      const double rr = star ? r * uniform(rng, 0.45, 1.0) : r;
      loop.push_back(c + Vec3{rr * std::cos(angles[i]), rr * std::sin(angles[i]), 0});
    }
    return polygon_object(label, std::move(loop));
  };

  std::vector<SceneObject> objects;
  int pair_index = 0;
  for (int cy = 0; cy < g; ++cy) {
    for (int cx = 0; cx < g; ++cx) {
      const Vec3 lo{cx * s, cy * s, 0};
      const std::string base = "p" + std::to_string(cy) + "_" + std::to_string(cx);
      const Kind k = kind[static_cast<size_t>(cy) * g + cx];
      if (k == kEmpty) continue;
      if (k == kSingle) {
        const double r = s * uniform(rng, 0.2, 0.42);
        const double slack = 0.46 * s - r;
        const Vec3 c = lo + Vec3{0.5 * s + uniform(rng, -slack, slack),
                                 0.5 * s + uniform(rng, -slack, slack), 0};
        objects.push_back(random_polygon(base, c, r));
        continue;
      }
      // Two polygons side by side, the right one pushed left until the gap is reached.
      // Gaps are log-spaced over the pairs (in raster order of the cells), largest first.
      const double f =
          options.pairs > 1 ? static_cast<double>(pair_index) / (options.pairs - 1) : 1;
      ++pair_index;
      const double target = options.max_gap * std::pow(options.min_gap / options.max_gap, f);
      const double cyy = 0.5 * s + uniform(rng, -0.1, 0.1) * s;
      SceneObject left =
          random_polygon(base + "a", lo + Vec3{0.25 * s, cyy, 0}, s * uniform(rng, 0.12, 0.2));
      SceneObject right =
          random_polygon(base + "b", lo + Vec3{0.75 * s, cyy, 0}, s * uniform(rng, 0.12, 0.2));
      double d = polyline_distance_2d(left, right);
      if (d < target) throw std::runtime_error("polygons2d: max_gap larger than a pair's gap");
      for (int it = 0; it < 2000 && d > target * 1.01; ++it) {
        translate(right, {-(d - target), 0, 0});  // moves by d - target: never closer than target
        d = polyline_distance_2d(left, right);
      }
      if (!(d >= target * 0.999)) throw std::runtime_error("polygons2d: pair pushed too far");
      objects.push_back(std::move(left));
      objects.push_back(std::move(right));
    }
  }

  // Verify: each polygon simple, no two polygons intersecting (bounding boxes first).
  std::vector<Box> boxes;
  for (const SceneObject& o : objects) boxes.push_back(bounds(o));
  for (size_t i = 0; i < objects.size(); ++i) {
    const SceneObject& o = objects[i];
    const size_t n = o.simplices.size();
    for (size_t a = 0; a < n; ++a) {
      for (size_t b = a + 2; b < n; ++b) {
        if (a == 0 && b == n - 1) continue;  // adjacent through the closing vertex
        if (segments_intersect(o.vertices[o.simplices[a].v[0]], o.vertices[o.simplices[a].v[1]],
                               o.vertices[o.simplices[b].v[0]], o.vertices[o.simplices[b].v[1]]))
          throw std::runtime_error("polygons2d: polygon '" + o.label + "' is not simple");
      }
    }
    for (size_t j = i + 1; j < objects.size(); ++j) {
      const Box& p = boxes[i];
      const Box& q = boxes[j];
      if (p.hi.x < q.lo.x || q.hi.x < p.lo.x || p.hi.y < q.lo.y || q.hi.y < p.lo.y) continue;
      if (polyline_distance_2d(objects[i], objects[j]) <= 0)
        throw std::runtime_error("polygons2d: '" + objects[i].label + "' and '" + objects[j].label +
                                 "' intersect");
    }
  }
  return checked_scene(2, std::move(objects));
}

Scene make_spheres(const SpheresOptions& options) {
  std::mt19937_64 rng(options.seed);
  struct Ball {
    Vec3 c;
    double r;
    int column;
  };
  std::vector<Ball> balls;
  const int per = options.per_column, cols = options.columns;
  const int total_gaps = cols * cols * (per - 1);
  // Gaps log-spaced from max to min, assigned to the column gaps in a seeded order.
  std::vector<double> gaps(total_gaps);
  for (int i = 0; i < total_gaps; ++i) {
    const double f = total_gaps > 1 ? static_cast<double>(i) / (total_gaps - 1) : 1;
    gaps[i] = options.max_gap * std::pow(options.min_gap / options.max_gap, f);
  }
  std::shuffle(gaps.begin(), gaps.end(), rng);
  int next_gap = 0;
  for (int cy = 0; cy < cols; ++cy) {
    for (int cx = 0; cx < cols; ++cx) {
      const int column = cy * cols + cx;
      const double x = cx + uniform(rng, -0.03, 0.03), y = cy + uniform(rng, -0.03, 0.03);
      double z = uniform(rng, 0.0, 0.3);
      for (int k = 0; k < per; ++k) {
        const double r = uniform(rng, 0.3, 0.42);
        if (k > 0)
          z += gaps[next_gap++] + r;
        else
          z += r;
        balls.push_back({{x, y, z}, r, column});
        z += r;  // top pole
      }
    }
  }
  // Different columns: bounding spheres must be apart (meshes lie inside them). Same column:
  // pole-to-pole vertical gaps are positive by construction.
  for (size_t i = 0; i < balls.size(); ++i) {
    for (size_t j = i + 1; j < balls.size(); ++j) {
      if (balls[i].column == balls[j].column) continue;
      if (dist(balls[i].c, balls[j].c) <= balls[i].r + balls[j].r)
        throw std::runtime_error("spheres: spheres " + std::to_string(i) + " and " +
                                 std::to_string(j) + " may intersect");
    }
  }
  std::vector<SceneObject> objects;
  for (size_t i = 0; i < balls.size(); ++i) {
    objects.push_back(gvd::test::make_sphere("s" + std::to_string(i), balls[i].c, balls[i].r,
                                             options.rings, options.segments));
  }
  return checked_scene(3, std::move(objects));
}

}  // namespace gvd::bench
