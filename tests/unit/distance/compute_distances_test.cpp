#include "gvd/distance/compute_distances.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "gvd/distance/distance_field.h"
#include "gvd/octree/build_octree.h"
#include "support/oracles.h"
#include "support/scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::distance;

namespace {

struct Setup {
  Scene scene;
  Domain domain;
  UnitGeometry geometry;
  SimplexBvh bvh;
  Octree octree;
  LeafSimplices simplices;  ///< the build's (the wavefront bounds its searches with them)
};

std::unique_ptr<Setup> setup(Scene scene) {
  auto s = std::make_unique<Setup>();
  s->scene = std::move(scene);
  s->domain = make_domain(s->scene);
  s->geometry = make_unit_geometry(s->scene, s->domain);
  s->bvh = SimplexBvh(s->geometry.dimension, s->geometry.points, s->geometry.simplices);
  s->octree = build_octree(s->geometry, {}, &s->simplices);
  return s;
}

// Both methods: kExact (the default) and the paper's wavefront.
class ComputeDistancesMethod : public ::testing::TestWithParam<DistanceMethod> {
 protected:
  DistanceOptions options(const gvd::Setup& s) const {
    DistanceOptions o;
    o.method = GetParam();
    o.leaf_simplices = &s.simplices;
    return o;
  }
};

INSTANTIATE_TEST_SUITE_P(Methods, ComputeDistancesMethod,
                         ::testing::Values(DistanceMethod::kExact, DistanceMethod::kWavefront),
                         [](const auto& method) {
                           return method.param == DistanceMethod::kExact ? "Exact" : "Wavefront";
                         });

TEST_P(ComputeDistancesMethod, ExactVerticesMatchBruteForceAndOthersStayWithinThreeHalves) {
  auto s = setup(test::make_scene(2, {test::make_circle("a", {0, 0, 0}, 1, 40),
                                      test::make_rect("b", {1.01, -0.5, 0}, {2, 0.5, 0})}));
  const DistanceField f = compute_distances(s->octree, s->geometry, s->bvh, options(*s));
  size_t exact = 0;
  for (uint32_t v = 0; v < f.size(); ++v) {
    const Vec3 p = s->domain.from_unit(f.vertices.position(v));
    const auto truth = test::brute_nearest(s->scene, p);
    const double got = f.distance(v) * s->domain.side;
    EXPECT_GE(got, truth.distance - 1e-12);
    EXPECT_LE(got, 1.5 * truth.distance + 1e-12);
    if (f.exact[v]) {
      EXPECT_NEAR(got, truth.distance, 1e-12);
      ++exact;
    }
  }
  EXPECT_GT(exact, 0u);
  if (GetParam() == DistanceMethod::kExact) {
    EXPECT_EQ(exact, f.size());
  }
}

TEST(ComputeDistances, ExactMethodAgreesWithBruteForceOnEveryVertexIn3d) {
  auto s = setup(test::make_scene(3, {test::make_sphere("a", {0, 0, 0}, 1, 8, 16),
                                      test::make_box("b", {1.05, -0.5, -0.5}, {2, 0.5, 0.5})}));
  const DistanceField f = compute_distances(s->octree, s->geometry, s->bvh);
  for (uint32_t v = 0; v < f.size(); ++v) {
    const Vec3 p = s->domain.from_unit(f.vertices.position(v));
    const auto truth = test::brute_nearest(s->scene, p);
    EXPECT_EQ(f.exact[v], 1);
    EXPECT_NEAR(f.distance(v) * s->domain.side, truth.distance, 1e-12) << "vertex " << v;
    if (truth.second_distance > truth.distance * (1 + 1e-9)) {
      EXPECT_EQ(f.label[v], truth.object) << "vertex " << v;
    }
  }
}

TEST_P(ComputeDistancesMethod, IncrementalRefinementEqualsAFullRecomputation) {
  // threads 1: one worker takes every chunk of leaves at once (the consumed field's lists,
  // grown in place, must not assume a chunk per grain).
  for (const auto& [dim, threads] : {std::pair{2, 0}, {3, 0}, {2, 1}, {3, 1}}) {
    SCOPED_TRACE("dim " + std::to_string(dim) + ", threads " + std::to_string(threads));
    auto s =
        setup(dim == 2 ? test::make_scene(2, {test::make_circle("a", {0, 0, 0}, 1, 32),
                                              test::make_circle("b", {2.01, 0, 0}, 1, 32),
                                              test::make_circle("c", {1, 1.8, 0}, 0.7, 32)})
                       : test::make_scene(3, {test::make_sphere("a", {0, 0, 0}, 1, 8, 16),
                                              test::make_sphere("b", {2.02, 0, 0}, 1, 8, 16)}));
    DistanceOptions o = options(*s);
    o.threads = threads;
    LeafVertices first_lists;
    const DistanceField first = compute_distances(s->octree, s->geometry, s->bvh, o, &first_lists);
    // Split every fifth leaf.
    std::vector<CellRef> splits;
    for (uint32_t l = 0; l < s->octree.leaf_count(); l += 5)
      splits.push_back(cell_of(s->octree, l));
    LeafSimplices refined_simplices;
    const Octree refined =
        refine_octree(s->octree, s->simplices, s->geometry, splits, {}, {}, &refined_simplices);
    o.leaf_simplices = &refined_simplices;
    LeafVertices incremental_lists, full_lists;
    DistanceField incremental = compute_distances(refined, s->geometry, s->bvh, o, first,
                                                  &s->octree, &first_lists, &incremental_lists);
    const DistanceField full =
        compute_distances(refined, s->geometry, s->bvh, o, first, nullptr, nullptr, &full_lists);
    // The overload that consumes the previous field and its lists gives the same field and
    // lists.
    LeafVertices consumed_lists = first_lists;
    const DistanceField consumed = compute_distances(
        refined, s->geometry, s->bvh, o, DistanceField(first), Octree(s->octree), consumed_lists);
    EXPECT_EQ(consumed.vertices.key, incremental.vertices.key);
    EXPECT_EQ(consumed.label, incremental.label);
    EXPECT_EQ(consumed.point, incremental.point);
    EXPECT_EQ(consumed_lists.vertex, incremental_lists.vertex);
    EXPECT_EQ(consumed_lists.slots, incremental_lists.slots);
    EXPECT_EQ(consumed_lists.begin, incremental_lists.begin);
    // (The exact method extends the consumed field's arrays in place.)
    EXPECT_TRUE(consumed.closest == incremental.closest);
    EXPECT_EQ(consumed.exact, incremental.exact);
    EXPECT_EQ(consumed.changed, incremental.changed);
    for (uint32_t v = 0; v < consumed.size(); ++v)
      ASSERT_EQ(consumed.vertices.find(consumed.vertices.key[v]), v);
    ASSERT_EQ(incremental.size(), full.size());
    sort_vertices(incremental, &incremental_lists);
    for (uint32_t v = 0; v < full.size(); ++v) {
      ASSERT_EQ(incremental.vertices.key[v], full.vertices.key[v]);
      EXPECT_EQ(incremental.label[v], full.label[v]) << "vertex " << v;
      EXPECT_EQ(incremental.exact[v], full.exact[v]) << "vertex " << v;
      EXPECT_EQ(incremental.closest[incremental.point[v]], full.closest[full.point[v]]);
    }
    // Each leaf's row, after the update and the renumbering, is what looking its vertices up
    // by key finds.
    ASSERT_TRUE(incremental_lists.covers(refined.leaf_count()));
    ASSERT_TRUE(full_lists.covers(refined.leaf_count()));
    for (uint32_t l = 0; l < refined.leaf_count(); ++l) {
      const LeafGrid a = incremental_lists.grid(refined, incremental.vertices, l);
      const LeafGrid b = full_lists.grid(refined, full.vertices, l);
      ASSERT_NE(incremental_lists.slots[l], 0u) << "leaf " << l;
      ASSERT_EQ(a, b) << "leaf " << l;
      ASSERT_EQ(b, full.grid(refined, l)) << "leaf " << l;
    }
  }
}

}  // namespace
}  // namespace gvd
