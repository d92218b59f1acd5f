// compute_grid (the uniform-grid discrete GVD, CuRV range culling) against an independent
// brute-force oracle written here: for every cell centre, the exact distance to every simplex
// of every object (L2 by projection onto the segment / the triangle's plane; L1 and L-infinity
// by nested ternary search on the convex distance along the simplex), the nearest object, and
// inside tests of their own (winding angle in 2D, solid angle in 3D). Nothing here is copied
// from the code's output.

#include "gvd/grid/compute_grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include "gvd/common/error.h"
#include "support/scenes.h"

namespace gvd {
namespace {

using test::make_box;
using test::make_circle;
using test::make_rect;
using test::make_scene;
using test::make_segment;
using test::make_sphere;

double norm(Vec3 v, GridMetric m) {
  switch (m) {
    case GridMetric::kL1:
      return std::abs(v.x) + std::abs(v.y) + std::abs(v.z);
    case GridMetric::kLinf:
      return std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)});
    case GridMetric::kL2:
      break;
  }
  return std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
}

// Our own products (vec.h has dot/cross; the oracle does not borrow them).
double odot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec3 ocross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

// Minimum of a convex function on [lo, hi] by ternary search (then the ends).
template <class F>
double ternary_min(F f, double lo, double hi, int iterations = 90) {
  double a = lo, b = hi;
  for (int i = 0; i < iterations; ++i) {
    const double m1 = a + (b - a) / 3, m2 = b - (b - a) / 3;
    if (f(m1) < f(m2))
      b = m2;
    else
      a = m1;
  }
  return std::min({f(0.5 * (a + b)), f(lo), f(hi)});
}

double oracle_segment(Vec3 p, Vec3 a, Vec3 b, GridMetric m) {
  if (m == GridMetric::kL2) {
    const Vec3 d = b - a;
    const double t = std::clamp(odot(p - a, d) / odot(d, d), 0.0, 1.0);
    return norm(p - (a + d * t), m);
  }
  return ternary_min([&](double t) { return norm(p - (a + (b - a) * t), m); }, 0.0, 1.0);
}

double oracle_triangle(Vec3 p, Vec3 a, Vec3 b, Vec3 c, GridMetric m) {
  if (m == GridMetric::kL2) {
    // Inside the prism: distance to the plane; else the nearest edge.
    const Vec3 n = ocross(b - a, c - a);
    const double nn = odot(n, n);
    const Vec3 q = p - n * (odot(p - a, n) / nn);
    const bool inside = odot(ocross(b - a, q - a), n) >= 0 && odot(ocross(c - b, q - b), n) >= 0 &&
                        odot(ocross(a - c, q - c), n) >= 0;
    if (inside) return std::abs(odot(p - a, n)) / std::sqrt(nn);
    return std::min(
        {oracle_segment(p, a, b, m), oracle_segment(p, b, c, m), oracle_segment(p, c, a, m)});
  }
  // g(u) = min over v of |p - a - u (b - a) - v (c - a)|, v in [0, 1 - u]: convex in u.
  auto g = [&](double u) {
    return ternary_min([&](double v) { return norm(p - (a + (b - a) * u + (c - a) * v), m); }, 0.0,
                       1.0 - u, 50);
  };
  // (2/3)^50 = 2e-9 of the parameter range: far inside the tolerance of the checks.
  return ternary_min(g, 0.0, 1.0, 50);
}

struct OracleCell {
  int first = -1;                 // nearest object
  double d1 = 1e300, d2 = 1e300;  // nearest and second-nearest object distances
};

OracleCell oracle_cell(const Scene& scene, Vec3 p, GridMetric m) {
  OracleCell r;
  for (size_t o = 0; o < scene.objects.size(); ++o) {
    const SceneObject& obj = scene.objects[o];
    double d = 1e300;
    for (const Simplex& s : obj.simplices) {
      const Vec3 a = obj.vertices[s.v[0]], b = obj.vertices[s.v[1]];
      d = std::min(d, scene.dimension == 2 ? oracle_segment(p, a, b, m)
                                           : oracle_triangle(p, a, b, obj.vertices[s.v[2]], m));
    }
    if (d < r.d1) {
      r.d2 = r.d1;
      r.d1 = d;
      r.first = static_cast<int>(o);
    } else if (d < r.d2) {
      r.d2 = d;
    }
  }
  return r;
}

// Inside tests of the oracle: total turning angle (2D), total solid angle (3D,
// Van Oosterom-Strackee); |winding| > 1/2 = inside.
bool oracle_inside(const SceneObject& obj, int dimension, Vec3 p) {
  double total = 0;
  for (const Simplex& s : obj.simplices) {
    if (dimension == 2) {
      const Vec3 a = obj.vertices[s.v[0]] - p, b = obj.vertices[s.v[1]] - p;
      total += std::atan2(a.x * b.y - a.y * b.x, a.x * b.x + a.y * b.y);
    } else {
      const Vec3 a = obj.vertices[s.v[0]] - p, b = obj.vertices[s.v[1]] - p,
                 c = obj.vertices[s.v[2]] - p;
      const double la = norm(a, GridMetric::kL2), lb = norm(b, GridMetric::kL2),
                   lc = norm(c, GridMetric::kL2);
      const double num = odot(a, ocross(b, c));
      const double den = la * lb * lc + odot(a, b) * lc + odot(b, c) * la + odot(c, a) * lb;
      total += 2 * std::atan2(num, den);
    }
  }
  const double turn = dimension == 2 ? 2 * std::numbers::pi : 4 * std::numbers::pi;
  return std::abs(total / turn) > 0.5;
}

double cell_diagonal(const GridSpec& spec, GridMetric m) {
  const double d = spec.dimension;
  return m == GridMetric::kL2 ? spec.h * std::sqrt(d)
                              : (m == GridMetric::kL1 ? spec.h * d : spec.h);
}

struct Checked {
  size_t cells = 0, label_mismatch = 0, unexplained_mismatch = 0, distance_bad = 0, sign_bad = 0;
};

// Compares every cell with the oracle. A label may differ only where the oracle's two nearest
// objects are within one cell diagonal of each other (the paper's one-cell bound); distances
// must be within float32 precision of the exact ones; signs negative exactly inside closed
// objects (the `closed` flags come from the test, not from the code).
Checked check_against_oracle(const Scene& scene, const DistanceGrid& grid,
                             const std::vector<bool>& closed, int stride = 1) {
  Checked c;
  const GridSpec& s = grid.spec;
  const double diag = cell_diagonal(s, grid.metric);
  for (int k = 0; k < s.n[2]; k += stride) {
    for (int j = 0; j < s.n[1]; j += stride) {
      for (int i = 0; i < s.n[0]; i += stride) {
        const size_t idx = (static_cast<size_t>(k) * s.n[1] + j) * s.n[0] + i;
        const Vec3 p{s.origin.x + (i + 0.5) * s.h, s.origin.y + (j + 0.5) * s.h,
                     s.dimension == 2 ? 0.0 : s.origin.z + (k + 0.5) * s.h};
        const OracleCell o = oracle_cell(scene, p, grid.metric);
        ++c.cells;
        if (grid.label[idx] != o.first) {
          ++c.label_mismatch;
          if (o.d2 - o.d1 >= diag) ++c.unexplained_mismatch;
        }
        const double d = std::abs(grid.distance[idx]);
        const double tol = 1.2e-7 * std::max(o.d1, s.h) + 1e-9 * s.h;
        if (!(std::abs(d - o.d1) <= tol)) ++c.distance_bad;
        const bool want_negative =
            closed[static_cast<size_t>(o.first)] &&
            oracle_inside(scene.objects[static_cast<size_t>(o.first)], s.dimension, p);
        // On the boundary (distance ~0) either sign is right.
        if (o.d1 > 1e-9 * s.h && (grid.distance[idx] < 0) != want_negative) ++c.sign_bad;
      }
    }
  }
  return c;
}

Scene random_segments(int objects, uint32_t seed, double length) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1), ang(0, 2 * std::numbers::pi);
  std::vector<SceneObject> objs;
  for (int o = 0; o < objects; ++o) {
    const Vec3 a{u(rng), u(rng), 0};
    const double t = ang(rng), l = length * (0.3 + u(rng));
    SceneObject obj =
        make_segment("s" + std::to_string(o), a, a + Vec3{l * std::cos(t), l * std::sin(t), 0});
    if (o % 3 == 0) {  // some objects of two segments (a polyline)
      const Vec3 b = obj.vertices[1];
      obj.vertices.push_back(b + Vec3{l * std::cos(t + 1), l * std::sin(t + 1), 0});
      obj.simplices.push_back({{1, 2, 0}});
    }
    objs.push_back(obj);
  }
  return make_scene(2, std::move(objs));
}

TEST(ComputeGrid, RandomSegmentsMatchTheOracle2D) {
  const Scene scene = random_segments(120, 7, 0.06);
  GridOptions o;
  o.resolution = 96;
  o.range_cells = 8;
  const DistanceGrid g = compute_grid(scene, o);
  const Checked c = check_against_oracle(scene, g, std::vector<bool>(scene.objects.size(), false));
  EXPECT_EQ(c.unexplained_mismatch, 0u) << c.label_mismatch << " label mismatches in all";
  EXPECT_EQ(c.distance_bad, 0u);
  EXPECT_EQ(c.sign_bad, 0u);  // nothing is closed: no negative distance
  // The culling evaluates far fewer pairs than brute force (a bound, not a measured value).
  EXPECT_LT(g.stats.pairs_evaluated, g.stats.brute_force_pairs / 4);
  EXPECT_EQ(g.stats.brute_force_pairs, g.spec.cell_count() * scene.objects.size());
}

TEST(ComputeGrid, CullingGivesTheBruteForceAnswerBitForBit) {
  const Scene scene = random_segments(200, 11, 0.04);
  GridOptions o;
  o.resolution = 128;
  o.range_cells = 8;
  const DistanceGrid culled = compute_grid(scene, o);
  o.cull = false;
  const DistanceGrid brute = compute_grid(scene, o);
  EXPECT_EQ(brute.stats.pairs_evaluated, brute.stats.brute_force_pairs);
  size_t label = 0, dist = 0;
  for (size_t i = 0; i < culled.label.size(); ++i) {
    label += culled.label[i] != brute.label[i];
    dist += culled.distance[i] != brute.distance[i];
  }
  EXPECT_EQ(label, 0u);
  EXPECT_EQ(dist, 0u);
}

TEST(ComputeGrid, SiteBoundsHoldTheirVoronoiRegions) {
  // §5's conservative bound V^(p): every cell lies in the bound of the object nearest to it
  // (by the oracle), ties apart.
  const Scene scene = random_segments(80, 3, 0.05);
  GridOptions o;
  o.resolution = 80;
  o.range_cells = 8;
  const DistanceGrid g = compute_grid(scene, o);
  const GridSpec& s = g.spec;
  size_t outside = 0;
  for (int j = 0; j < s.n[1]; ++j) {
    for (int i = 0; i < s.n[0]; ++i) {
      const OracleCell c = oracle_cell(scene, s.centre(i, j, 0), GridMetric::kL2);
      if (c.d2 - c.d1 < 1e-12) continue;
      const RangeBounds& b = g.site_bounds[static_cast<size_t>(c.first)];
      const int ti = i / g.range_cells, tj = j / g.range_cells;
      outside += b.empty() || ti < b.lo[0] || ti > b.hi[0] || tj < b.lo[1] || tj > b.hi[1];
    }
  }
  EXPECT_EQ(outside, 0u);
}

TEST(ComputeGrid, ClosedPolygonsAreSignedInside2D) {
  // A circle, a square whose corners sit exactly on rows of cell centres (the ray test's
  // degenerate case) and an open polyline.
  std::vector<SceneObject> objs;
  objs.push_back(make_circle("circle", {0.3, 0.3, 0}, 0.2, 40));
  objs.push_back(make_rect("square", {0.555, 0.555, 0}, {0.905, 0.905, 0}));
  SceneObject open = make_segment("open", {0.1, 0.8, 0}, {0.4, 0.95, 0});
  open.vertices.push_back({0.45, 0.7, 0});
  open.simplices.push_back({{1, 2, 0}});
  objs.push_back(open);
  const Scene scene = make_scene(2, std::move(objs));
  GridOptions o;
  o.resolution = 100;
  o.box = Box{{0, 0, 0}, {1, 1, 0}};
  o.range_cells = 16;
  const DistanceGrid g = compute_grid(scene, o);
  // Cell centres at (i + 0.5) / 100: the square's sides at 0.555 / 0.905 run through them,
  // its corners are cell centres.
  EXPECT_NEAR(g.spec.h, 0.01, 1e-15);
  EXPECT_EQ(g.closed, (std::vector<uint8_t>{1, 1, 0}));
  const Checked c = check_against_oracle(scene, g, {true, true, false});
  EXPECT_EQ(c.unexplained_mismatch, 0u);
  EXPECT_EQ(c.distance_bad, 0u);
  EXPECT_EQ(c.sign_bad, 0u);
  size_t negative = 0;
  for (double d : g.distance) negative += d < 0;
  EXPECT_GT(negative, 1000u);  // the circle alone covers ~1,250 cell centres
}

TEST(ComputeGrid, ClosedMeshesAreSignedInside3D) {
  // A sphere and a box whose faces lie on planes of cell centres (centres at (i + 0.5) / 16:
  // rows of centres run along its edges and face diagonals), an open triangle fan.
  std::vector<SceneObject> objs;
  objs.push_back(make_sphere("ball", {0.3, 0.35, 0.4}, 0.22, 8, 12));
  objs.push_back(make_box("box", {0.59375, 0.15625, 0.15625}, {0.90625, 0.84375, 0.65625}));
  SceneObject fan;
  fan.label = "fan";
  fan.vertices = {{0.1, 0.8, 0.8}, {0.4, 0.9, 0.85}, {0.2, 0.95, 0.6}, {0.05, 0.7, 0.95}};
  fan.simplices = {{{0, 1, 2}}, {{0, 2, 3}}};
  objs.push_back(fan);
  const Scene scene = make_scene(3, std::move(objs));
  GridOptions o;
  o.resolution = 16;
  o.box = Box{{0, 0, 0}, {1, 1, 1}};
  o.range_cells = 4;
  const DistanceGrid g = compute_grid(scene, o);
  EXPECT_EQ(g.closed, (std::vector<uint8_t>{1, 1, 0}));
  const Checked c = check_against_oracle(scene, g, {true, true, false});
  EXPECT_EQ(c.unexplained_mismatch, 0u) << c.label_mismatch << " mismatches";
  EXPECT_EQ(c.distance_bad, 0u);
  EXPECT_EQ(c.sign_bad, 0u);
}

TEST(ComputeGrid, ManhattanAndChebyshevMatchTheirOracles2D) {
  const Scene scene = random_segments(40, 5, 0.1);
  for (GridMetric m : {GridMetric::kL1, GridMetric::kLinf}) {
    GridOptions o;
    o.resolution = 64;
    o.range_cells = 8;
    o.metric = m;
    const DistanceGrid g = compute_grid(scene, o);
    EXPECT_EQ(g.metric, m);
    const Checked c =
        check_against_oracle(scene, g, std::vector<bool>(scene.objects.size(), false));
    EXPECT_EQ(c.unexplained_mismatch, 0u) << grid_metric_name(m);
    EXPECT_EQ(c.distance_bad, 0u) << grid_metric_name(m);
    EXPECT_LT(g.stats.pairs_evaluated, g.stats.brute_force_pairs) << grid_metric_name(m);
  }
}

TEST(ComputeGrid, ManhattanAndChebyshevMatchTheirOracles3D) {
  std::vector<SceneObject> objs;
  objs.push_back(make_box("a", {0.1, 0.1, 0.1}, {0.4, 0.35, 0.3}));
  SceneObject tri;
  tri.label = "tilted";
  tri.vertices = {{0.6, 0.2, 0.7}, {0.9, 0.6, 0.5}, {0.5, 0.9, 0.9}};
  tri.simplices = {{{0, 1, 2}}};
  objs.push_back(tri);
  objs.push_back(make_sphere("b", {0.3, 0.7, 0.6}, 0.15, 3, 4));
  const Scene scene = make_scene(3, std::move(objs));
  for (GridMetric m : {GridMetric::kL1, GridMetric::kLinf}) {
    GridOptions o;
    o.resolution = 6;
    o.range_cells = 2;
    o.metric = m;
    const DistanceGrid g = compute_grid(scene, o);
    const Checked c = check_against_oracle(scene, g, {true, false, true});
    EXPECT_EQ(c.unexplained_mismatch, 0u) << grid_metric_name(m);
    EXPECT_EQ(c.distance_bad, 0u) << grid_metric_name(m);
    EXPECT_EQ(c.sign_bad, 0u) << grid_metric_name(m);
  }
}

TEST(ComputeGrid, TwoPointsGiveTheirBisector) {
  // Analytic: two tiny segments; the label flips exactly at the bisector x = 0.5.
  const Scene scene = make_scene(2, {make_segment("l", {0.2, 0.5, 0}, {0.2, 0.5001, 0}),
                                     make_segment("r", {0.8, 0.5, 0}, {0.8, 0.5001, 0})});
  GridOptions o;
  o.resolution = 50;
  o.box = Box{{0, 0, 0}, {1, 1, 0}};
  const DistanceGrid g = compute_grid(scene, o);
  for (int j = 0; j < g.spec.n[1]; ++j)
    for (int i = 0; i < g.spec.n[0]; ++i)
      ASSERT_EQ(g.label[static_cast<size_t>(j) * g.spec.n[0] + i], i < 25 ? 0 : 1) << i << "," << j;
}

TEST(ComputeGrid, BadInputIsAClearError) {
  const Scene scene = random_segments(3, 1, 0.1);
  GridOptions o;
  o.resolution = 0;
  EXPECT_THROW(compute_grid(scene, o), Error);
  o.resolution = -5;
  EXPECT_THROW(compute_grid(scene, o), Error);
  o.resolution = 100000;
  o.max_cells = 1000000;
  try {
    compute_grid(scene, o);
    ADD_FAILURE() << "no error for too many cells";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kLimitExceeded);
  }
  o = {};
  o.box = Box{{0.5, 0.5, 0}, {0.6, 0.6, 0}};  // does not hold the vertices
  EXPECT_THROW(compute_grid(scene, o), Error);
  Scene empty;
  empty.dimension = 2;
  EXPECT_THROW(compute_grid(empty, {}), Error);
  EXPECT_THROW(parse_grid_metric("l3"), Error);
  EXPECT_EQ(parse_grid_metric("linf"), GridMetric::kLinf);
}

}  // namespace
}  // namespace gvd
