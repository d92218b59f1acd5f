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
#include "support/grid_oracle.h"
#include "support/scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::grid;

namespace {

using test::make_box;
using test::make_circle;
using test::make_rect;
using test::make_scene;
using test::make_segment;
using test::make_sphere;

using test::check_against_oracle;
using test::Checked;
using test::oracle_cell;
using test::OracleCell;

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
