// grid_advice: the uniform-grid resolution that separates the closest pair, checked on scenes
// whose gap is known by construction (the expected numbers come from that gap and the box,
// never from the code's output).

#include "gvd/grid/grid_advice.h"

#include <gtest/gtest.h>

#include <cmath>

#include "gvd/pipeline/pipeline.h"
#include "support/scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::graph;
using namespace gvd::result;
using namespace gvd::grid;
using namespace gvd::pipeline;

namespace {

using test::make_box;
using test::make_rect;
using test::make_scene;

TEST(GridAdvice, TwoBarsAMillimetreApart2D) {
  // Bars [0, 1] x [0, 0.1] and [0, 1] x [0.1 + g, 0.2 + g]: the gap is g, the box's longest
  // side 1 x 1.1 (5 % padding of the longest extent, 1, on both sides).
  const double g = 1e-3;
  const Scene scene = make_scene(2, {make_rect("low", {0, 0, 0}, {1, 0.1, 0}),
                                     make_rect("high", {0, 0.1 + g, 0}, {1, 0.2 + g, 0})});
  const GvdResult r = compute_gvd(scene);
  const GridAdvice a = grid_advice(r.scene, r.graph);
  ASSERT_TRUE(a.measured);
  EXPECT_EQ(a.a, 0u);
  EXPECT_EQ(a.b, 1u);
  EXPECT_NEAR(a.gap, g, 1e-12);
  EXPECT_NEAR(a.longest_side, 1.1, 1e-12);
  // The least N with (1.1 / N) sqrt(2) < g: 1.1 sqrt(2) / 1e-3 = 1555.63..., so N = 1556.
  EXPECT_EQ(a.resolution, 1556);
  const double h = 1.1 / 1556;
  EXPECT_LT(h * std::sqrt(2.0), g);
  EXPECT_GE(1.1 / 1555 * std::sqrt(2.0), g);
  // y: extent 0.2 + g + 2 x 0.05 = 0.301 -> ceil(0.301 / h) = ceil(425.78...) = 426 rows.
  EXPECT_EQ(a.cells, 1556.0 * 426.0);
  EXPECT_TRUE(a.fits);
  EXPECT_EQ(a.touching_pairs, 0u);
}

TEST(GridAdvice, FlushBoxesNeedTheOctree3D) {
  const double g = 1e-3;
  const Scene scene = make_scene(
      3, {make_box("a", {0, 0, 0}, {1, 1, 0.5}), make_box("b", {0, 0, 0.5 + g}, {1, 1, 1 + g})});
  const GvdResult r = compute_gvd(scene);
  const GridAdvice a = grid_advice(r.scene, r.graph);
  ASSERT_TRUE(a.measured);
  EXPECT_NEAR(a.gap, g, 1e-12);
  // The box: x, y extents 1 + 0.1 (1 + g) = 1.1001, z 1.1 (1 + g) = 1.1011 (the longest).
  // 1.1011 sqrt(3) / g = 1907.16...: N = 1908 along z, ceil(1.1001 / (1.1011 / 1908)) =
  // ceil(1906.27...) = 1907 along x and y: 6.9e9 cells, beyond the default limit of 2^27.
  EXPECT_EQ(a.resolution, 1908);
  EXPECT_EQ(a.cells, 1907.0 * 1907.0 * 1908.0);
  EXPECT_FALSE(a.fits);
}

TEST(GridAdvice, TouchingPairsAndUnmeasuredGaps) {
  const Scene scene =
      make_scene(2, {make_rect("a", {0, 0, 0}, {1, 1, 0}), make_rect("b", {1, 0, 0}, {2, 1, 0}),
                     make_rect("c", {0, 1.5, 0}, {2, 2, 0})});
  DualGraph graph;
  graph.node_count = 3;
  graph.edges = {
      {0, 1, 1, 0, {}, 0, true}, {0, 2, 1, 0.25, {}, 0.5, false}, {1, 2, 1, 0.25, {}, 0.5, false}};
  GridAdvice a = grid_advice(scene, graph);
  ASSERT_TRUE(a.measured);
  EXPECT_EQ(a.touching_pairs, 1u);
  EXPECT_EQ(a.gap, 0.5);
  EXPECT_EQ(a.a, 0u);  // the first of the two tied pairs
  EXPECT_EQ(a.b, 2u);
  // Every pair touching: nothing to resolve.
  graph.edges.resize(1);
  a = grid_advice(scene, graph);
  EXPECT_TRUE(a.measured);
  EXPECT_EQ(a.gap, 0);
  EXPECT_EQ(a.resolution, 0);
  EXPECT_FALSE(a.fits);
  // Gaps not measured (a result saved before they were): no advice.
  graph.edges = {{0, 1, 1, 0.1, {}, -1, false}};
  EXPECT_FALSE(grid_advice(scene, graph).measured);
  graph.edges.clear();
  EXPECT_FALSE(grid_advice(scene, graph).measured);
}

}  // namespace
}  // namespace gvd
