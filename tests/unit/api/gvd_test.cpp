// The facade gvd/gvd.h: the same answers as the core calls it wraps, in 2D too (the install
// test's example is 3D), its defaults equal to `gvd compute`'s, and its argument checks.

#include "gvd/gvd.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "gvd/pipeline/parameters.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/query/gvd_index.h"
#include "gvd/scene/scene.h"

namespace gvd::api {

using namespace gvd::scene;
using namespace gvd::result;
using namespace gvd::query;
using namespace gvd::grid;
using namespace gvd::pipeline;

namespace {

// Two closed unit squares side by side, `gap` apart (2D): their GVD is the line x = 1 + gap/2.
Scene two_squares(double gap) {
  Scene scene(2);
  const std::vector<uint32_t> loop = {0, 1, 1, 2, 2, 3, 3, 0};
  scene.add("left", std::vector<double>{0, 0, 1, 0, 1, 1, 0, 1}, loop);
  const double x = 1 + gap;
  scene.add("right", std::vector<double>{x, 0, x + 1, 0, x + 1, 1, x, 1}, loop);
  return scene;
}

ComputeOptions cpu() {
  ComputeOptions o;
  o.backend = "cpu";
  return o;
}

TEST(GvdApi, DefaultsAreThoseOfTheCore) {
  const ComputeOptions a;
  const PipelineOptions p;
  const SceneLimits l;
  EXPECT_EQ(a.max_depth, p.max_depth);
  EXPECT_EQ(a.contact_depth, p.contact_depth);
  EXPECT_EQ(a.max_leaves, p.max_leaves);
  EXPECT_EQ(a.ambiguity_levels, p.ambiguity_levels);
  EXPECT_EQ(a.ambiguity_rounds, p.ambiguity_rounds);
  EXPECT_EQ(a.unseen_rounds, p.unseen_rounds);
  EXPECT_EQ(a.threads, p.threads);
  EXPECT_EQ(a.octree_build, choice_name(p.octree_build));
  EXPECT_EQ(a.distance, choice_name(p.distance));
  EXPECT_EQ(a.refine, choice_name(p.refine));
  EXPECT_EQ(a.resolution, choice_name(p.resolution));
  EXPECT_EQ(a.curved_tolerance, p.curved_tolerance);
  EXPECT_EQ(a.frame, domain_frame_name(p.domain.frame));
  EXPECT_EQ(a.max_objects, l.max_objects);
  EXPECT_EQ(a.max_simplices, l.max_simplices);
  EXPECT_EQ(a.backend, "auto");  // `gvd compute`'s default (the core's own is "cpu")
}

// The scene's length unit: set by name (canonical), carried by the result and its saved
// file; none when none was set; an unknown unit names the field.
TEST(GvdApi, UnitsAreSetCarriedAndChecked) {
  Scene scene = two_squares(0.1);
  EXPECT_EQ(scene.units(), "");
  EXPECT_EQ(compute(scene, cpu()).units(), "");
  scene.set_units("um");
  EXPECT_EQ(scene.units(), "\u00b5m");
  const Result r = compute(scene, cpu());
  EXPECT_EQ(r.units(), "\u00b5m");
  const std::string path = std::string(GVD_TEST_OUTPUT_DIR) + "/api_units.gvd";
  r.save(path);
  EXPECT_EQ(load(path).units(), "\u00b5m");
  try {
    scene.set_units("furlong");
    ADD_FAILURE() << "an unknown unit was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    EXPECT_NE(e.detail().find("units must name a length unit"), std::string::npos) << e.detail();
  }
  EXPECT_EQ(scene.units(), "\u00b5m");
  scene.set_units("");
  EXPECT_EQ(scene.units(), "");
}

TEST(GvdApi, TwoSquaresIn2D) {
  const double gap = 0.01, mid = 1 + gap / 2;
  const Result r = compute(two_squares(gap), cpu());
  ASSERT_EQ(r.dimension(), 2);
  ASSERT_EQ(r.size(), 2);
  EXPECT_EQ(r.object("right"), 1);

  const std::vector<Edge> graph = r.graph();
  ASSERT_EQ(graph.size(), 1u);
  EXPECT_NEAR(graph[0].gap, gap, 1e-12);
  EXPECT_NEAR(graph[0].min_clearance, gap / 2, 1e-12);
  EXPECT_EQ(graph[0].tightest_point[2], 0);

  const std::vector<double> points = {0.5, 1.5, mid + 0.001, 0.5};
  const NearestBatch n = r.nearest(points, false, 2);
  ASSERT_EQ(n.object.size(), 2u);
  ASSERT_EQ(n.closest.size(), 4u);
  EXPECT_EQ(n.object[0], 0);
  EXPECT_GE(n.distance[0], 0.5 - 1e-12);
  EXPECT_LE(n.distance[0], 0.75);
  EXPECT_NEAR(n.closest[1], 1, 1e-9);  // on the top side of "left"
  EXPECT_EQ(n.object[1], 1);

  const Cell cell = r.cell("left");
  ASSERT_FALSE(cell.other.empty());
  EXPECT_EQ(cell.vertices.size(), 2 * cell.other.size());
  EXPECT_EQ(cell.clearance.size(), cell.other.size());
  EXPECT_EQ(cell.simplices.size() % 2, 0u);
  for (size_t v = 0; v < cell.other.size(); ++v) {
    EXPECT_LE(cell.vertices[2 * v], mid + 1e-6);
    if (cell.other[v] == 1) {
      EXPECT_NEAR(cell.vertices[2 * v], mid, 1e-6);
    }
  }

  const std::vector<double> from = {0.5, 1.3}, to = {1.6, 1.3};
  const Path p = r.path(from, to, {.min_clearance = 0.1});
  ASSERT_TRUE(p.found) << p.reason;
  EXPECT_EQ(p.points.front(), 0.5);
  EXPECT_EQ(p.points.back(), 1.3);
  EXPECT_GE(p.min_clearance, 0.1);

  const Explosion e = r.explode("left");
  EXPECT_EQ(e.ring, (std::vector<int>{0, 1}));
  EXPECT_GT(e.displacement[2], 0);                       // "right" moves away from "left", along +x
  EXPECT_EQ(e.factor, (std::vector<double>{1.0, 1.0}));  // nothing in its way

  // The squares are closed: inside "left" the distance is negative, 0.5 from its sides.
  const std::vector<double> within = {0.5, 0.5};
  const NearestBatch in = r.nearest(within);
  EXPECT_EQ(in.inside[0], 1);
  EXPECT_EQ(n.inside[0], 0);
  EXPECT_EQ(in.signed_distance[0], -in.distance[0]);
  EXPECT_GE(in.distance[0], 0.5 - 1e-12);

  // Contacts: the one pair, at the exact gap, with one site along the facing sides (length
  // 1 + 2 r, r = sqrt((G/2)^2 - (g/2)^2), the mid-line being straight by symmetry).
  const double bound = 0.05;
  const std::vector<Contact> contacts = r.contacts(bound);
  ASSERT_EQ(contacts.size(), 1u);
  EXPECT_EQ(contacts[0].a, 0);
  EXPECT_EQ(contacts[0].b, 1);
  EXPECT_NEAR(contacts[0].gap, gap, 1e-12);
  EXPECT_FALSE(contacts[0].interference);
  ASSERT_EQ(contacts[0].sites.size(), 1u);
  const double reach = std::sqrt(bound * bound - gap * gap) / 2;
  EXPECT_NEAR(contacts[0].sites[0].area, 1 + 2 * reach, 0.01);
  EXPECT_NEAR(contacts[0].sites[0].centroid[0], mid, 1e-6);
  EXPECT_TRUE(r.contacts(gap / 2).empty());
}

TEST(GvdApi, AnswersAreTheCoresOnTheSameScene) {
  const Scene scene = two_squares(0.02);
  const Result r = compute(scene, cpu());
  const GvdResult& core = r.internal();
  const GvdIndex index(std::make_shared<const GvdResult>(core));
  const std::vector<Edge> graph = r.graph();
  ASSERT_EQ(graph.size(), core.graph.edges.size());
  for (size_t i = 0; i < graph.size(); ++i) {
    EXPECT_EQ(graph[i].area, core.graph.edges[i].area);
    EXPECT_EQ(graph[i].min_clearance, core.graph.edges[i].min_clearance);
  }
  const std::vector<double> points = {0.3, 0.2, 1.01, 0.7, -0.05, 1.05};
  const NearestBatch n = r.nearest(points);
  for (size_t i = 0; i < 3; ++i) {
    const NearestAnswer a = index.nearest({points[2 * i], points[2 * i + 1], 0});
    EXPECT_EQ(n.object[i], static_cast<Object>(a.object));
    EXPECT_EQ(n.distance[i], a.distance);
  }
  const std::vector<RingNeighbor> ring = index.neighbors(0, 1);
  const std::vector<Neighbor> mine = r.neighbors("left");
  ASSERT_EQ(mine.size(), ring.size());
  EXPECT_EQ(mine[0].area, ring[0].area);
}

TEST(GvdApi, ArgumentsAreChecked) {
  auto code_of = [](auto&& call) {
    try {
      call();
    } catch (const Error& e) {
      return e.code();
    }
    return ErrorCode::kInternal;
  };
  EXPECT_EQ(code_of([] { Scene s(4); }), ErrorCode::kInvalidArgument);
  Scene s(3);
  const std::vector<double> v = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const std::vector<uint32_t> t = {0, 1, 2};
  s.add("a", v, t);
  EXPECT_EQ(code_of([&] { s.add("a", v, t); }), ErrorCode::kInvalidScene);
  EXPECT_EQ(code_of([&] {
              s.add("b", std::vector<double>{0, 0}, t);
            }),
            ErrorCode::kInvalidArgument);
  s.add("c", v, std::vector<uint32_t>{0, 1, 7});  // index 7: the scene check at compute
  EXPECT_EQ(code_of([&] { compute(s, cpu()); }), ErrorCode::kInvalidScene);
  ComputeOptions bad = cpu();
  bad.refine = "sometimes";
  EXPECT_EQ(code_of([&] { compute(two_squares(0.1), bad); }), ErrorCode::kInvalidArgument);
  bad = cpu();
  bad.domain = {0, 0, 1};
  EXPECT_EQ(code_of([&] { compute(two_squares(0.1), bad); }), ErrorCode::kInvalidArgument);

  const Result r = compute(two_squares(0.1), cpu());
  EXPECT_EQ(code_of([&] { r.nearest(std::vector<double>{1, 2, 3}); }), ErrorCode::kInvalidArgument);
  EXPECT_EQ(code_of([&] { r.cell(5); }), ErrorCode::kNotFound);
  EXPECT_EQ(code_of([&] {
              r.path(std::vector<double>{0, 0}, std::vector<double>{90, 0});
            }),
            ErrorCode::kOutsideDomain);
  EXPECT_EQ(code_of([&] { r.neighbors("left", 0); }), ErrorCode::kInvalidArgument);
}

// grid() and Result::grid() read their options through the parameter table, as compute()
// does: its defaults, ranges, choices and checks across parameters, named as the keywords.
TEST(GvdApi, GridOptionsAreTheParameterTables) {
  const GridOptions d;
  const PipelineParams table;
  EXPECT_EQ(d.resolution, find_parameter("resolution", ParamMode::kGrid)->keyword_value);
  EXPECT_EQ(d.metric, choice_name(table.metric));
  EXPECT_EQ(d.signed_distance, !table.unsigned_distance);
  EXPECT_EQ(d.range_cells, table.range_cells);
  EXPECT_EQ(d.max_cells, table.max_cells);
  EXPECT_EQ(d.threads, table.threads);
  EXPECT_EQ(d.backend, choice_name(table.backend));

  auto detail_of = [](auto&& call) -> std::string {
    try {
      call();
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument) << e.detail();
      return e.detail();
    }
    return "no error";
  };
  const Scene scene = two_squares(0.1);
  GridOptions cpu_grid;
  cpu_grid.backend = "cpu";
  cpu_grid.resolution = 16;
  const Result r = compute(scene, cpu());
  const auto refused = [&](GridOptions o, const std::string& says) {
    EXPECT_EQ(detail_of([&] { grid(scene, o); }), says);
    EXPECT_EQ(detail_of([&] { r.grid(o); }), says);
  };
  GridOptions o = cpu_grid;
  o.resolution = 0;
  refused(o, "resolution must be between 1 and 1048576, got 0");
  o = cpu_grid;
  o.metric = "l3";
  refused(o, "metric must be l2, l1 or linf, got \"l3\"");
  o = cpu_grid;
  o.domain = {2, 2, -1, -1};
  refused(o, "domain: the lower corner must be below the upper corner");
  o.domain = {-1, -1, 0, 2, 2, 1};
  refused(o, "domain needs 4 numbers for a 2D scene");
  o = cpu_grid;
  o.range_cells = -1;
  refused(o, "range_cells must be between 0 and 4096, got -1");
  o = cpu_grid;
  o.threads = -2;
  refused(o, "threads must be between 0 and 2147483647, got -2");
  // Within the table's ranges: the same grid from the scene and from the result over the
  // result's box.
  o = cpu_grid;
  o.domain = {-1, -1, 4, 3};
  const Grid g = grid(scene, o);
  EXPECT_EQ(g.shape[0], 16);
  EXPECT_EQ(r.grid(o).label, g.label);
}

}  // namespace
}  // namespace gvd::api
