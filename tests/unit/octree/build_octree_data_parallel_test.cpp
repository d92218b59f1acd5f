// The data-parallel octree build (draft: Karras vertex octree, smallest containing cells,
// conflict cells refined; then the engine's buffer rule and balance) against the
// level-synchronous CPU build: the same leaves, objects and leaf -> simplex lists on small
// scenes, and the separation properties on its own.

#include "gvd/octree/build_octree_data_parallel.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "gvd/common/error.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/octree/build_octree.h"
#include "gvd/octree/contacts.h"
#include "support/scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::octree;

namespace {

struct Case {
  Scene scene;
  UnitGeometry geometry;
};

Case make_case(Scene scene) {
  Case c{std::move(scene), {}};
  c.geometry = make_unit_geometry(c.scene, make_domain(c.scene));
  return c;
}

// Same leaves as build_octree, with the same objects and simplices; returns the DP octree.
Octree expect_same_as_cpu(const UnitGeometry& g, OctreeOptions o = {}) {
  o.threads = 2;
  LeafSimplices cpu_simplices, dp_simplices;
  const Octree cpu = build_octree(g, o, &cpu_simplices);
  DataParallelBuildStats stats;
  const Octree dp = build_octree_data_parallel(g, o, nullptr, &stats, &dp_simplices);
  EXPECT_EQ(dp.code.size(), cpu.code.size());
  EXPECT_EQ(dp.code, cpu.code);
  EXPECT_EQ(dp.level, cpu.level);
  EXPECT_EQ(dp.object, cpu.object);
  EXPECT_EQ(dp_simplices.begin, cpu_simplices.begin);
  EXPECT_EQ(dp_simplices.index, cpu_simplices.index);
  EXPECT_EQ(dp.depth, cpu.depth);
  EXPECT_GE(stats.resolved_leaves, stats.vertex_octree_leaves - stats.conflict_cells);
  return dp;
}

// No leaf above the depth limit touches two objects; face-adjacent non-empty leaves hold the
// same object (SHOULD_SUBDIVIDE's buffer cell); leaves tile the domain.
void expect_separated(const Octree& t) {
  double volume = 0;
  for (uint32_t i = 0; i < t.leaf_count(); ++i) {
    volume += std::pow(std::ldexp(1.0, -t.level[i]), t.dimension);
    if (t.level[i] < t.max_depth) {
      ASSERT_NE(t.object[i], kManyObjects) << "leaf " << i;
    }
    if (t.object[i] == kNoObject || t.level[i] >= t.max_depth) continue;
    const Box box = t.box(i);
    const double h = box.hi.x - box.lo.x;
    for (int a = 0; a < t.dimension; ++a)
      for (int s = -1; s <= 1; s += 2) {
        Vec3 p = box.center();
        p[a] += s * (0.5 * h + 1e-12);
        if (p[a] <= 0 || p[a] >= 1) continue;
        const uint32_t n = t.locate(p);
        if (t.object[n] == kNoObject || t.level[n] >= t.max_depth) continue;
        EXPECT_EQ(t.object[n], t.object[i]) << "face neighbours " << i << " and " << n;
      }
  }
  EXPECT_NEAR(volume, 1.0, 1e-12);
}

TEST(BuildOctreeDataParallel, SingleObjectAndEmptyScene) {
  using namespace test;
  const Case c = make_case(make_scene(2, {make_circle("a", {0, 0, 0}, 1, 16)}));
  const Octree t = expect_same_as_cpu(c.geometry);
  EXPECT_EQ(t.leaf_count(), 1u);
}

TEST(BuildOctreeDataParallel, TwoDimensionalScenesMatchTheCpuBuild) {
  using namespace test;
  for (const Scene& s : {make_scene(2, {make_circle("a", {0, 0, 0}, 1, 40),
                                        make_rect("b", {1.01, -0.5, 0}, {2, 0.5, 0})}),
                         make_scene(2, {make_gear2d("g1", {0, 0, 0}, 0.8, 1.0, 12, 0.0),
                                        make_gear2d("g2", {2.02, 0, 0}, 0.8, 1.0, 12, 0.26),
                                        make_segment("s", {-1, 1.3, 0}, {3, 1.3, 0})})}) {
    const Case c = make_case(s);
    expect_separated(expect_same_as_cpu(c.geometry));
  }
}

TEST(BuildOctreeDataParallel, ThreeDimensionalScenesMatchTheCpuBuild) {
  using namespace test;
  for (const Scene& s :
       {make_scene(3, {make_sphere("s1", {0, 0, 0}, 1.0, 8, 16),
                       make_sphere("s2", {2.05, 0, 0}, 1.0, 8, 16)}),
        make_scene(3, {make_point3("p", {0.5, 0.5, 0.5}), make_box("b1", {0, 0, 0}, {1, 1, 0.3}),
                       make_sphere("s", {0.5, 0.5, 0.9}, 0.2, 6, 10)})}) {
    const Case c = make_case(s);
    expect_separated(expect_same_as_cpu(c.geometry));
  }
}

// Gaps below the finest cell: conflict cells are refined to the depth limit, touching pairs
// only to the contact depth.
TEST(BuildOctreeDataParallel, DeepestLevelAndContactsMatchTheCpuBuild) {
  using namespace test;
  const Case c = make_case(make_scene(
      3, {make_box("b1", {0, 0, 0}, {1, 1, 0.5}), make_box("b2", {0.2, 0.2, 0.5}, {0.8, 0.8, 1.0}),
          make_sphere("s", {1.6, 0.5, 0.5}, 0.3, 6, 10)}));
  OctreeOptions o;
  o.max_depth = 9;
  expect_same_as_cpu(c.geometry, o);  // without contacts: b1/b2 refined to the limit
  const SimplexBvh bvh(3, c.geometry.points, c.geometry.simplices);
  const ContactPairs contacts =
      find_contact_pairs(c.geometry, bvh, 2.0 * std::sqrt(3.0) * std::ldexp(1.0, -9), 2);
  ASSERT_FALSE(contacts.empty());
  o.contacts = &contacts;
  o.contact_depth = 5;
  expect_same_as_cpu(c.geometry, o);
}

// Many small random triangles of several objects, some nearly touching.
TEST(BuildOctreeDataParallel, RandomTrianglesMatchTheCpuBuild) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0, 1), off(-0.04, 0.04);
  std::vector<SceneObject> objects;
  for (int o = 0; o < 6; ++o) {
    SceneObject obj;
    obj.label = "o" + std::to_string(o);
    const Vec3 c{u(rng), u(rng), u(rng)};
    for (int k = 0; k < 20; ++k) {
      const Vec3 b = c + Vec3{off(rng), off(rng), off(rng)} * 3.0;
      const uint32_t base = static_cast<uint32_t>(obj.vertices.size());
      for (int v = 0; v < 3; ++v) obj.vertices.push_back(b + Vec3{off(rng), off(rng), off(rng)});
      obj.simplices.push_back({{base, base + 1, base + 2}});
    }
    objects.push_back(std::move(obj));
  }
  const Case c = make_case(test::make_scene(3, std::move(objects)));
  OctreeOptions o;
  o.max_depth = 10;
  expect_same_as_cpu(c.geometry, o);
}

TEST(BuildOctreeDataParallel, LeafLimitIsEnforced) {
  using namespace test;
  const Case c = make_case(
      make_scene(2, {make_circle("a", {0, 0, 0}, 1, 40), make_circle("b", {2.0001, 0, 0}, 1, 40)}));
  OctreeOptions o;
  o.max_leaves = 50;
  EXPECT_THROW(build_octree_data_parallel(c.geometry, o), Error);
}

}  // namespace
}  // namespace gvd
