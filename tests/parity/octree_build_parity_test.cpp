// Parity of the data-parallel octree build kernels (kernels/cl/octree_build.cl) with their
// CPU twins: vertex Morton keys, the Karras radix tree, smallest containing cells, the
// two-pass facet lists, and the whole data-parallel build (whose leaves must also equal
// build_octree's). Exact: integer results, and overlap tests from one shared source.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <random>

#include "gvd/common/radix_sort.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/octree/build_octree.h"
#include "gvd/octree/build_octree_data_parallel.h"
#include "gvd/octree/contacts.h"
#include "parity/opencl_env.h"
#include "support/scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::octree;

namespace {

UnitGeometry geometry_of(const Scene& s) { return make_unit_geometry(s, make_domain(s)); }

// Random triangles (3D) or segments (2D) of several objects, some vertices repeated and some
// on the finest lattice, plus degenerate simplices.
Scene random_scene(int dim, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1), off(-0.05, 0.05);
  std::vector<SceneObject> objects;
  for (int o = 0; o < 5; ++o) {
    SceneObject obj;
    obj.label = "o" + std::to_string(o);
    const Vec3 c{u(rng), u(rng), dim == 3 ? u(rng) : 0.0};
    for (int k = 0; k < 25; ++k) {
      const uint32_t base = static_cast<uint32_t>(obj.vertices.size());
      const Vec3 b = c + Vec3{off(rng), off(rng), dim == 3 ? off(rng) : 0.0} * 2.0;
      for (int v = 0; v < dim; ++v)
        obj.vertices.push_back(b + Vec3{off(rng), off(rng), dim == 3 ? off(rng) : 0.0});
      Simplex s;
      for (int v = 0; v < dim; ++v) s.v[v] = base + static_cast<uint32_t>(v);
      obj.simplices.push_back(s);
      if (k % 5 == 0) {  // a simplex sharing a vertex with the previous one
        Simplex t = s;
        t.v[0] = base + 1;
        t.v[1] = base;
        obj.simplices.push_back(t);
      }
    }
    objects.push_back(std::move(obj));
  }
  return test::make_scene(dim, std::move(objects));
}

void expect_steps_agree(kernels::OpenClBackend& backend, const UnitGeometry& g, int max_level) {
  const auto twin = make_cpu_octree_build_steps(g, 2);
  const auto ocl = backend.octree_build_steps(g);
  ASSERT_NE(ocl, nullptr);
  std::vector<uint64_t> keys = twin->vertex_keys(max_level);
  EXPECT_EQ(keys, ocl->vertex_keys(max_level));
  radix_sort(keys, [](uint64_t k) { return k; });
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  std::vector<item::GvdRadixNode> na, nb;
  std::vector<int32_t> pa, pb;
  twin->radix_tree(keys, g.dimension * max_level, na, pa);
  ocl->radix_tree(keys, g.dimension * max_level, nb, pb);
  ASSERT_EQ(na.size(), nb.size());
  EXPECT_EQ(0, na.empty() ? 0 : std::memcmp(na.data(), nb.data(), na.size() * sizeof(na[0])));
  EXPECT_EQ(pa, pb);
  // Every internal node but the root has a parent, and the ranges nest.
  for (size_t i = 1; i < na.size(); ++i) {
    ASSERT_GE(pa[i], 0) << "node " << i;
    const auto& p = na[static_cast<size_t>(pa[i])];
    EXPECT_LE(p.first, na[i].first);
    EXPECT_GE(p.last, na[i].last);
    EXPECT_LT(p.prefix, na[i].prefix);
  }
  std::vector<uint32_t> ba, bb;
  std::vector<uint64_t> ca, cb;
  std::vector<int32_t> la, lb;
  twin->facet_cells(max_level, ba, ca, la);
  ocl->facet_cells(max_level, bb, cb, lb);
  EXPECT_EQ(ba, bb);
  EXPECT_EQ(ca, cb);
  EXPECT_EQ(la, lb);
  // Each simplex is stored in 1 .. 2^D cells.
  for (size_t s = 0; s + 1 < ba.size(); ++s) {
    EXPECT_GE(ba[s + 1] - ba[s], 1u);
    EXPECT_LE(ba[s + 1] - ba[s], 1u << g.dimension);
  }
}

void expect_builds_agree(kernels::OpenClBackend& backend, const UnitGeometry& g, OctreeOptions o) {
  o.threads = 2;
  const auto steps = backend.octree_build_steps(g);
  DataParallelBuildStats sa, sb;
  LeafSimplices twin_simplices, ocl_simplices;
  const Octree twin = build_octree_data_parallel(g, o, nullptr, &sa, &twin_simplices);
  const Octree ocl = build_octree_data_parallel(g, o, steps.get(), &sb, &ocl_simplices);
  const Octree cpu = build_octree(g, o);
  EXPECT_EQ(twin.code, ocl.code);
  EXPECT_EQ(twin.level, ocl.level);
  EXPECT_EQ(twin.object, ocl.object);
  EXPECT_EQ(twin_simplices.begin, ocl_simplices.begin);
  EXPECT_EQ(twin_simplices.index, ocl_simplices.index);
  EXPECT_EQ(sa.vertex_octree_leaves, sb.vertex_octree_leaves);
  EXPECT_EQ(sa.conflict_cells, sb.conflict_cells);
  EXPECT_EQ(sa.resolved_leaves, sb.resolved_leaves);
  EXPECT_EQ(cpu.code, ocl.code) << "the data-parallel build differs from build_octree";
  EXPECT_EQ(cpu.level, ocl.level);
  EXPECT_EQ(cpu.object, ocl.object);
}

class OctreeBuildParity : public ::testing::TestWithParam<int> {};

TEST_P(OctreeBuildParity, RandomScenesStepByStepAndWhole) {
  GVD_REQUIRE_OPENCL(backend);
  const int dim = GetParam();
  for (uint64_t seed : {1u, 2u}) {
    const UnitGeometry g = geometry_of(random_scene(dim, seed));
    expect_steps_agree(*backend, g, dim == 3 ? 21 : 26);
    expect_steps_agree(*backend, g, 6);
    OctreeOptions o;
    o.max_depth = dim == 3 ? 9 : 14;
    expect_builds_agree(*backend, g, o);
  }
}

// Objects that touch (refined to the depth limit, or to the contact depth with contacts), a
// single object, a degenerate-only scene.
TEST_P(OctreeBuildParity, TouchingObjectsDeepestLevelAndDegenerateInput) {
  GVD_REQUIRE_OPENCL(backend);
  const int dim = GetParam();
  using namespace test;
  const Scene touching = dim == 3
                             ? make_scene(3, {make_box("a", {0, 0, 0}, {1, 1, 0.5}),
                                              make_box("b", {0.25, 0.25, 0.5}, {0.75, 0.75, 1}),
                                              make_point3("p", {1.5, 0.5, 0.5}, 1e-3)})
                             : make_scene(2, {make_rect("a", {0, 0, 0}, {1, 0.5, 0}),
                                              make_rect("b", {0.25, 0.5, 0}, {0.75, 1, 0}),
                                              make_segment("s", {1.2, 0, 0}, {1.2, 1, 0})});
  const UnitGeometry g = geometry_of(touching);
  expect_steps_agree(*backend, g, dim == 3 ? 21 : 26);
  OctreeOptions o;
  o.max_depth = dim == 3 ? 8 : 12;
  expect_builds_agree(*backend, g, o);
  const SimplexBvh bvh(dim, g.points, g.simplices);
  const ContactPairs contacts =
      find_contact_pairs(g, bvh, 2.0 * std::sqrt(double(dim)) * std::ldexp(1.0, -o.max_depth), 2);
  o.contacts = &contacts;
  o.contact_depth = 5;
  expect_builds_agree(*backend, g, o);
  const UnitGeometry single = geometry_of(make_scene(
      dim, {dim == 3 ? make_sphere("s", {0, 0, 0}, 1, 4, 6) : make_circle("c", {0, 0, 0}, 1, 8)}));
  expect_builds_agree(*backend, single, {});
}

INSTANTIATE_TEST_SUITE_P(Dim, OctreeBuildParity, ::testing::Values(2, 3),
                         [](const auto& p) { return std::to_string(p.param) + "D"; });

}  // namespace
}  // namespace gvd
