// sample_result_grid (a uniform grid sampled from a finished adaptive result) against the
// independent brute-force oracle of support/grid_oracle.h, and against compute_grid (CuRV on
// the scene itself) on the same box: the two must agree cell for cell.

#include "gvd/grid/sample_result_grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <random>

#include "gvd/common/error.h"
#include "gvd/io/result_file.h"
#include "gvd/pipeline/pipeline.h"
#include "support/grid_oracle.h"
#include "support/scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::result;
using namespace gvd::grid;
using namespace gvd::io;
using namespace gvd::pipeline;

namespace {

using test::make_box;
using test::make_circle;
using test::make_rect;
using test::make_scene;
using test::make_segment;
using test::make_sphere;

Scene scattered_segments(int objects, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1), ang(0, 2 * std::numbers::pi);
  std::vector<SceneObject> objs;
  for (int o = 0; o < objects; ++o) {
    const Vec3 a{u(rng), u(rng), 0};
    const double t = ang(rng), l = 0.03 + 0.04 * u(rng);
    objs.push_back(
        make_segment("s" + std::to_string(o), a, a + Vec3{l * std::cos(t), l * std::sin(t), 0}));
  }
  return make_scene(2, std::move(objs));
}

GvdResult adaptive(const Scene& scene) {
  PipelineOptions o;
  o.threads = 2;
  return compute_gvd(scene, o);
}

// Every cell against the oracle (evaluated once per cell): labels exact (a mismatch only where
// the oracle's two nearest objects tie to 1e-9 of a cell), distances within float32 of exact
// (the tolerance of check_against_oracle), negative exactly inside closed objects.
void expect_exact(const Scene& scene, const DistanceGrid& g, const std::vector<bool>& closed) {
  size_t untied = 0, distance_bad = 0, sign_bad = 0;
  const GridSpec& s = g.spec;
  for (int k = 0; k < s.n[2]; ++k)
    for (int j = 0; j < s.n[1]; ++j)
      for (int i = 0; i < s.n[0]; ++i) {
        const size_t idx = (static_cast<size_t>(k) * s.n[1] + j) * s.n[0] + i;
        const Vec3 p = s.centre(i, j, k);
        const test::OracleCell o = test::oracle_cell(scene, p, g.metric);
        if (g.label[idx] != o.first && o.d2 - o.d1 > 1e-9 * s.h) ++untied;
        const double d = std::abs(g.distance[idx]);
        if (!(std::abs(d - o.d1) <= 1.2e-7 * std::max(o.d1, s.h) + 1e-9 * s.h)) ++distance_bad;
        const size_t first = static_cast<size_t>(o.first);
        const bool inside =
            closed[first] && test::oracle_inside(scene.objects[first], s.dimension, p);
        if (o.d1 > 1e-9 * s.h && (g.distance[idx] < 0) != inside) ++sign_bad;
      }
  EXPECT_EQ(untied, 0u);
  EXPECT_EQ(distance_bad, 0u);
  EXPECT_EQ(sign_bad, 0u);
}

// Cell for cell the same labels and distances as compute_grid on the result's domain.
void expect_same_as_compute_grid(const GvdResult& r, const DistanceGrid& sampled) {
  GridOptions o;
  o.resolution = sampled.spec.n[0] >= sampled.spec.n[1] ? sampled.spec.n[0] : sampled.spec.n[1];
  o.metric = sampled.metric;
  o.box = r.domain.box();
  const DistanceGrid direct = compute_grid(r.scene, o);
  ASSERT_EQ(direct.spec.n, sampled.spec.n);
  ASSERT_EQ(direct.spec.h, sampled.spec.h);
  size_t labels = 0, distances = 0;
  for (size_t c = 0; c < direct.label.size(); ++c) {
    labels += direct.label[c] != sampled.label[c];
    distances += direct.distance[c] != sampled.distance[c];
  }
  EXPECT_EQ(labels, 0u);
  EXPECT_EQ(distances, 0u);
}

TEST(SampleResultGrid, ScatteredSegmentsAreExact2D) {
  const Scene scene = scattered_segments(40, 9);
  const GvdResult r = adaptive(scene);
  ResultGridOptions o;
  o.resolution = 80;
  const DistanceGrid g = sample_result_grid(r, o);
  EXPECT_EQ(g.spec.n[0], 80);  // the result's domain is a square
  EXPECT_EQ(g.spec.n[1], 80);
  expect_exact(scene, g, std::vector<bool>(scene.objects.size(), false));
  // Every cell centre lies in the domain, so the octree bounded every search.
  EXPECT_EQ(g.stats.octree_bounded, g.spec.cell_count());
  EXPECT_LT(g.stats.pairs_evaluated, g.stats.brute_force_pairs / 4);
  expect_same_as_compute_grid(r, g);
}

TEST(SampleResultGrid, ClosedPolygonsAreSigned2D) {
  const Scene scene = make_scene(
      2, {make_circle("c", {0.3, 0.4, 0}, 0.2, 40), make_rect("r", {0.55, 0.2, 0}, {0.9, 0.7, 0}),
          make_segment("s", {0.1, 0.85, 0}, {0.8, 0.9, 0})});
  const GvdResult r = adaptive(scene);
  ResultGridOptions o;
  o.resolution = 60;
  const DistanceGrid g = sample_result_grid(r, o);
  EXPECT_EQ(g.closed, (std::vector<uint8_t>{1, 1, 0}));
  expect_exact(scene, g, {true, true, false});
  size_t negative = 0;
  for (double d : g.distance) negative += d < 0;
  EXPECT_GT(negative, 300u);  // the circle alone covers ~0.126 of the ~0.9 x 0.9 domain
  expect_same_as_compute_grid(r, g);
}

TEST(SampleResultGrid, ClosedMeshesAreSigned3D) {
  std::vector<SceneObject> objs;
  objs.push_back(make_sphere("ball", {0.3, 0.35, 0.4}, 0.22, 8, 12));
  objs.push_back(make_box("box", {0.6, 0.15, 0.15}, {0.9, 0.8, 0.65}));
  SceneObject fan;
  fan.label = "fan";
  fan.vertices = {{0.1, 0.8, 0.8}, {0.4, 0.9, 0.85}, {0.2, 0.95, 0.6}, {0.05, 0.7, 0.95}};
  fan.simplices = {{{0, 1, 2}}, {{0, 2, 3}}};
  objs.push_back(fan);
  const Scene scene = make_scene(3, std::move(objs));
  const GvdResult r = adaptive(scene);
  ResultGridOptions o;
  o.resolution = 14;
  const DistanceGrid g = sample_result_grid(r, o);
  EXPECT_EQ(g.spec.cell_count(), 14u * 14u * 14u);
  expect_exact(scene, g, {true, true, false});
  expect_same_as_compute_grid(r, g);
}

TEST(SampleResultGrid, ManhattanAndChebyshevAreExact) {
  const Scene flat = scattered_segments(25, 4);
  const GvdResult r2 = adaptive(flat);
  std::vector<SceneObject> objs;
  objs.push_back(make_box("a", {0.1, 0.1, 0.1}, {0.4, 0.35, 0.3}));
  SceneObject tri;
  tri.label = "tilted";
  tri.vertices = {{0.6, 0.2, 0.7}, {0.9, 0.6, 0.5}, {0.5, 0.9, 0.9}};
  tri.simplices = {{{0, 1, 2}}};
  objs.push_back(tri);
  objs.push_back(make_sphere("b", {0.3, 0.7, 0.6}, 0.15, 3, 4));
  const Scene solid = make_scene(3, std::move(objs));
  const GvdResult r3 = adaptive(solid);
  for (GridMetric m : {GridMetric::kL1, GridMetric::kLinf}) {
    ResultGridOptions o;
    o.metric = m;
    o.resolution = 24;
    const DistanceGrid g2 = sample_result_grid(r2, o);
    expect_exact(flat, g2, std::vector<bool>(flat.objects.size(), false));
    expect_same_as_compute_grid(r2, g2);
    o.resolution = 6;
    const DistanceGrid g3 = sample_result_grid(r3, o);
    expect_exact(solid, g3, {true, false, true});
    expect_same_as_compute_grid(r3, g3);
  }
}

TEST(SampleResultGrid, ASavedResultSamplesLikeTheComputedOne) {
  // A loaded result has no per-leaf vertex lists and a rebuilt vertex index: same grid.
  const Scene scene = scattered_segments(30, 21);
  const GvdResult r = adaptive(scene);
  const GvdResult loaded = load_result_bytes(result_to_bytes(r));
  ResultGridOptions o;
  o.resolution = 50;
  const DistanceGrid a = sample_result_grid(r, o);
  const DistanceGrid b = sample_result_grid(loaded, o);
  EXPECT_EQ(a.label, b.label);
  EXPECT_EQ(a.distance, b.distance);
  EXPECT_EQ(b.stats.octree_bounded, b.spec.cell_count());
}

TEST(SampleResultGrid, TwoPointsGiveTheirBisector) {
  // Analytic: two tiny segments; the label flips exactly at the bisector x = 0.5, and the
  // distance is the distance to the nearer one.
  const Scene scene = make_scene(2, {make_segment("l", {0.2, 0.5, 0}, {0.2, 0.5001, 0}),
                                     make_segment("r", {0.8, 0.5, 0}, {0.8, 0.5001, 0})});
  const GvdResult r = adaptive(scene);
  ResultGridOptions o;
  o.resolution = 50;
  o.box = Box{{0, 0, 0}, {1, 1, 0}};
  const DistanceGrid g = sample_result_grid(r, o);
  for (int j = 0; j < g.spec.n[1]; ++j) {
    for (int i = 0; i < g.spec.n[0]; ++i) {
      const size_t c = static_cast<size_t>(j) * g.spec.n[0] + i;
      ASSERT_EQ(g.label[c], i < 25 ? 0 : 1) << i << "," << j;
      const Vec3 p = g.spec.centre(i, j, 0);
      const double x = i < 25 ? 0.2 : 0.8;
      const double y = std::clamp(p.y, 0.5, 0.5001);
      ASSERT_NEAR(g.distance[c], std::hypot(p.x - x, p.y - y), 1e-12);
    }
  }
}

TEST(SampleResultGrid, BadInputIsAClearError) {
  const GvdResult r = adaptive(scattered_segments(3, 1));
  ResultGridOptions o;
  o.resolution = 0;
  EXPECT_THROW(sample_result_grid(r, o), Error);
  o.resolution = 100000;
  o.max_cells = 1000000;
  try {
    make_result_grid_spec(r, o);
    ADD_FAILURE() << "no error for too many cells";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kLimitExceeded);
  }
  o = {};
  o.box = Box{{0.5, 0.5, 0}, {0.6, 0.6, 0}};  // does not hold the vertices
  EXPECT_THROW(sample_result_grid(r, o), Error);
  GvdResult empty;
  empty.scene.dimension = 2;
  try {
    sample_result_grid(empty, {});
    ADD_FAILURE() << "no error for a result without objects";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidScene);
  }
}

}  // namespace
}  // namespace gvd
