#include "gvd/octree/build_octree.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>

#include "gvd/common/error.h"
#include "gvd/common/flat_hash.h"
#include "gvd/geometry/primitives.h"
#include "gvd/octree/octree.h"
#include "support/scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::octree;

namespace {

struct Built {
  Scene scene;
  Domain domain;
  UnitGeometry geometry;
  Octree octree;
  LeafSimplices simplices;  ///< the build's, beside the octree
};

Built build(Scene scene, int max_depth = 0) {
  Built b{std::move(scene), {}, {}, {}, {}};
  b.domain = make_domain(b.scene);
  b.geometry = make_unit_geometry(b.scene, b.domain);
  OctreeOptions o;
  o.max_depth = max_depth;
  b.octree = build_octree(b.geometry, o, &b.simplices);
  return b;
}

// Leaves tile the domain: their volumes sum to 1, and locating each leaf's centre finds it.
void expect_tiles_domain(const Octree& t) {
  double volume = 0;
  for (uint32_t i = 0; i < t.leaf_count(); ++i) {
    volume += std::pow(std::ldexp(1.0, -t.level[i]), t.dimension);
    const Box b = t.box(i);
    ASSERT_EQ(t.locate(b.center()), i);
  }
  EXPECT_NEAR(volume, 1.0, 1e-12);
}

// No leaf below the depth limit touches two objects, and no two face-adjacent leaves hold
// different objects (the buffer cell of SHOULD_SUBDIVIDE).
void expect_separated(const Built& b) {
  const Octree& t = b.octree;
  const int dim = t.dimension;
  for (uint32_t i = 0; i < t.leaf_count(); ++i) {
    if (t.level[i] < t.max_depth) {
      ASSERT_NE(t.object[i], kManyObjects) << "leaf " << i;
    }
    if (t.object[i] == kNoObject) continue;
    // Sample points just outside each face centre, locate the neighbour.
    const Box box = t.box(i);
    const double h = box.hi.x - box.lo.x;
    for (int a = 0; a < dim; ++a) {
      for (int s = -1; s <= 1; s += 2) {
        Vec3 p = box.center();
        p[a] += s * (0.5 * h + 1e-12);
        if (p[a] <= 0 || p[a] >= 1) continue;
        const uint32_t n = t.locate(p);
        if (t.object[n] == kNoObject || t.level[n] >= t.max_depth || t.level[i] >= t.max_depth)
          continue;
        EXPECT_EQ(t.object[n], t.object[i]) << "face neighbours " << i << " and " << n;
      }
    }
  }
}

// Leaves sharing a face, edge or corner differ by at most one level.
void expect_balanced(const Octree& t) {
  const int dim = t.dimension;
  for (uint32_t i = 0; i < t.leaf_count(); ++i) {
    const Box box = t.box(i);
    const double h = box.hi.x - box.lo.x;
    const int kz = dim == 3 ? 1 : 0;
    for (int dz = -kz; dz <= kz; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          if (dx == 0 && dy == 0 && dz == 0) continue;
          // Probe just beyond the corner/edge/face, at a quarter of the cell size, so that
          // a finer neighbour is hit.
          Vec3 p = box.center() +
                   Vec3{dx * (0.5 * h + 1e-12), dy * (0.5 * h + 1e-12), dz * (0.5 * h + 1e-12)};
          bool inside = true;
          for (int a = 0; a < dim; ++a) inside &= p[a] > 0 && p[a] < 1;
          if (!inside) continue;
          const uint32_t n = t.locate(p);
          EXPECT_LE(std::abs(int{t.level[n]} - int{t.level[i]}), 1) << i << " vs " << n;
        }
  }
}

// Conservative incidence: every simplex is listed in every leaf its exact bounding region
// touches — checked by sampling points on the simplex and locating them.
void expect_incidence_complete(const Built& b) {
  const Octree& t = b.octree;
  const UnitGeometry& g = b.geometry;
  ASSERT_TRUE(b.simplices.covers(t.leaf_count()));
  for (uint32_t s = 0; s < g.simplices.size(); ++s) {
    const Simplex& x = g.simplices[s];
    for (int k = 0; k <= 10; ++k) {
      for (int m = 0; m + k <= 10; ++m) {
        const double u = k / 10.0, v = m / 10.0;
        Vec3 p = g.points[x.v[0]] * (1 - u - v) + g.points[x.v[1]] * u;
        if (g.dimension == 3)
          p = p + g.points[x.v[2]] * v;
        else if (m > 0)
          continue;
        const uint32_t leaf = t.locate(p);
        bool found = false;
        for (const uint32_t q : b.simplices.of(leaf)) found |= q == s;
        ASSERT_TRUE(found) << "simplex " << s << " missing from leaf " << leaf;
      }
    }
  }
}

TEST(BuildOctree, SingleObjectIsOneLeaf) {
  auto b = build(test::make_scene(3, {test::make_sphere("a", {0, 0, 0}, 1)}));
  EXPECT_EQ(b.octree.leaf_count(), 1u);
  EXPECT_EQ(b.octree.object[0], 0u);
  expect_tiles_domain(b.octree);
}

TEST(BuildOctree, TwoCirclesSeparatedWithBuffer2D) {
  auto b = build(test::make_scene(
      2, {test::make_circle("a", {0, 0, 0}, 1), test::make_circle("b", {2.001, 0, 0}, 1)}));
  expect_tiles_domain(b.octree);
  expect_separated(b);
  expect_balanced(b.octree);
  expect_incidence_complete(b);
  // The gap is 1e-3 of ~3 units: depth must reach about log2(3.2 / 1e-3) ~ 12.
  EXPECT_GE(b.octree.depth, 11);
  EXPECT_LT(b.octree.depth, 16);
}

TEST(BuildOctree, SpheresSeparatedWithBuffer3D) {
  auto b = build(test::make_scene(
      3, {test::make_sphere("a", {0, 0, 0}, 1), test::make_sphere("b", {2.01, 0, 0}, 1),
          test::make_sphere("c", {1, 1.8, 0}, 1)}));
  expect_tiles_domain(b.octree);
  expect_separated(b);
  expect_balanced(b.octree);
  expect_incidence_complete(b);
}

TEST(BuildOctree, IntersectingObjectsStopAtTheDepthLimit) {
  auto b = build(test::make_scene(2, {test::make_rect("a", {0, 0, 0}, {1, 1, 0}),
                                      test::make_rect("b", {0.5, 0.5, 0}, {1.5, 1.5, 0})}),
                 10);
  EXPECT_EQ(b.octree.depth, 10);
  size_t many = 0;
  for (uint32_t i = 0; i < b.octree.leaf_count(); ++i) {
    if (b.octree.object[i] == kManyObjects) {
      ++many;
      EXPECT_EQ(b.octree.level[i], 10);
    }
  }
  EXPECT_GT(many, 0u);
  expect_tiles_domain(b.octree);
  expect_balanced(b.octree);
}

// The leaf limit bounds cells, not the simplex lists they hold: 200 coincident tetrahedra put
// hundreds of simplices in every cell they touch. The lists are bounded by the same option
// (kReferencesPerLeaf per leaf of max_leaves): the build stops with a limit error that says
// so while the leaves are still far under their limit. Two tetrahedra build at the same
// limits.
TEST(BuildOctree, ManyObjectsSharingCellsHitTheReferenceLimit) {
  auto tetrahedra = [](int copies) {
    std::vector<SceneObject> objects;
    for (int i = 0; i < copies; ++i) {
      SceneObject o;
      o.label = "t" + std::to_string(i);
      o.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
      o.simplices = {{{0, 1, 2}}, {{0, 1, 3}}, {{0, 2, 3}}, {{1, 2, 3}}};
      objects.push_back(o);
    }
    Scene scene = test::make_scene(3, objects);
    Built b{std::move(scene), {}, {}, {}, {}};
    b.domain = make_domain(b.scene);
    b.geometry = make_unit_geometry(b.scene, b.domain);
    return b;
  };
  OctreeOptions o;
  o.max_depth = 5;
  o.max_leaves = 20000;
  Built two = tetrahedra(2);
  LeafSimplices small_simplices;
  const Octree small = build_octree(two.geometry, o, &small_simplices);
  EXPECT_LT(small.leaf_count(), o.max_leaves);
  EXPECT_LE(small_simplices.index.size(), kReferencesPerLeaf * o.max_leaves);
  Built many = tetrahedra(200);
  try {
    (void)build_octree(many.geometry, o);
    FAIL() << "no limit error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kLimitExceeded);
    EXPECT_NE(std::string(e.what()).find("simplex references"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("many objects share cells"), std::string::npos)
        << e.what();
  }
}

TEST(BuildOctree, SizeGrowsWithClosePlacesNotTriangles) {
  // Same two spheres, 16x more triangles: the leaf count must not grow with the mesh.
  auto coarse = build(test::make_scene(3, {test::make_sphere("a", {0, 0, 0}, 1, 8, 16),
                                           test::make_sphere("b", {3, 0, 0}, 1, 8, 16)}));
  auto fine = build(test::make_scene(3, {test::make_sphere("a", {0, 0, 0}, 1, 32, 64),
                                         test::make_sphere("b", {3, 0, 0}, 1, 32, 64)}));
  EXPECT_LT(fine.octree.leaf_count(), 2 * coarse.octree.leaf_count() + 64);
}

TEST(BuildOctree, RefineSplitsAndRebalances) {
  auto b = build(test::make_scene(
      2, {test::make_circle("a", {0, 0, 0}, 1), test::make_circle("b", {2.5, 0, 0}, 1)}));
  const uint32_t leaf = b.octree.locate({0.5, 0.5, 0});
  const int before = b.octree.level[leaf];
  std::vector<CellRef> split{cell_of(b.octree, leaf)};
  Octree r = refine_octree(b.octree, b.simplices, b.geometry, split);
  EXPECT_EQ(r.level[r.locate({0.5, 0.5, 0})], before + 1);
  expect_tiles_domain(r);
  expect_balanced(r);
}

TEST(BuildOctree, ManyRefinementsStayBalancedTiledAndComplete) {
  for (int dim : {2, 3}) {
    auto b =
        build(dim == 2 ? test::make_scene(2, {test::make_circle("a", {0, 0, 0}, 1),
                                              test::make_circle("b", {2.05, 0, 0}, 1)})
                       : test::make_scene(3, {test::make_sphere("a", {0, 0, 0}, 1, 8, 16),
                                              test::make_sphere("b", {2.05, 0, 0}, 1, 8, 16)}));
    // Every seventh leaf, plus a cell three levels inside another leaf (its ancestors and the
    // balance they need must follow).
    std::vector<CellRef> split;
    for (uint32_t l = 0; l < b.octree.leaf_count(); l += 7) split.push_back(cell_of(b.octree, l));
    const uint32_t host = b.octree.locate({0.9, 0.9, dim == 3 ? 0.9 : 0.0});
    CellRef deep = cell_of(b.octree, host);
    for (int k = 0; k < 3; ++k) deep = child_cell(dim, deep, (1u << dim) - 1);
    split.push_back(deep);
    LeafSimplices simplices;
    const Octree r = refine_octree(b.octree, b.simplices, b.geometry, split, {}, {}, &simplices);
    expect_tiles_domain(r);
    expect_balanced(r);
    Built refined{b.scene, b.domain, b.geometry, r, std::move(simplices)};
    expect_incidence_complete(refined);
    for (const CellRef& c : split) {
      if (c.level >= r.max_depth) continue;
      const uint32_t leaf = r.locate_lattice(lattice::morton_decode(dim, c.code));
      EXPECT_GT(r.level[leaf], c.level) << "a requested cell was not split";
    }
  }
}

TEST(BuildOctree, RefinementIsTheSameOnOneAndTwoThreads) {
  // Big enough (> 4096 leaves) for the copy to run in several parallel chunks.
  auto b = build(test::make_scene(3, {test::make_sphere("a", {0, 0, 0}, 1, 8, 16),
                                      test::make_sphere("b", {2.002, 0, 0}, 1, 8, 16)}));
  ASSERT_GT(b.octree.leaf_count(), 4096u);
  std::vector<CellRef> split;
  for (uint32_t l = 0; l < b.octree.leaf_count(); l += 5) split.push_back(cell_of(b.octree, l));
  OctreeOptions one, two;
  one.threads = 1;
  two.threads = 2;
  LeafSimplices s1, s2;
  const Octree r1 = refine_octree(b.octree, b.simplices, b.geometry, split, one, {}, &s1);
  const Octree r2 = refine_octree(b.octree, b.simplices, b.geometry, split, two, {}, &s2);
  EXPECT_GT(r1.leaf_count(), b.octree.leaf_count());
  EXPECT_EQ(r1.code, r2.code);
  EXPECT_EQ(r1.level, r2.level);
  EXPECT_EQ(r1.object, r2.object);
  EXPECT_EQ(s1.begin, s2.begin);
  EXPECT_EQ(s1.index, s2.index);
  EXPECT_EQ(r1.depth, r2.depth);
  expect_tiles_domain(r2);
  expect_balanced(r2);
  Built refined{b.scene, b.domain, b.geometry, r2, std::move(s2)};
  expect_incidence_complete(refined);
  // The leaf limit holds during refinement too.
  two.max_leaves = b.octree.leaf_count() + 10;
  try {
    refine_octree(b.octree, b.simplices, b.geometry, split, two);
    FAIL() << "expected a limit error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kLimitExceeded);
  }
}

TEST(BuildOctree, LeafLocatorAgreesWithLocate) {
  for (int dim : {2, 3}) {
    auto b =
        build(dim == 2 ? test::make_scene(2, {test::make_circle("a", {0, 0, 0}, 1),
                                              test::make_circle("b", {2.001, 0, 0}, 1)})
                       : test::make_scene(3, {test::make_sphere("a", {0, 0, 0}, 1, 8, 16),
                                              test::make_sphere("b", {2.002, 0, 0}, 1, 8, 16)}));
    const LeafLocator locator(b.octree);
    std::mt19937_64 rng(dim);
    const uint64_t side = lattice::side_units(dim);
    for (int i = 0; i < 20000; ++i) {
      lattice::Coord p;
      for (int a = 0; a < dim; ++a) p.c[a] = static_cast<uint32_t>(rng() % side);
      if (i < 64) {  // the domain's corners and edges
        for (int a = 0; a < dim; ++a) p.c[a] = (i >> a) & 1 ? static_cast<uint32_t>(side - 1) : 0;
      }
      ASSERT_EQ(locator.locate_lattice(p), b.octree.locate_lattice(p)) << "query " << i;
    }
    // Every leaf's own corner finds it.
    for (uint32_t l = 0; l < b.octree.leaf_count(); ++l)
      ASSERT_EQ(locator.locate_lattice(b.octree.corner(l)), l);
  }
}

TEST(BuildOctree, LeafLimitIsEnforced) {
  Built b{test::make_scene(
              2, {test::make_circle("a", {0, 0, 0}, 1), test::make_circle("b", {2.0001, 0, 0}, 1)}),
          {},
          {},
          {}};
  b.domain = make_domain(b.scene);
  b.geometry = make_unit_geometry(b.scene, b.domain);
  OctreeOptions o;
  o.max_leaves = 50;
  try {
    build_octree(b.geometry, o);
    FAIL() << "expected a limit error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kLimitExceeded);
  }
}

TEST(Lattice, MortonRoundTrips) {
  for (int dim : {2, 3}) {
    const uint32_t maxc = (1u << lattice_bits(dim)) - 1;
    for (uint32_t x : {0u, 1u, 12345u, maxc}) {
      lattice::Coord c{{x, maxc - x, dim == 3 ? x / 3 : 0}};
      const lattice::Coord d = lattice::morton_decode(dim, lattice::morton(dim, c));
      EXPECT_EQ(d.c[0], c.c[0]);
      EXPECT_EQ(d.c[1], c.c[1]);
      EXPECT_EQ(d.c[2], c.c[2]);
      const lattice::Coord e = lattice::vertex_coord(dim, lattice::vertex_key(dim, c));
      EXPECT_EQ(e.c[0], c.c[0]);
      EXPECT_EQ(e.c[2], c.c[2]);
    }
  }
}

}  // namespace
}  // namespace gvd
