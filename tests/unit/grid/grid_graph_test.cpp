// grid_dual_graph (the dual graph of the uniform-grid GVD) against analytic answers (two boxes
// meet on their mid plane, over the grid's whole cross-section), a face adjacency counted here
// from the labels, brute-force clearances at every shared face, and the adaptive pipeline's
// dual graph of the same scene.

#include "gvd/grid/grid_graph.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <set>
#include <utility>

#include "gvd/pipeline/pipeline.h"
#include "support/oracles.h"
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

const DualEdge* find_edge(const DualGraph& g, ObjectId a, ObjectId b) {
  for (const DualEdge& e : g.edges)
    if (e.a == a && e.b == b) return &e;
  return nullptr;
}

// Two equal boxes side by side along x, 0.5 apart: every point equidistant from them lies on
// the plane x = 1.25 (their y, z extents are the same), so the labels switch on one plane of
// cell faces across the whole grid; the gap is 0.5 and the clearance 0.25, exactly.
TEST(GridDualGraph, TwoBoxesMeetOnTheirMidPlane3D) {
  const Scene scene =
      make_scene(3, {make_box("a", {0, 0, 0}, {1, 1, 1}), make_box("b", {1.5, 0, 0}, {2.5, 1, 1})});
  GridOptions o;
  o.resolution = 50;
  const DistanceGrid grid = compute_grid(scene, o);
  const DualGraph g = grid_dual_graph(grid, scene);
  ASSERT_EQ(g.node_count, 2u);
  ASSERT_EQ(g.edges.size(), 1u);
  const DualEdge& e = g.edges[0];
  EXPECT_EQ(e.a, 0u);
  EXPECT_EQ(e.b, 1u);
  const double h = grid.spec.h;
  EXPECT_NEAR(e.area, grid.spec.n[1] * h * grid.spec.n[2] * h, 1e-9);
  EXPECT_FALSE(e.touching);
  EXPECT_NEAR(e.gap, 0.5, 1e-12);
  EXPECT_NEAR(e.min_clearance, 0.25, 1e-12);
  EXPECT_NEAR(e.tightest_point.x, 1.25, 1e-12);
}

// Boxes that share a face touch: clearance 0, gap 0. A third box between two others keeps
// their labels apart: no edge between them.
TEST(GridDualGraph, TouchingPairsAndSeparatedPairs3D) {
  const Scene scene = make_scene(
      3, {make_box("a", {0, 0, 0}, {1, 1, 1}), make_box("c", {1, -0.5, -0.5}, {1.2, 1.5, 1.5}),
          make_box("b", {1.4, 0, 0}, {2.4, 1, 1})});
  GridOptions o;
  o.resolution = 64;
  const DualGraph g = grid_dual_graph(compute_grid(scene, o), scene);
  const DualEdge* ac = find_edge(g, 0, 1);
  ASSERT_NE(ac, nullptr);
  EXPECT_TRUE(ac->touching);
  EXPECT_EQ(ac->gap, 0.0);
  EXPECT_EQ(ac->min_clearance, 0.0);
  const DualEdge* cb = find_edge(g, 1, 2);
  ASSERT_NE(cb, nullptr);
  EXPECT_FALSE(cb->touching);
  EXPECT_NEAR(cb->gap, 0.2, 1e-12);
  EXPECT_NEAR(cb->min_clearance, 0.1, 1e-12);
  EXPECT_EQ(find_edge(g, 0, 2), nullptr);
}

// Random rectangles in 2D: the edges and their face counts equal a face adjacency counted
// here from the grid's labels; each gap is the brute-force least distance between the two
// objects; each clearance is half the gap or no more than the brute-force clearance at the
// shared faces' centres, and at least half the gap less a cell. Against the adaptive GVD of the
// same scene: every grid edge is an adaptive edge, and every adaptive edge with an interface longer
// than four cells is a grid edge.
TEST(GridDualGraph, RandomRectanglesMatchAFaceCountAndTheAdaptiveGraph2D) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<SceneObject> objects;
  std::vector<std::pair<Vec3, Vec3>> boxes;
  while (boxes.size() < 40) {  // apart by at least 0.005
    const Vec3 lo{u(rng), u(rng), 0};
    const Vec3 hi = lo + Vec3{0.02 + 0.05 * u(rng), 0.02 + 0.05 * u(rng), 0};
    bool apart = true;
    for (const auto& [l, h] : boxes)
      apart &= lo.x > h.x + 0.005 || hi.x < l.x - 0.005 || lo.y > h.y + 0.005 || hi.y < l.y - 0.005;
    if (!apart) continue;
    boxes.push_back({lo, hi});
    objects.push_back(make_rect("r" + std::to_string(objects.size()), lo, hi));
  }
  const Scene scene = make_scene(2, objects);
  GridOptions o;
  o.resolution = 300;
  const DistanceGrid grid = compute_grid(scene, o);
  const DualGraph g = grid_dual_graph(grid, scene, {.threads = 2});
  const GridSpec& s = grid.spec;
  std::map<std::pair<ObjectId, ObjectId>, uint64_t> faces;
  std::map<std::pair<ObjectId, ObjectId>, double> least;  // brute-force face clearance
  for (int j = 0; j < s.n[1]; ++j) {
    for (int i = 0; i < s.n[0]; ++i) {
      const int32_t la = grid.label[static_cast<size_t>(j) * s.n[0] + i];
      for (int axis = 0; axis < 2; ++axis) {
        const int i2 = i + (axis == 0), j2 = j + (axis == 1);
        if (i2 >= s.n[0] || j2 >= s.n[1]) continue;
        const int32_t lb = grid.label[static_cast<size_t>(j2) * s.n[0] + i2];
        if (la < 0 || lb < 0 || la == lb) continue;
        const std::pair<ObjectId, ObjectId> key{std::min(la, lb), std::max(la, lb)};
        ++faces[key];
        if (faces[key] % 7 != 1) continue;  // brute force on a sample of the faces
        Vec3 c = s.centre(i, j, 0);
        c[axis] += 0.5 * s.h;
        const double d = test::brute_nearest(scene, c).distance;
        auto it = least.find(key);
        if (it == least.end() || d < it->second) least[key] = d;
      }
    }
  }
  ASSERT_EQ(g.edges.size(), faces.size());
  for (const DualEdge& e : g.edges) {
    const std::pair<ObjectId, ObjectId> key{e.a, e.b};
    ASSERT_TRUE(faces.count(key)) << e.a << "-" << e.b;
    EXPECT_NEAR(e.area, faces[key] * s.h, 1e-9);
    double gap = 1e300;
    for (const Vec3& v : scene.objects[e.a].vertices)
      gap = std::min(gap, test::brute_distance(scene, e.b, v));
    for (const Vec3& v : scene.objects[e.b].vertices)
      gap = std::min(gap, test::brute_distance(scene, e.a, v));
    EXPECT_NEAR(e.gap, gap, 1e-12) << e.a << "-" << e.b;  // rectangles: a corner is nearest
    // Half the gap, exactly (the true interface's least clearance), or no more than the
    // discrete interface's own.
    if (std::abs(e.min_clearance - 0.5 * gap) > 1e-12) {
      EXPECT_LE(e.min_clearance, least[key] + 1e-12) << e.a << "-" << e.b;
    }
    EXPECT_GE(e.min_clearance, 0.5 * e.gap - s.h) << e.a << "-" << e.b;
  }
  const GvdResult adaptive = compute_gvd(scene);
  std::set<std::pair<ObjectId, ObjectId>> theirs;
  for (const DualEdge& e : adaptive.graph.edges) {
    theirs.insert({e.a, e.b});
    if (e.area > 4 * s.h) {
      EXPECT_NE(find_edge(g, e.a, e.b), nullptr) << e.a << "-" << e.b;
    }
  }
  for (const DualEdge& e : g.edges) EXPECT_TRUE(theirs.count({e.a, e.b})) << e.a << "-" << e.b;
}

}  // namespace
}  // namespace gvd
