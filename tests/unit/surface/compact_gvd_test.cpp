// Compact output (surface/compact_gvd.h) against the full-resolution GVD of the same run: the
// same surface with fewer pieces. Each cell stays closed, encloses the same volume (2D: area)
// and has the same interface area per neighbour; every compact vertex is a surfaced vertex
// (nothing moves), no piece crosses an object, and flat interfaces shrink to their outlines.

#include "gvd/surface/compact_gvd.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <tuple>

#include "gvd/pipeline/pipeline.h"
#include "support/oracles.h"
#include "support/scenes.h"
#include "support/thin_gap_scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::surface;
using namespace gvd::result;
using namespace gvd::pipeline;

namespace {

GvdResult run(const Scene& scene, const std::string& resolution) {
  PipelineOptions o;
  o.threads = 2;
  o.resolution = parse_choice<GvdResolution>(resolution);
  return compute_gvd(scene, o);
}

// Volume (3D, divergence theorem) or area (2D, shoelace) enclosed by a closed cell boundary,
// and the interface measure per other object.
struct Measures {
  double enclosed = 0;
  std::map<ObjectId, double> interface;
};
Measures measure(const GvdCell& cell, int dim) {
  Measures m;
  const int arity = dim == 2 ? 2 : 3;
  for (size_t s = 0; s + arity <= cell.indices.size(); s += arity) {
    const Vec3 a = cell.positions[cell.indices[s]], b = cell.positions[cell.indices[s + 1]];
    if (dim == 2) {
      m.enclosed += 0.5 * (a.x * b.y - a.y * b.x);
      m.interface[cell.other[cell.indices[s]]] += dist(a, b);
    } else {
      const Vec3 c = cell.positions[cell.indices[s + 2]];
      m.enclosed += dot(a, cross(b, c)) / 6;
      m.interface[cell.other[cell.indices[s]]] += 0.5 * norm(cross(b - a, c - a));
    }
  }
  return m;
}

// Every vertex of the compact cell is one the surfacer made (same position, same pair).
void expect_only_surfaced_vertices(const GvdCell& full, const GvdCell& compact, size_t cell) {
  std::set<std::tuple<double, double, double, ObjectId>> surfaced;
  for (size_t v = 0; v < full.positions.size(); ++v)
    surfaced.insert({full.positions[v].x, full.positions[v].y, full.positions[v].z, full.other[v]});
  for (size_t v = 0; v < compact.positions.size(); ++v) {
    const Vec3 p = compact.positions[v];
    EXPECT_TRUE(surfaced.count({p.x, p.y, p.z, compact.other[v]}))
        << "cell " << cell << " vertex " << v << " was not surfaced";
  }
}

void expect_same_surface(const GvdResult& full, const GvdResult& compact, double reduction) {
  const int dim = full.scene.dimension;
  ASSERT_EQ(full.gvd.cells.size(), compact.gvd.cells.size());
  EXPECT_EQ(test::count_gvd_object_crossings(compact.scene, compact.gvd, 3000), 0u);
  size_t before = 0, after = 0;
  for (size_t i = 0; i < full.gvd.cells.size(); ++i) {
    const GvdCell& f = full.gvd.cells[i];
    const GvdCell& c = compact.gvd.cells[i];
    before += f.indices.size();
    after += c.indices.size();
    EXPECT_EQ(test::count_open_edges(c, dim), 0u) << "cell " << i << " is not closed";
    const Measures mf = measure(f, dim), mc = measure(c, dim);
    EXPECT_NEAR(mc.enclosed, mf.enclosed, 1e-9 * std::abs(mf.enclosed)) << "cell " << i;
    ASSERT_EQ(mc.interface.size(), mf.interface.size()) << "cell " << i;
    for (const auto& [other, area] : mf.interface)
      EXPECT_NEAR(mc.interface.at(other), area, 1e-9 * area) << "cell " << i << " / " << other;
    expect_only_surfaced_vertices(f, c, i);
  }
  EXPECT_LE(after * reduction, before) << before / (dim == 2 ? 2 : 3) << " simplices full, "
                                       << after / (dim == 2 ? 2 : 3) << " compact";
  // The dual graph is measured on the full-resolution GVD either way.
  ASSERT_EQ(full.graph.edges.size(), compact.graph.edges.size());
  for (size_t e = 0; e < full.graph.edges.size(); ++e) {
    EXPECT_EQ(full.graph.edges[e].area, compact.graph.edges[e].area);
    EXPECT_EQ(full.graph.edges[e].min_clearance, compact.graph.edges[e].min_clearance);
  }
}

TEST(CompactGvd, FlatInterfacesShrinkToTheirOutlines3D) {
  test::StackedPlatesOptions po;
  po.count = 3;
  po.gap = 1e-3;
  po.cell = 0.1;
  const Scene plates = test::make_stacked_plates(po);
  expect_same_surface(run(plates, "full"), run(plates, "compact"), 4.0);
  test::ShaftInBoreOptions so;
  so.gap = 1e-2;
  so.cell = 0.1;
  const Scene shaft = test::make_shaft_in_bore(so);
  expect_same_surface(run(shaft, "full"), run(shaft, "compact"), 1.5);
}

// With a curved tolerance the curved parts merge too: cells stay closed, only surfaced
// vertices remain, nothing crosses an object, and volumes and interface areas move no more
// than the tolerance allows (each point within tolerance x its local clearance).
TEST(CompactGvd, CurvedInterfacesMergeWithinTheirTolerance3D) {
  const Scene scene =
      test::make_scene(3, {test::make_sphere("ball", {0, 0, 0}, 1.0, 16, 32),
                           test::make_box("box", {-1.01, -1.01, -1.01}, {1.01, 1.01, 1.01})});
  PipelineOptions o;
  o.threads = 2;
  o.resolution = GvdResolution::kFull;
  const GvdResult full = compute_gvd(scene, o);
  o.resolution = GvdResolution::kCompact;
  o.curved_tolerance = 1e-2;
  const GvdResult compact = compute_gvd(scene, o);
  EXPECT_EQ(test::count_gvd_object_crossings(compact.scene, compact.gvd), 0u);
  size_t before = 0, after = 0;
  for (size_t i = 0; i < full.gvd.cells.size(); ++i) {
    const GvdCell& f = full.gvd.cells[i];
    const GvdCell& c = compact.gvd.cells[i];
    before += f.indices.size() / 3;
    after += c.indices.size() / 3;
    EXPECT_EQ(test::count_open_edges(c, 3), 0u) << "cell " << i << " is not closed";
    double largest = 0;
    for (double x : f.clearance) largest = std::max(largest, x);
    const Measures mf = measure(f, 3), mc = measure(c, 3);
    double area = 0;
    for (const auto& [other, a] : mf.interface) area += a;
    EXPECT_NEAR(mc.enclosed, mf.enclosed, o.curved_tolerance * largest * area) << "cell " << i;
    expect_only_surfaced_vertices(f, c, i);
  }
  EXPECT_LE(after * 3, before * 2) << before << " simplices full, " << after << " compact";
}

TEST(CompactGvd, CurvedInterfacesKeepTheirPieces3D) {
  const Scene shell = test::make_scene(3, {test::make_sphere("inner", {0, 0, 0}, 0.5, 12, 24),
                                           test::make_sphere("shell", {0, 0, 0}, 1.0, 12, 24)});
  expect_same_surface(run(shell, "full"), run(shell, "compact"), 1.0);
}

TEST(CompactGvd, StraightInterfacesShrinkToTheirEnds2D) {
  test::ParallelBarsOptions bo;
  bo.gap = 1e-5;
  const Scene bars = test::make_parallel_bars_2d(bo);
  expect_same_surface(run(bars, "full"), run(bars, "compact"), 2.0);
  test::PolygonPairsOptions pp;
  pp.pairs = 40;
  pp.min_gap = 1e-5;
  const Scene pairs = test::make_polygon_pairs_2d(pp);
  expect_same_surface(run(pairs, "full"), run(pairs, "compact"), 1.0);
}

}  // namespace
}  // namespace gvd
